//! The step with any effect (paper Eq. 5 with the catalogue's held inputs): the entries of
//! role [`Role::HeldInputs`] (armature reaction, bridge dead time, the current limit,
//! cogging, the winding's hot resistance) as held voltage and load, each from its own
//! entry, and the winding's temperature advanced after the step; the fan load at the step's
//! end, solved with it ([`Role::SpeedLoad`]); brush drop and
//! friction as dead zones, whose stuck state is frozen while the other advances with its
//! own exact first-order step (see the module doc of [`super`]).

use super::{sign, MeasuredTacho, Simulator};
use crate::capacity::FULL;
use crate::model::compensated::Compensated;
use crate::model::effects::{
    brush_drop, quadratic_load, tacho_ripple, winding_heating, Held, Role, StepState, ROLES,
    SWITCHES,
};
use crate::param_id::ParamId;

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

/// Whether a state that moved over a step with an opposing dead-zone term went from `before`
/// to `after` through zero (or to it).
fn crossed_zero(before: f32, opposition: f32, after: f32) -> bool {
    let moving_dir = if before != 0.0 {
        sign(before)
    } else {
        sign(opposition)
    };
    opposition != 0.0 && sign(after) != moving_dir
}

/// After a step with an opposing dead-zone term: a state that crossed zero sticks there.
fn stick_on_crossing(before: f32, opposition: f32, state: &mut Compensated, stuck: &mut bool) {
    if crossed_zero(before, opposition, state.hi) {
        state.set(0.0);
        *stuck = true;
    }
}

impl Simulator {
    #[inline(never)]
    pub(super) fn step_with_effects(&mut self, v: f32, tl: f32, measured: Option<MeasuredTacho>) {
        let i0 = self.current.hi;
        let w0 = self.omega.hi;
        // The entries' held inputs (armature reaction, bridge dead time, the drive's current
        // limit, cogging, the winding's heating), in
        // catalogue order; none on a board, whose simulator holds no such entry.
        let (mut volts, mut load) = (v, tl);
        if FULL {
            let (held, at) = (
                Held(&self.held),
                StepState {
                    volts: v,
                    held_rotor: (self.disc.ae, self.disc.ge),
                    kv: self.kv,
                    current: i0,
                    omega: w0,
                    cogging_angle: self.cogging_psi.first().copied().unwrap_or(0.0),
                    winding_rise: self.winding_rise.first().map_or(0.0, |r| r.hi),
                },
            );
            for (e, role) in ROLES.iter().enumerate() {
                if let (Role::HeldInputs(inputs), true) = (role, held.get(SWITCHES[e]) != 0.0) {
                    let added = inputs(&held, &at);
                    volts += added.volts;
                    load += added.load;
                }
            }
        }
        let vb = self.effect(ParamId::Vb);
        let mut brush = 0.0;
        let mut friction = 0.0;
        let current_moves = if self.open {
            false
        } else if vb > 0.0 {
            let law = |direction| brush_drop::voltage(vb, direction);
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
        let shaft_moves = if self.friction {
            let friction_law = self.friction_law();
            let law = |direction| friction_law.opposition(direction, w0);
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
        if shaft_moves {
            self.speed_load_over_the_step(current_moves);
        }
        if current_moves && vb > 0.0 && crossed_zero(i0, brush, self.current.hi) {
            self.current_through_zero_within_step(i0, w0, volts + brush, load, shaft_moves);
        }
        if shaft_moves && self.friction {
            let w1 = self.omega.hi;
            stick_on_crossing(w0, friction, &mut self.omega, &mut self.shaft_stuck);
            if self.shaft_stuck && w0 != 0.0 {
                self.stop_within_step(i0, w0, w1, volts, load - friction);
            }
        } else if self.friction && current_moves && !self.open {
            // Stuck over the step: break away where the drive torque reaches the opposition.
            self.break_away_within_step(i0, volts, load);
        }
        self.heat_winding_over_the_step(i0);
        if self.tracks_angle() {
            let rate = measured.map_or(0.5 * (w0 + self.omega.hi), |m| m.rate);
            if FULL && measured.is_some() && !self.psi_from_reading {
                self.psi_from_reading = true;
                self.unripple_delay_line(w0);
            }
            let cycles = self.effect(ParamId::RippleCycles);
            self.psi = tacho_ripple::advance(self.psi, cycles, rate, self.dt);
            let cogging = self.effect(ParamId::CogCycles);
            if let Some(psi) = self.cogging_psi.first_mut() {
                *psi = tacho_ripple::advance(*psi, cogging, rate, self.dt);
            }
        }
        self.push_reading();
        if let (true, Some(after)) = (FULL, measured.and_then(|m| m.after)) {
            self.track_angle(after);
        }
    }

    /// The winding's temperature rise (`winding_heating`, a state of the host's simulator
    /// alone) over a step from current `i0`: the exact step of
    /// `tau_th d(dT)/dt = rth loss - dT` with the copper loss `Ra (1 + ALPHA dT) i^2` held
    /// over the step, `i^2` the mean of its values at the step's ends (the trapezoid: at a
    /// reversal the current falls by much of itself within a few steps). Its drop
    /// `-ALPHA dT Ra i` acts through the entry's held input in the next step.
    #[inline(always)]
    fn heat_winding_over_the_step(&mut self, i0: f32) {
        let rth = self.effect(ParamId::Rth);
        if rth == 0.0 {
            return;
        }
        let i1 = self.current.hi;
        let ra = self.disc.resistance();
        let gain = self.thermal_gain.first().copied().unwrap_or(0.0);
        if let Some(rise) = self.winding_rise.first_mut() {
            let hot = ra * winding_heating::resistance_factor(rise.hi);
            let loss = hot * 0.5 * (i0 * i0 + i1 * i1);
            rise.add(winding_heating::rise_increment(rise.hi, loss, rth, gain));
        }
    }

    /// The entry of role [`Role::SpeedLoad`] (the fan load `kq w |w|`) over a step the shaft
    /// turned: the load at the step's end, solved with the step (backward Euler on the load:
    /// exact in the steady state, stable at any step). The step's linear response of the
    /// speed to a held load is `gt[1]` (`gm` with no current), so `w1 = w + g kq w1 |w1|`
    /// ([`quadratic_load::torque_at_step_end`]); the current takes the same load's `gt[0]`.
    fn speed_load_over_the_step(&mut self, current_moves: bool) {
        let kq = self.effect(ParamId::Kq);
        if kq == 0.0 {
            return;
        }
        let (gw, gi) = match current_moves {
            true => (self.disc.gt[1], self.disc.gt[0]),
            false => (self.disc.gm, 0.0),
        };
        let torque = quadratic_load::torque_at_step_end(kq, gw, self.omega.hi);
        self.omega.add(gw * torque);
        self.current.add(gi * torque);
    }
}
