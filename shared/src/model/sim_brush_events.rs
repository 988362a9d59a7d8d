//! The brush drop's event within a simulation step: a current that falls through zero does
//! so at its instant in the step, then flows the other way for the rest of it or is held at
//! zero by the brushes (see the module doc of [`super`]), as the shaft does under Coulomb
//! friction ([`super::friction_events`]).

use super::{sign, Simulator};
use crate::model::effects::brush_drop;
use crate::param_id::ParamId;

impl Simulator {
    /// The current went from `i0` through zero over the step (to the other sign, as if the
    /// brushes still opposed it), reaching zero at the share `i0 / (i0 - i1)` of the step
    /// (the current close to linear in time there), the speed interpolated from `w0`. If the
    /// driving voltage `volts - kv w` there (`volts` the step's, the brush drop not taken
    /// off) passes the drop `vb` (paper Eq. 1 with the drop against the current), the
    /// current flows on that way for the rest of the step (the step's exact coefficients over
    /// its share, [`crate::model::discretise::Discrete::over_share`]; with the shaft held,
    /// the held-rotor response); otherwise the brushes hold it at zero. Held at zero to the
    /// step's end instead, a current the supply reverses lagged by one step, a lag the whole
    /// electrical transient kept: at 2 kHz a brush drop beside winding heating misfit the
    /// reversals' current at 1.5 times its noise, and a dead time at the floor of its band
    /// fitted the records better than the true brush drop (docs/measurements/blind-checks.md).
    pub(super) fn current_through_zero_within_step(
        &mut self,
        i0: f32,
        w0: f32,
        volts: f32,
        load: f32,
        shaft_moves: bool,
    ) {
        let (i1, w1) = (self.current.hi, self.omega.hi);
        self.current.set(0.0);
        self.current_stuck = true;
        let share = match i0 != i1 {
            true => (i0 / (i0 - i1)).clamp(0.0, 1.0),
            false => 1.0,
        };
        let left = 1.0 - share;
        let w = match shaft_moves {
            true => w0 + share * (w1 - w0),
            false => w0,
        };
        let drive = volts - self.kv * w;
        let direction = sign(drive);
        let vb = self.effect(ParamId::Vb);
        if left <= 0.0 || direction == 0.0 || drive.abs() <= vb {
            return;
        }
        let applied = volts - brush_drop::voltage(vb, direction);
        if shaft_moves {
            let part = self.disc.over_share(self.dt, self.kv, left).ok();
            let (di, dw) = part
                .as_ref()
                .unwrap_or(&self.disc)
                .increments(0.0, w, applied, load);
            self.omega.set(w + dw);
            self.current.set(di);
        } else {
            self.current
                .set(self.held_rotor_current(0.0, applied, left));
        }
        self.current_stuck = sign(self.current.hi) != direction;
        if self.current_stuck {
            self.current.set(0.0);
        }
    }
}
