//! Memory for the simulators of the Jacobian ([`crate::fit::normal_equations`]): the nominal
//! parameter set, up to two perturbed sets per free parameter and the shifted initial speed,
//! run side by side over each record. On a board they were its largest frame: fourteen
//! simulators, each with the coefficients of a mean over the step (records of averaged
//! readings, [`crate::model::step_mean`]), would not fit its 8 KB stack, so a board keeps
//! this workspace in static RAM (docs/measurements/footprint.md) and lends it to the fit
//! ([`crate::fit::identify::identify_from`]). Without one, each evaluation of the normal
//! equations takes the simulators on its own frame, as the host does.

use crate::capacity::MAX_FREE;
use crate::model::sim::Simulator;
use core::cell::RefCell;

/// Simulators one evaluation of the normal equations runs: the nominal set, an upper and a
/// lower set per free parameter, and the nominal set from the shifted initial speed.
pub const JACOBIAN_SIMS: usize = 2 * MAX_FREE + 2;

/// The simulators of one evaluation of the normal equations.
pub type JacobianSims = heapless::Vec<Simulator, JACOBIAN_SIMS>;

/// A fit's workspace, lent by shared reference (the objective is shared by the whole fit);
/// one evaluation at a time borrows it (an evaluation that finds it borrowed takes its
/// own frame instead).
#[derive(Debug)]
pub struct FitWorkspace {
    sims: RefCell<JacobianSims>,
}

impl FitWorkspace {
    /// An empty workspace (const: a board's static, zero-initialised at link time).
    pub const fn new() -> Self {
        FitWorkspace {
            sims: RefCell::new(heapless::Vec::new()),
        }
    }

    /// The simulators, emptied, unless an evaluation holds them.
    fn borrow_sims(&self) -> Option<core::cell::RefMut<'_, JacobianSims>> {
        let mut sims = self.sims.try_borrow_mut().ok()?;
        sims.clear();
        Some(sims)
    }
}

/// Run `f` on the simulators of `workspace` when one is lent and free, else on simulators
/// on a frame of their own (out of line, so that the workspace's caller does not hold that
/// frame on a board's stack).
pub(crate) fn with_sims<R>(
    workspace: Option<&FitWorkspace>,
    f: impl FnOnce(&mut JacobianSims) -> R,
) -> R {
    match workspace.and_then(FitWorkspace::borrow_sims) {
        Some(mut sims) => f(&mut sims),
        None => on_frame(f),
    }
}

/// `f` on simulators of this frame.
#[inline(never)]
fn on_frame<R>(f: impl FnOnce(&mut JacobianSims) -> R) -> R {
    f(&mut JacobianSims::new())
}

impl Default for FitWorkspace {
    fn default() -> Self {
        FitWorkspace::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::normal_equations::NormalEquations;
    use crate::fit::objective::Objective;
    use crate::fit::space::{ProblemSpec, Space};
    use crate::model::params::ModelParams;
    use crate::model::record::Record;
    use crate::model::synth::Noise;
    use crate::param_id::ParamId;
    use crate::testkit::Owned;

    #[test]
    fn the_normal_equations_in_a_lent_workspace_are_those_on_the_frame() {
        // A noisy record of averaged readings (the board's commissioning records) from a
        // motor with Coulomb friction, its simulators in the workspace or on the frame:
        // the same sums to the bit, and the workspace holds the simulators it ran.
        let p = ModelParams::PAPER_MOTOR.with(ParamId::Tc, 0.02);
        let noise = Noise {
            omega: 0.5,
            current: 0.05,
        };
        let slow = Owned::commissioning_noisy(&p, 600, 2e-3, 24.0, noise, 3);
        let records = [Record {
            averaged: 4,
            ..slow.record(true, false)
        }];
        let mut spec = ProblemSpec::default();
        spec.free(ParamId::Tc);
        let space = Space::new(&spec, true).unwrap();
        let dim = space.dim();
        let u = space.unit(&p.with(ParamId::B, 1.3 * p.get(ParamId::B)));
        let workspace = FitWorkspace::new();
        let on_frame = Objective::new(&records).unwrap();
        let lent = on_frame.with_workspace(Some(&workspace));
        for central in [false, true] {
            let (mut a, mut b) = (NormalEquations::EMPTY, NormalEquations::EMPTY);
            assert!(on_frame.normal_equations(&space, &u[..dim], 1e-3, central, &mut a));
            assert!(lent.normal_equations(&space, &u[..dim], 1e-3, central, &mut b));
            assert_eq!((a.jtj, a.jtr, a.cost), (b.jtj, b.jtr, b.cost));
            assert!(a.cost.sse.is_finite() && a.jtj[0][0] > 0.0);
            // The nominal set, a perturbed one per direction (two when central), and the
            // nominal set from the shifted initial speed (a record that does not start at
            // rest: its first readings are noisy).
            let perturbed = if central { 2 * dim } else { dim };
            assert_eq!(workspace.sims.borrow().len(), 1 + perturbed + 1);
            // Held by another evaluation: it takes its own frame, with the same result.
            let held = workspace.sims.borrow_mut();
            let mut c = NormalEquations::EMPTY;
            assert!(lent.normal_equations(&space, &u[..dim], 1e-3, central, &mut c));
            assert_eq!((a.jtj, a.jtr), (c.jtj, c.jtr));
            drop(held);
        }
    }
}
