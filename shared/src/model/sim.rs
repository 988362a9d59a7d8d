//! Fixed-step simulation of the motor (seed Eq. 1-5) with the optional effects.
//!
//! The linear part advances with the exact ZOH coefficients of [`crate::model::discretise`]. Each
//! nonlinear effect enters as an extra voltage or load torque evaluated at the start of the
//! step and held over it; Coulomb friction and brush drop are dead zones (stiction: the shaft
//! stays at rest until the drive torque exceeds `tc`; no current flows until the driving
//! voltage exceeds `vb`), handled by freezing the stuck state and advancing the other one
//! with its own exact first-order step. Tacho effects (delay, ripple) act on the reading only.
//! The state is kept as a compensated (two-sum) f32 pair so that slow modes at high sample
//! rates do not stall on f32 rounding.

use crate::error::Error;
use crate::model::discretise::Discrete;
use crate::model::effects::{
    armature_reaction, brush_drop, coulomb_friction, quadratic_load, sensor_delay, tacho_ripple,
};
use crate::model::params::ModelParams;
use crate::param_id::ParamId;

use crate::capacity::MAX_DELAY_SAMPLES;
const RING: usize = MAX_DELAY_SAMPLES + 2;
// Ring positions are bytes (a Simulator is copied a dozen times into every Jacobian).
const _: () = assert!(RING <= u8::MAX as usize);

/// Compensated f32 accumulator: `hi + lo` carries about twice the precision of one f32.
#[derive(Clone, Copy, Debug, Default)]
struct Compensated {
    hi: f32,
    lo: f32,
}

impl Compensated {
    fn new(v: f32) -> Self {
        Compensated { hi: v, lo: 0.0 }
    }
    /// Knuth's two-sum; exact because Rust never fuses or reassociates f32 operations.
    fn add(&mut self, d: f32) {
        let y = d + self.lo;
        let s = self.hi + y;
        let bp = s - self.hi;
        let err = (self.hi - (s - bp)) + (y - bp);
        self.hi = s;
        self.lo = err;
    }
    fn set(&mut self, v: f32) {
        self.hi = v;
        self.lo = 0.0;
    }
}

/// What drives a simulation over one step of a record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepInput {
    /// Armature voltage [V] (not applied with the bridge open).
    pub v: f32,
    /// Known load torque [N m].
    pub tl: f32,
    /// Measured rotor speed over the step, for the ripple angle (see [`Simulator::apply`]).
    pub measured_omega: Option<f32>,
    /// The bridge opens at the start of this step (the record's coast-down begins).
    pub opens: bool,
}

/// Initial condition of a simulation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct InitialState {
    /// Armature current [A].
    pub current: f32,
    /// Shaft speed [rad/s].
    pub omega: f32,
}

impl InitialState {
    /// Motor at rest, no current.
    pub const REST: InitialState = InitialState {
        current: 0.0,
        omega: 0.0,
    };
}

/// What the simulated sensors read at one sample instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Reading {
    /// Tacho reading [rad/s] (with sensor delay and ripple, if present).
    pub omega: f32,
    /// Armature current [A].
    pub current: f32,
}

/// Sign of `x` with 0 for 0.
pub(crate) fn sign(x: f32) -> f32 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// A dead zone on a state that may stick at zero (shaft speed under friction, current under
/// brush drop), with `opposition(direction)` the opposing term of the effect's entry for a
/// motion in `direction` (+1, -1; 0 gives 0). Returns the opposing term to apply over the
/// next step: `None` while the state stays stuck (the drive within the opposition), else
/// the opposition in the direction of motion (or, from rest, of the drive).
#[inline(always)]
fn dead_zone_opposition(
    value: f32,
    drive: f32,
    opposition: impl Fn(f32) -> f32,
    stuck: &mut bool,
) -> Option<f32> {
    if *stuck {
        let held = opposition(sign(drive));
        if drive.abs() <= held.abs() {
            return None;
        }
        *stuck = false;
        return Some(held);
    }
    let direction = if value != 0.0 {
        sign(value)
    } else {
        sign(drive)
    };
    Some(opposition(direction))
}

/// After a step with an opposing dead-zone term: a state that crossed zero sticks there.
fn stick_on_crossing(before: f32, opposition: f32, state: &mut Compensated, stuck: &mut bool) {
    let moving_dir = if before != 0.0 {
        sign(before)
    } else {
        sign(opposition)
    };
    if opposition != 0.0 && sign(state.hi) != moving_dir {
        state.set(0.0);
        *stuck = true;
    }
}

/// A running simulation of one parameter set at one sample step.
#[derive(Clone, Debug)]
pub struct Simulator {
    disc: Discrete,
    dt: f32,
    kv: f32,
    tc: f32,
    kq: f32,
    kar: f32,
    vb: f32,
    ripple_amp: f32,
    ripple_cycles: f32,
    ripple_phase: f32,
    /// Delay in samples, split into whole samples and fraction.
    delay_whole: u8,
    delay_frac: f32,
    /// The tacho reading lags (`delay_whole` or `delay_frac` non-zero): readings go
    /// through `ring`; otherwise the newest one is `tacho`.
    delayed: bool,
    /// No effect acts on the dynamics or the reading.
    linear: bool,
    /// `linear` and the bridge closed: [`Simulator::step`] takes the plain linear step (the
    /// same arithmetic as the general one with every effect at zero).
    plain: bool,
    /// No effect but Coulomb friction (if any): a turning shaft takes
    /// [`Simulator::step_friction`].
    friction_only: bool,
    /// The bridge is open (coast-down): no armature current, the voltage is not applied.
    open: bool,
    /// Newest tacho reading.
    tacho: f32,
    current: Compensated,
    omega: Compensated,
    /// Ripple angle `ripple_cycles * theta`, wrapped to [-pi, pi].
    psi: f32,
    shaft_stuck: bool,
    current_stuck: bool,
    ring: [f32; RING],
    head: u8,
    filled: u8,
}

impl Simulator {
    /// A simulator for `p` at step `dt`, starting from `init`.
    pub fn new(p: &ModelParams, dt: f32, init: InitialState) -> Result<Simulator, Error> {
        p.validate()?;
        let disc = Discrete::new(p, dt)?;
        let (delay_whole, delay_frac) =
            sensor_delay::in_samples(p.get(ParamId::Td), dt).ok_or(Error::DelayTooLong)?;
        let (tc, kq, kar, vb) = (
            p.get(ParamId::Tc),
            p.get(ParamId::Kq),
            p.get(ParamId::Kar),
            p.get(ParamId::Vb),
        );
        let ripple_amp = p.get(ParamId::RippleAmp);
        let delayed = delay_whole != 0 || delay_frac != 0.0;
        let friction_only = kq == 0.0 && kar == 0.0 && vb == 0.0 && ripple_amp == 0.0;
        let linear = tc == 0.0 && friction_only;
        let mut s = Simulator {
            disc,
            dt,
            kv: p.get(ParamId::Kv),
            tc,
            kq,
            kar,
            vb,
            ripple_amp,
            ripple_cycles: p.get(ParamId::RippleCycles),
            ripple_phase: p.get(ParamId::RipplePhase),
            delay_whole,
            delay_frac,
            delayed,
            linear,
            plain: linear,
            friction_only,
            open: false,
            tacho: 0.0,
            current: Compensated::new(0.0),
            omega: Compensated::new(0.0),
            psi: 0.0,
            shaft_stuck: false,
            current_stuck: false,
            ring: [0.0; RING],
            head: 0,
            filled: 0,
        };
        s.reset(init);
        Ok(s)
    }

    /// Restart from `init` with the same parameters.
    pub fn reset(&mut self, init: InitialState) {
        self.current = Compensated::new(init.current);
        self.omega = Compensated::new(init.omega);
        self.psi = 0.0;
        self.shaft_stuck = self.tc > 0.0 && init.omega == 0.0;
        self.current_stuck = self.vb > 0.0 && init.current == 0.0;
        self.open = false;
        self.plain = self.linear;
        self.head = 0;
        self.filled = 0;
        self.push_reading();
    }

    #[inline(always)]
    fn tacho_now(&self) -> f32 {
        tacho_ripple::reading(self.ripple_amp, self.ripple_phase, self.omega.hi, self.psi)
    }

    #[inline(always)]
    fn push_reading(&mut self) {
        self.push_tacho(self.tacho_now());
    }

    #[inline(always)]
    fn push_tacho(&mut self, tacho: f32) {
        self.tacho = tacho;
        if self.delayed {
            let head = (usize::from(self.head) + 1) % RING;
            self.ring[head] = self.tacho;
            self.head = head as u8;
            self.filled = (usize::from(self.filled) + 1).min(RING) as u8;
        }
    }

    fn ring_back(&self, n: usize) -> f32 {
        let n = n.min(usize::from(self.filled) - 1);
        self.ring[(usize::from(self.head) + RING - n) % RING]
    }

    /// What the sensors read now.
    #[inline(always)]
    pub fn reading(&self) -> Reading {
        let omega = if !self.delayed {
            self.tacho
        } else {
            let whole = usize::from(self.delay_whole);
            let a = self.ring_back(whole);
            let b = self.ring_back(whole + 1);
            sensor_delay::interpolate(a, b, self.delay_frac)
        };
        Reading {
            omega,
            current: self.current.hi,
        }
    }

    /// True when the tacho ripple follows the rotor angle: [`Simulator::apply`] then uses
    /// the measured speed it is given (otherwise it is ignored).
    pub fn tracks_angle(&self) -> bool {
        self.ripple_amp != 0.0
    }

    /// True shaft speed (no sensor effects).
    pub fn omega(&self) -> f32 {
        self.omega.hi
    }

    /// Open the bridge (a coast-down, see [`crate::model::record::Record::coast_from`]): from now on
    /// no armature current flows and the voltage given to the steps is not applied; the
    /// shaft obeys seed Eq. 4 with `i = 0` (viscous and Coulomb friction, load). The current
    /// is taken to vanish at once: in a real bridge it decays through the freewheel diodes
    /// against the bus voltage within `La/Ra ln(1 + Ra i / (Vbus + Kv w))`, a fraction of
    /// a sample at commissioning rates for the small current of a steady speed.
    pub fn open_circuit(&mut self) {
        self.open = true;
        self.plain = false;
        self.current.set(0.0);
        self.current_stuck = false;
    }

    /// Close the bridge again after [`Simulator::open_circuit`] (nothing changes when it is
    /// closed): the steps apply their voltage from zero current.
    pub fn close_circuit(&mut self) {
        if self.open {
            self.open = false;
            self.plain = self.linear;
            self.current_stuck = self.vb > 0.0;
        }
    }

    /// Advance one step with armature voltage `v` and known load torque `tl` held over it.
    pub fn advance(&mut self, v: f32, tl: f32) {
        self.step(v, tl, None);
    }

    /// Advance one step of a record with `input` (see [`crate::model::record::Record::step_input`]):
    /// the bridge opens first if the coast-down starts here, and the rotor angle of the
    /// tacho ripple advances by the *measured* speed when it is given (the ripple follows the
    /// real rotor, whose angle a fit integrating its own, slightly wrong, speed would lose
    /// after some thousand revolutions). Every loop that simulates a record steps through
    /// here, so none can miss the coast-down.
    #[inline(always)]
    pub fn apply(&mut self, input: &StepInput) {
        if input.opens {
            self.open_circuit();
        }
        self.step(input.v, input.tl, input.measured_omega);
    }

    #[inline(always)]
    fn step(&mut self, v: f32, tl: f32, measured_omega: Option<f32>) {
        if self.plain {
            self.step_plain(v, tl);
        } else {
            self.step_nonlinear(v, tl, measured_omega);
        }
    }

    /// Every step but the plain one: one copy of it in flash, however many fit loops call it.
    #[inline(never)]
    fn step_nonlinear(&mut self, v: f32, tl: f32, measured_omega: Option<f32>) {
        if self.friction_only && !self.shaft_stuck && self.omega.hi.abs() > 0.0 {
            self.step_friction(v, tl);
        } else {
            self.step_with_effects(v, tl, measured_omega);
        }
    }

    /// Seed Eq. 5 by the exact ZOH step, no effect: the hot path of every fit without
    /// effects, inlined into the fit loops. The same arithmetic as
    /// [`Simulator::step_with_effects`] with every effect at zero.
    #[inline(always)]
    fn step_plain(&mut self, v: f32, tl: f32) {
        let (i0, w0) = (self.current.hi, self.omega.hi);
        self.linear_update(i0, w0, v, tl);
        self.push_reading();
    }

    /// The exact ZOH step of seed Eq. 5 from `(i0, w0)` with `volts` and `load` held over
    /// it: the one copy of this arithmetic, so that every path agrees bit for bit.
    #[inline(always)]
    fn linear_update(&mut self, i0: f32, w0: f32, volts: f32, load: f32) {
        let d = &self.disc;
        let di = d.d[0][0] * i0 + d.d[0][1] * w0 + d.gv[0] * volts + d.gt[0] * load;
        let dw = d.d[1][0] * i0 + d.d[1][1] * w0 + d.gv[1] * volts + d.gt[1] * load;
        self.current.add(di);
        self.omega.add(dw);
    }

    /// The mechanical step with no armature current (seed Eq. 4 with `i = 0`).
    #[inline(always)]
    fn mechanical_update(&mut self, w0: f32, load: f32) {
        let d = &self.disc;
        self.omega.add(d.am * w0 + d.gm * load);
    }

    /// Seed Eq. 5 with no effect but Coulomb friction, shaft turning: the friction
    /// `tc sign(w)` is a load held over the step (with the bridge open, seed Eq. 4 alone
    /// with `i = 0`), and a shaft whose speed crosses zero sticks there. The hot path of a
    /// commissioning fit; the same arithmetic as [`Simulator::step_with_effects`] in this
    /// case.
    #[inline(always)]
    fn step_friction(&mut self, v: f32, tl: f32) {
        let (i0, w0) = (self.current.hi, self.omega.hi);
        // `coulomb_friction::torque(tc, sign(w0))` with w0 non-zero and not NaN (see
        // `step_nonlinear`), without the multiplication by +-1 (the same bits).
        let forward = w0 > 0.0;
        let friction = if forward { self.tc } else { -self.tc };
        let load = tl + friction;
        if self.open {
            self.mechanical_update(w0, load);
        } else {
            self.linear_update(i0, w0, v, load);
        }
        // `stick_on_crossing`: a speed that no longer has the sign of w0 sticks at zero.
        let w1 = self.omega.hi;
        let kept = if forward { w1 > 0.0 } else { w1 < 0.0 };
        if self.tc > 0.0 && !kept {
            self.omega.set(0.0);
            self.shaft_stuck = true;
        }
        // No ripple acts (`friction_only`): the tacho reads the shaft speed.
        self.push_tacho(self.omega.hi);
    }

    #[inline(never)]
    fn step_with_effects(&mut self, v: f32, tl: f32, measured_omega: Option<f32>) {
        let i0 = self.current.hi;
        let w0 = self.omega.hi;
        // Armature reaction as held inputs: the linear part uses kv; the flux loss adds
        // back (1 - flux) kv w to the voltage and removes (1 - flux) kv i of torque.
        let dkv = armature_reaction::lost_constant(self.kar, self.kv, i0);
        let mut volts = v + dkv * w0;
        let mut load = tl + dkv * i0 + quadratic_load::torque(self.kq, w0);
        let mut brush = 0.0;
        let mut friction = 0.0;
        let current_moves = if self.open {
            false
        } else if self.vb > 0.0 {
            let law = |direction| brush_drop::voltage(self.vb, direction);
            match dead_zone_opposition(i0, volts - self.kv * w0, law, &mut self.current_stuck) {
                Some(o) => {
                    brush = o;
                    true
                }
                None => false,
            }
        } else {
            true
        };
        let shaft_moves = if self.tc > 0.0 {
            let law = |direction| coulomb_friction::torque(self.tc, direction);
            match dead_zone_opposition(w0, self.kv * i0 - load, law, &mut self.shaft_stuck) {
                Some(o) => {
                    friction = o;
                    true
                }
                None => false,
            }
        } else {
            true
        };
        volts -= brush;
        load += friction;
        match (current_moves, shaft_moves) {
            (true, true) => self.linear_update(i0, w0, volts, load),
            (true, false) => self.current.add(self.disc.ae * i0 + self.disc.ge * volts),
            (false, true) => self.mechanical_update(w0, load),
            (false, false) => {}
        }
        if current_moves && self.vb > 0.0 {
            stick_on_crossing(i0, brush, &mut self.current, &mut self.current_stuck);
        }
        if shaft_moves && self.tc > 0.0 {
            stick_on_crossing(w0, friction, &mut self.omega, &mut self.shaft_stuck);
        }
        if self.ripple_amp != 0.0 {
            let rate = measured_omega.unwrap_or(0.5 * (w0 + self.omega.hi));
            self.psi = tacho_ripple::advance(self.psi, self.ripple_cycles, rate, self.dt);
        }
        self.push_reading();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::profile::{Experiment, Profile};
    use crate::model::record::{simulate, Record};
    use proptest::prelude::*;
    use std::vec;
    use std::vec::Vec;

    fn trace(p: &ModelParams, dt: f32, n: usize) -> Vec<f32> {
        let v = vec![50.0f32; n];
        let (mut w, mut i) = (vec![0.0; n], vec![0.0; n]);
        let r = Record {
            dt,
            v: &v,
            omega: &w.clone(),
            current: None,
            load: None,
            coast_from: None,
        };
        simulate(p, &r, InitialState::REST, false, &mut w, &mut i).unwrap();
        w
    }

    fn max_rel_diff(a: &[f32], b: &[f32]) -> f32 {
        let peak = a.iter().fold(0.0f32, |m, x| m.max(x.abs()));
        a.iter()
            .zip(b)
            .map(|(x, y)| (x - y).abs())
            .fold(0.0, f32::max)
            / peak
    }

    #[test]
    fn design_md_equal_fit_sets_give_the_same_speed_trace() {
        // Scaling (Ra, La) by 2.5 and (J, B) by 1/2.5 (`docs/ARCHITECTURE.md`, the identifiability trap) leaves seed Eq. 6 unchanged.
        let paper = ModelParams::SEED_MOTOR;
        let scaled = ModelParams::motor(8.53, 0.14325, 0.01696, 0.001068, 0.1604);
        let a = trace(&paper, 1e-3, 20_000);
        let b = trace(&scaled, 1e-3, 20_000);
        assert!(max_rel_diff(&a, &b) < 1e-4, "{}", max_rel_diff(&a, &b));
        // The second direction trades La J against Kv: near-equal fit.
        let traded = ModelParams::motor(3.407, 0.0573, 0.0212, 0.00322, 0.0802);
        let c = trace(&traded, 1e-3, 20_000);
        assert!(max_rel_diff(&a, &c) < 2e-3, "{}", max_rel_diff(&a, &c));
        // While a genuinely different motor does not.
        let other = ModelParams::motor(3.412, 0.0573, 0.0424, 0.00267, 0.17);
        assert!(max_rel_diff(&a, &trace(&other, 1e-3, 20_000)) > 1e-2);
    }

    #[test]
    fn coulomb_friction_holds_the_shaft_below_breakaway() {
        let tc = 0.05f32;
        let p = ModelParams::SEED_MOTOR.with(ParamId::Tc, tc);
        // Stall torque at 1 V is Kv V / Ra = 0.047 N m < tc: the shaft never turns.
        let mut sim = Simulator::new(&p, 1e-3, InitialState::REST).unwrap();
        for _ in 0..5000 {
            sim.advance(1.0, 0.0);
            assert_eq!(sim.omega(), 0.0);
        }
        // At 50 V it turns, and settles below the friction-free speed.
        let free = trace(&ModelParams::SEED_MOTOR, 1e-3, 30_000);
        let with = trace(&p, 1e-3, 30_000);
        assert!(with[29_999] > 0.0 && with[29_999] < free[29_999]);
    }

    #[test]
    fn the_friction_fast_path_is_the_general_step_bit_for_bit() {
        // Start, a load step, a reversal (the shaft crosses zero and sticks), a coast-down,
        // driven again (bridge closed after the coast), then restarted from rest and coasting
        // once more; also without friction (the coast-downs take the fast path then).
        for (tc, rate) in [
            (0.0f32, 100.0f32),
            (0.05, 100.0),
            (0.5, 1000.0),
            (2.0, 1000.0),
        ] {
            let p = ModelParams::SEED_MOTOR.with(ParamId::Tc, tc);
            let dt = 1.0 / rate;
            let n = (80.0 * rate) as usize;
            let mut fast = Simulator::new(&p, dt, InitialState::REST).unwrap();
            let mut general = fast.clone();
            general.friction_only = false;
            let (mut fast_steps, mut stuck) = (0, 0);
            for k in 0..n {
                let t = k as f32 * dt;
                let (a, b) = (fast.reading(), general.reading());
                assert_eq!(a.omega.to_bits(), b.omega.to_bits(), "tc {tc}, {t} s");
                assert_eq!(a.current.to_bits(), b.current.to_bits(), "tc {tc}, {t} s");
                if k == (60.0 * rate) as usize {
                    fast.reset(InitialState::REST);
                    general.reset(InitialState::REST);
                }
                let open = (40.0..50.0).contains(&t) || t >= 70.0;
                for sim in [&mut fast, &mut general] {
                    if open {
                        sim.open_circuit();
                    } else {
                        sim.close_circuit();
                    }
                }
                let v = match t {
                    t if t < 30.0 => 50.0,
                    t if t < 40.0 => -50.0,
                    _ => 25.0,
                };
                let tl = if (20.0..30.0).contains(&t) { 0.3 } else { 0.0 };
                fast_steps += usize::from(!fast.plain && !fast.shaft_stuck && fast.omega() != 0.0);
                stuck += usize::from(fast.shaft_stuck);
                fast.advance(v, tl);
                general.advance(v, tl);
            }
            let least = if tc == 0.0 { n / 5 } else { n / 2 };
            assert!(
                fast_steps > least,
                "tc {tc}: fast path taken {fast_steps} of {n}"
            );
            assert!(tc == 0.0 || stuck > 0, "tc {tc}: the shaft never stuck");
        }
    }

    #[test]
    fn sensor_delay_shifts_the_reading() {
        let p = ModelParams::SEED_MOTOR.with(ParamId::Td, 0.01);
        let a = trace(&ModelParams::SEED_MOTOR, 1e-3, 2000);
        let b = trace(&p, 1e-3, 2000);
        for k in 10..2000 {
            assert!(
                (b[k] - a[k - 10]).abs() <= 1e-3 * a[k - 10].abs().max(1.0),
                "{k}"
            );
        }
    }

    fn log_uniform(lo: f32, hi: f32) -> impl Strategy<Value = f32> {
        (0.0f32..=1.0).prop_map(move |u| lo * (hi / lo).powf(u))
    }

    proptest! {
        #![proptest_config(ProptestConfig { cases: 300, ..ProptestConfig::default() })]
        /// Any motor in the Table 1 box, with any effects, at any rate from 100 Hz to 50 kHz,
        /// simulates to finite numbers (Euler/RK4 diverge for part of the box, `docs/ARCHITECTURE.md`).
        #[test]
        fn every_motor_in_the_box_simulates_finite(
            ra in log_uniform(0.5, 10.0),
            la in log_uniform(0.01, 2.0),
            j in log_uniform(0.001, 1.0),
            b in log_uniform(0.0005, 1.0),
            kv in log_uniform(0.01, 2.0),
            rate in log_uniform(100.0, 50_000.0),
            tc in prop_oneof![Just(0.0f32), 0.0f32..1.0],
            kq in prop_oneof![Just(0.0f32), 0.0f32..1e-3],
            kar in prop_oneof![Just(0.0f32), 0.0f32..0.1],
            vb in prop_oneof![Just(0.0f32), 0.0f32..5.0],
            td_frac in prop_oneof![Just(0.0f32), 0.0f32..1.0],
            ripple in prop_oneof![Just(0.0f32), 0.0f32..0.2],
            profile in prop_oneof![Just(Profile::Start), Just(Profile::Steps), Just(Profile::Load), Just(Profile::Reversal)],
        ) {
            let p = ModelParams::motor(ra, la, j, b, kv)
                .with(ParamId::Tc, tc).with(ParamId::Kq, kq).with(ParamId::Kar, kar)
                .with(ParamId::Vb, vb).with(ParamId::Td, td_frac * MAX_DELAY_SAMPLES as f32 / rate)
                .with(ParamId::RippleAmp, ripple).with(ParamId::RippleCycles, 4.0);
            let dt = 1.0 / rate;
            let n = 600;
            let exp = Experiment { profile, voltage: 220.0, duration: n as f32 * dt, load_torque: 0.5 };
            let mut sim = Simulator::new(&p, dt, InitialState::REST).unwrap();
            for k in 0..n {
                let input = exp.at(k as f32 * dt);
                let r = sim.reading();
                prop_assert!(r.omega.is_finite() && r.current.is_finite(), "step {k}: {r:?}");
                sim.advance(input.v, input.tl);
            }
        }
    }
}
