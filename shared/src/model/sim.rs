//! Fixed-step simulation of the motor (paper Eq. 1-5) with the optional effects.
//!
//! The linear part advances with the exact ZOH coefficients of [`crate::model::discretise`]. Each
//! nonlinear effect enters as an extra voltage or load torque evaluated at the start of the
//! step and held over it; Coulomb friction and brush drop are dead zones (stiction: the shaft
//! stays at rest until the drive torque exceeds `tc`; no current flows until the driving
//! voltage exceeds `vb`), handled by freezing the stuck state and advancing the other one
//! with its own exact first-order step. A shaft that stops or breaks away within a step does
//! so at its instant in the step (stop: where the speed, close to linear over the step,
//! crosses zero; break-away: where the held-rotor current's exact exponential reaches the
//! friction), then holds or turns for the rest of the step: on the coarse steps of a
//! commissioning record, events placed at step boundaries biased B and tc by up to 8 %.
//! A current that falls through zero under a brush drop likewise flows on the other way
//! from its instant in the step, unless the brushes hold it (held to the step's end, a
//! reversed current lagged a step through its whole transient).
//! Tacho effects (delay, ripple) act on the reading only.
//! The state is kept as a compensated (two-sum) f32 pair so that slow modes at high sample
//! rates do not stall on f32 rounding.

use crate::capacity::{FULL, SIM_EFFECT_PARAMS};
use crate::error::Error;
use crate::model::compensated::Compensated;
use crate::model::discretise::Discrete;
use crate::model::effects::friction::FrictionLaw;
use crate::model::effects::{
    sensor_delay, winding_heating, Held, BEYOND_COULOMB, SHAFT_DEAD_ZONE, SHAFT_FRICTION, SWITCHES,
};
use crate::model::params::ModelParams;
use crate::param_id::ParamId;

use crate::capacity::MAX_DELAY_SAMPLES;
const RING: usize = MAX_DELAY_SAMPLES + 2;
// Ring positions are bytes (a Simulator is copied a dozen times into every Jacobian).
const _: () = assert!(RING <= u8::MAX as usize);

/// What drives a simulation over one step of a record.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepInput {
    /// Armature voltage [V] (not applied with the bridge open).
    pub v: f32,
    /// Known load torque [N m].
    pub tl: f32,
    /// The tacho's readings over the step, for the ripple angle (see [`Simulator::apply`]).
    pub measured: Option<MeasuredTacho>,
    /// The bridge opens at the start of this step (the record's coast-down begins).
    pub opens: bool,
}

/// What the tacho of a record read over one step: the ripple's angle advances by `rate`
/// and is corrected by the reading `after` ([`Simulator::apply`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeasuredTacho {
    /// Mean measured speed over the step [rad/s] (the trapezoid of its two readings).
    pub rate: f32,
    /// The reading at the step's end [rad/s] (none after a record's last sample).
    pub after: Option<f32>,
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

/// One slot on the host, none on a board ([`crate::capacity::FULL`]).
const HOST_SLOT: usize = FULL as usize;

/// Position of the first held effect parameter (`tc`) in [`ParamId::ALL`].
const FIRST_HELD: usize = ParamId::MOTOR.len();

/// A running simulation of one parameter set at one sample step.
#[derive(Clone, Debug)]
pub struct Simulator {
    disc: Discrete,
    dt: f32,
    kv: f32,
    /// The effect parameters this build holds ([`SIM_EFFECT_PARAMS`] of them, from `tc` on
    /// in [`ParamId`] order); read through [`Simulator::effect`].
    held: [f32; SIM_EFFECT_PARAMS],
    /// A friction effect acts on the shaft (its dead zone, see [`Simulator::friction`]).
    friction: bool,
    /// Delay in samples, split into whole samples and fraction.
    delay_whole: u8,
    delay_frac: f32,
    /// The tacho reading lags (`delay_whole` or `delay_frac` non-zero): what `tacho` holds
    /// goes through `ring`; otherwise it is read as it is.
    delayed: bool,
    /// No effect acts on the dynamics or the reading.
    linear: bool,
    /// `linear` and the bridge closed: [`Simulator::step`] takes the plain linear step (the
    /// same arithmetic as the general one with every effect at zero).
    plain: bool,
    /// No effect on the dynamics or the reading's shape but Coulomb friction (if any): a
    /// turning shaft takes [`Simulator::step_friction`].
    friction_only: bool,
    /// The bridge is open (coast-down): no armature current, the voltage is not applied.
    open: bool,
    /// The newest value into the delay line: the tacho's reading, or, where the ripple's
    /// angle follows a record's readings, the shaft speed, the ripple applied after the
    /// line (the reading is then the angle tracker's, `sim_readings.rs`).
    tacho: f32,
    current: Compensated,
    omega: Compensated,
    /// Ripple angle `ripple_cycles * theta`, wrapped to [-pi, pi].
    psi: f32,
    /// `psi` integrates the measured speed, ripple included, corrected by the readings
    /// ([`Simulator::apply`]): the rotor's angle is [`tacho_ripple::rotor_angle`] of it.
    psi_from_reading: bool,
    /// The ripple angle's tracker (host builds only, as `cogging_psi`).
    angle_tracker: [angle_tracker::AngleTracker; HOST_SLOT],
    /// Cogging angle `cog_cycles * theta`, wrapped to [-pi, pi] (host builds only: a board's
    /// simulator holds no cogging, and is copied too often to carry the slot).
    cogging_psi: [f32; HOST_SLOT],
    /// The winding's temperature rise since the record's start [K] (`winding_heating`;
    /// host builds only, as `cogging_psi`).
    winding_rise: [Compensated; HOST_SLOT],
    /// The share of the way to its steady state the rise goes in a step
    /// ([`winding_heating::step_gain`]; host builds only).
    thermal_gain: [f32; HOST_SLOT],
    /// Readings averaged over each step ([`Simulator::for_record`]; a board's too: the
    /// Jacobian's simulators sit in a workspace, [`crate::fit::workspace`], not on its
    /// stack).
    averaged: Option<averaged::Averaged>,
    shaft_stuck: bool,
    /// The shaft stopped or broke away within a step since this was last cleared (records
    /// of averaged readings clear it before each step: `sim_averaged`).
    friction_event: bool,
    current_stuck: bool,
    ring: [f32; RING],
    head: u8,
    filled: u8,
}

impl Simulator {
    /// A simulator for `p` at step `dt`, starting from `init`.
    pub fn new(p: &ModelParams, dt: f32, init: InitialState) -> Result<Simulator, Error> {
        Simulator::with_motor(p, dt, init, None)
    }

    /// [`Simulator::new`], given the motor's coefficients when they are known (`disc`, the
    /// [`Discrete::new`] of a set with `p`'s motor at `dt`: [`Simulator::for_record_like`]).
    pub(super) fn with_motor(
        p: &ModelParams,
        dt: f32,
        init: InitialState,
        disc: Option<Discrete>,
    ) -> Result<Simulator, Error> {
        p.validate()?;
        let disc = match disc {
            Some(d) => d,
            None => Discrete::new(p, dt)?,
        };
        let (delay_whole, delay_frac) =
            sensor_delay::in_samples(p.get(ParamId::Td), dt).ok_or(Error::DelayTooLong)?;
        // An effect this build's simulator does not hold must be off.
        for id in SWITCHES {
            if id.index() >= FIRST_HELD + SIM_EFFECT_PARAMS && p.get(id) != 0.0 {
                return Err(Error::EffectNotInBuild(id));
            }
        }
        let mut held = [0.0; SIM_EFFECT_PARAMS];
        for (k, v) in held.iter_mut().enumerate() {
            *v = p.get(ParamId::ALL[FIRST_HELD + k]);
        }
        let mut on = 0u32;
        for (e, id) in SWITCHES.iter().enumerate() {
            if p.get(*id) != 0.0 {
                on |= 1 << e;
            }
        }
        let delayed = delay_whole != 0 || delay_frac != 0.0;
        let friction = on & SHAFT_FRICTION != 0;
        // Effects on the dynamics or the reading's shape other than Coulomb friction (a
        // delay only shifts the reading: the fast paths push through the delay line).
        let friction_only = on & BEYOND_COULOMB == 0;
        let linear = friction_only && on & SHAFT_DEAD_ZONE == 0;
        let mut s = Simulator {
            disc,
            dt,
            kv: p.get(ParamId::Kv),
            held,
            friction,
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
            psi_from_reading: false,
            angle_tracker: core::array::from_fn(|_| {
                angle_tracker::AngleTracker::start(p.get(ParamId::RipplePhase))
            }),
            cogging_psi: [0.0; HOST_SLOT],
            winding_rise: [Compensated::new(0.0); HOST_SLOT],
            // (`from_fn`: a board's empty slot calls nothing.)
            thermal_gain: core::array::from_fn(|_| {
                winding_heating::step_gain(p.get(ParamId::TauTh), dt)
            }),
            averaged: None,
            shaft_stuck: false,
            friction_event: false,
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
        self.psi_from_reading = false;
        let phase = self.effect(ParamId::RipplePhase);
        self.angle_tracker = core::array::from_fn(|_| angle_tracker::AngleTracker::start(phase));
        self.cogging_psi = [0.0; HOST_SLOT];
        // Each record begins cold (`winding_heating`).
        self.winding_rise = [Compensated::new(0.0); HOST_SLOT];
        self.shaft_stuck = self.friction && init.omega == 0.0;
        self.current_stuck = self.effect(ParamId::Vb) > 0.0 && init.current == 0.0;
        self.open = false;
        self.plain = self.linear;
        self.head = 0;
        self.filled = 0;
        self.push_reading();
        let now = self.reading();
        if let Some(a) = &mut self.averaged {
            a.last = now;
        }
    }

    /// Effect parameter `id` (0 for one this build does not hold: a constant).
    #[inline(always)]
    fn effect(&self, id: ParamId) -> f32 {
        Held(&self.held).get(id)
    }

    /// The shaft's friction law: the opposing torque for a motion in `direction` at speed
    /// `w` (Coulomb, with its static and asymmetric extensions).
    #[inline(always)]
    fn friction_law(&self) -> FrictionLaw {
        FrictionLaw {
            tc: self.effect(ParamId::Tc),
            ts: self.effect(ParamId::Ts),
            ws: self.effect(ParamId::Ws),
            ka: self.effect(ParamId::Ka),
        }
    }

    /// True when the tacho ripple or cogging follows the rotor angle: [`Simulator::apply`]
    /// then uses the measured speed it is given (otherwise it is ignored).
    pub fn tracks_angle(&self) -> bool {
        self.effect(ParamId::RippleAmp) != 0.0 || self.effect(ParamId::CogAmp) != 0.0
    }

    /// True shaft speed (no sensor effects).
    pub fn omega(&self) -> f32 {
        self.omega.hi
    }

    /// Open the bridge (a coast-down, see [`crate::model::record::Record::coast_from`]): from now on
    /// no armature current flows and the voltage given to the steps is not applied; the
    /// shaft obeys paper Eq. 4 with `i = 0` (viscous and Coulomb friction, load). The current
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
            self.current_stuck = self.effect(ParamId::Vb) > 0.0;
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
    /// after some thousand revolutions), and is corrected by the reading at the step's end
    /// (the tracker of `sim_angle_tracker.rs`: the measured speed's noise, integrated, made
    /// the angle a random walk). Every loop that simulates a record steps through here, so
    /// none can miss the coast-down.
    #[inline(always)]
    pub fn apply(&mut self, input: &StepInput) {
        if input.opens {
            self.open_circuit();
        }
        self.step(input.v, input.tl, input.measured);
    }

    #[inline(always)]
    fn step(&mut self, v: f32, tl: f32, measured: Option<MeasuredTacho>) {
        if self.plain {
            self.step_plain(v, tl);
        } else {
            self.step_nonlinear(v, tl, measured);
        }
    }

    /// Every step but the plain one: one copy of it in flash, however many fit loops call it.
    #[inline(never)]
    fn step_nonlinear(&mut self, v: f32, tl: f32, measured: Option<MeasuredTacho>) {
        if self.friction_only && !self.shaft_stuck && self.omega.hi.abs() > 0.0 {
            self.step_friction(v, tl);
        } else {
            self.step_with_effects(v, tl, measured);
        }
    }

    /// Paper Eq. 5 by the exact ZOH step, no effect: the hot path of every fit without
    /// effects, inlined into the fit loops. The same arithmetic as
    /// [`Simulator::step_with_effects`] with every effect at zero.
    #[inline(always)]
    fn step_plain(&mut self, v: f32, tl: f32) {
        let (i0, w0) = (self.current.hi, self.omega.hi);
        self.linear_update(i0, w0, v, tl);
        self.push_reading();
    }

    /// The exact ZOH step of paper Eq. 5 from `(i0, w0)` with `volts` and `load` held over
    /// it: the one copy of this arithmetic, so that every path agrees bit for bit.
    #[inline(always)]
    fn linear_update(&mut self, i0: f32, w0: f32, volts: f32, load: f32) {
        let (di, dw) = self.disc.increments(i0, w0, volts, load);
        self.current.add(di);
        self.omega.add(dw);
    }

    /// The mechanical step with no armature current (paper Eq. 4 with `i = 0`).
    #[inline(always)]
    fn mechanical_update(&mut self, w0: f32, load: f32) {
        let d = &self.disc;
        self.omega.add(d.am * w0 + d.gm * load);
    }

    /// Paper Eq. 5 with no effect but Coulomb friction, shaft turning: the friction
    /// `tc sign(w)` is a load held over the step (with the bridge open, paper Eq. 4 alone
    /// with `i = 0`), and a shaft whose speed crosses zero sticks there. The hot path of a
    /// commissioning fit; the same arithmetic as [`Simulator::step_with_effects`] in this
    /// case.
    #[inline(always)]
    fn step_friction(&mut self, v: f32, tl: f32) {
        let (i0, w0) = (self.current.hi, self.omega.hi);
        // `coulomb_friction::torque(tc, sign(w0))` with w0 non-zero and not NaN (see
        // `step_nonlinear`), without the multiplication by +-1 (the same bits).
        let forward = w0 > 0.0;
        let tc = self.effect(ParamId::Tc);
        let friction = if forward { tc } else { -tc };
        let load = tl + friction;
        if self.open {
            self.mechanical_update(w0, load);
        } else {
            self.linear_update(i0, w0, v, load);
        }
        // `stick_on_crossing`: a speed that no longer has the sign of w0 sticks at zero.
        let w1 = self.omega.hi;
        let kept = if forward { w1 > 0.0 } else { w1 < 0.0 };
        if tc > 0.0 && !kept {
            self.stop_within_step(i0, w0, w1, v, tl);
        }
        // No ripple acts (`friction_only`): the tacho reads the shaft speed.
        self.push_tacho(self.omega.hi);
    }
}

#[path = "sim_angle_tracker.rs"]
mod angle_tracker;
#[path = "sim_averaged.rs"]
mod averaged;
#[path = "sim_brush_events.rs"]
mod brush_events;
#[path = "sim_effect_step.rs"]
mod effect_step;
#[path = "sim_friction_events.rs"]
mod friction_events;
#[path = "sim_readings.rs"]
mod readings;

#[cfg(test)]
#[path = "sim_tests.rs"]
mod tests;
