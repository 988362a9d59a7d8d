//! Coulomb friction's events within a simulation step: a shaft that stops, reverses or
//! breaks away does so at its instant in the step, then holds or turns for the rest of it
//! (see the module doc of [`super`]). Placed at the step's end instead, such events biased
//! viscous and Coulomb friction by up to 8 % on the coarse steps of a commissioning record
//! (`docs/measurements/commissioning.md`).

use super::{sign, Simulator};

impl Simulator {
    /// The electrical step with the rotor at rest over `share` of the step (0 to 1), from
    /// `i0` with `volts` held: `i(t) - i_ss = (i0 - i_ss) E^(t/dt)`, `E = 1 + ae`, the exact
    /// first-order response ([`Discrete::ae`]) over part of the step.
    pub(super) fn held_rotor_current(&self, i0: f32, volts: f32, share: f32) -> f32 {
        let (ae, ge) = (self.disc.ae, self.disc.ge);
        if ae.abs() < 1e-6 {
            // La/Ra far beyond the step: the current ramps.
            return i0 + share * (ae * i0 + ge * volts);
        }
        let decay = libm::powf(1.0 + ae, share) - 1.0;
        i0 + decay * (i0 + ge / ae * volts)
    }

    /// The shaft reached zero speed within the step (its speed went from `w0` to `w1` of the
    /// other sign, as if friction still opposed it), at the share `w0 / (w0 - w1)` of the
    /// step (the speed close to linear in time there), the current then interpolated. If
    /// the drive torque `kv i - load` there passes the friction of the other direction, the
    /// shaft turns on the other way for the rest of the step; otherwise it is held, and the
    /// current (bridge closed) follows the held-rotor response. Placed at the step's end
    /// instead (held for the rest of the step, turning again only from the next), such
    /// reversals and stops biased viscous and Coulomb friction by up to 8 % on coarse
    /// record steps (`docs/measurements/commissioning.md`).
    pub(super) fn stop_within_step(&mut self, i0: f32, w0: f32, w1: f32, volts: f32, load: f32) {
        self.omega.set(0.0);
        self.shaft_stuck = true;
        self.friction_event = true;
        let moving = (w0 / (w0 - w1)).clamp(0.0, 1.0);
        let at_stop = match self.open {
            true => 0.0,
            false => i0 + moving * (self.current.hi - i0),
        };
        if self.move_from_rest(at_stop, volts, load, 1.0 - moving) || self.open {
            return;
        }
        let end = self.held_rotor_current(at_stop, volts, 1.0 - moving);
        self.current.set(end);
    }

    /// The shaft held by friction over the step, the current from `i0` under `volts`: if
    /// the drive torque `kv i - load` passes the opposition within the step, the shaft
    /// breaks away there and moves for the rest of the step, instead of waiting for the
    /// next step.
    pub(super) fn break_away_within_step(&mut self, i0: f32, volts: f32, load: f32) {
        let i1 = self.current.hi;
        let direction = sign(self.kv * i1 - load);
        let held = self.friction_law().opposition(direction, 0.0);
        if direction == 0.0 || (self.kv * i1 - load).abs() <= held.abs() {
            return;
        }
        self.friction_event = true;
        let (ae, ge) = (self.disc.ae, self.disc.ge);
        let at_break = (held + load) / self.kv;
        let steady = if ae != 0.0 {
            -ge / ae * volts
        } else {
            f32::INFINITY
        };
        let share = libm::logf((at_break - steady) / (i0 - steady)) / libm::logf(1.0 + ae);
        if !(share.is_finite() && (0.0..1.0).contains(&share)) {
            return;
        }
        // The drive torque equals the opposition at the break: it moves on (by the
        // tiniest margin) in `move_from_rest`, whose test it must pass.
        let _ = self.move_from_rest(at_break, volts, load, 1.0 - share);
    }

    /// From rest with current `i` under `volts` and `load` (no friction in it): if the drive
    /// torque reaches the friction's opposition in its direction, move for the share `left`
    /// of the step (its exact coefficients, [`Discrete::over_share`]) and say so; otherwise
    /// leave the state as it is.
    fn move_from_rest(&mut self, i: f32, volts: f32, load: f32, left: f32) -> bool {
        if self.open {
            return false;
        }
        let drive = self.kv * i - load;
        let direction = sign(drive);
        let held = self.friction_law().opposition(direction, 0.0);
        if direction == 0.0 || drive.abs() < held.abs() {
            return false;
        }
        let part = match left < 1.0 {
            true => self.disc.over_share(self.dt, self.kv, left).ok(),
            false => None,
        };
        let (di, dw) = part
            .as_ref()
            .unwrap_or(&self.disc)
            .increments(i, 0.0, volts, load + held);
        self.current.set(i + di);
        self.omega.set(dw);
        self.shaft_stuck = sign(self.omega.hi) != direction;
        if self.shaft_stuck {
            self.omega.set(0.0);
        }
        true
    }
}
