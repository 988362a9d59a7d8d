//! Local refinement: Levenberg-Marquardt on the weighted residuals of [`crate::objective`],
//! in the unit coordinates of [`crate::space`], with steps projected onto the bounds.
//!
//! The seed stops at the FFO result; least squares from a good start reaches the noise
//! floor in tens of evaluations. Marquardt scaling (`diag(J^T J)`) plus a tiny multiple of
//! the identity keeps the step defined along directions the data does not pin (speed-only
//! records, see [`crate::identifiability`]): they are simply left where the search put them.

use crate::linalg::{cholesky_solve, Vector};
use crate::objective::{Cost, Objective};
use crate::space::{Space, MAX_FREE};
use core::ops::ControlFlow;

/// Levenberg-Marquardt settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmConfig {
    /// Largest number of Jacobian evaluations.
    pub max_iterations: u32,
    /// Finite-difference step in unit coordinates.
    pub h: f32,
    /// Stop when an accepted step lowers the SSE by less than this fraction.
    pub rel_tol: f64,
    /// Initial damping.
    pub lambda0: f64,
}

impl Default for LmConfig {
    fn default() -> Self {
        LmConfig {
            max_iterations: 40,
            h: 1e-4,
            rel_tol: 1e-6,
            lambda0: 1e-3,
        }
    }
}

/// Progress of one refinement iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmProgress {
    /// Iterations (Jacobians) done.
    pub iteration: u32,
    /// Evaluations spent by the refinement so far.
    pub evaluations: u32,
    /// Current cost.
    pub cost: Cost,
}

/// Result of a refinement.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmResult {
    /// Final point in unit coordinates.
    pub u: [f32; MAX_FREE],
    /// Cost there.
    pub cost: Cost,
    /// Evaluations spent.
    pub evaluations: u32,
    /// Iterations (Jacobians) done.
    pub iterations: u32,
    /// False when stopped by the caller.
    pub completed: bool,
}

/// Refine from `u0`. `progress` is called after every iteration; `Break` stops early.
/// Returns `None` when `u0` itself cannot be simulated.
pub fn levenberg_marquardt(
    objective: &Objective,
    space: &Space,
    u0: &[f32],
    cfg: &LmConfig,
    mut progress: impl FnMut(&LmProgress) -> ControlFlow<()>,
) -> Option<LmResult> {
    let dim = space.dim();
    let mut u = [0.0f32; MAX_FREE];
    u[..dim].copy_from_slice(&u0[..dim]);
    let mut ne = objective.normal_equations(space, &u[..dim], cfg.h, false)?;
    let mut evaluations = ne.simulations;
    let mut lambda = cfg.lambda0;
    let mut iterations = 0;
    let mut completed = true;
    'outer: while iterations < cfg.max_iterations {
        iterations += 1;
        let max_diag = (0..dim).map(|i| ne.jtj[i][i]).fold(0.0f64, f64::max);
        if max_diag <= 0.0 {
            break;
        }
        // Inner loop: raise damping until a step lowers the cost.
        loop {
            let mut a = ne.jtj;
            for (i, row) in a.iter_mut().enumerate().take(dim) {
                row[i] += lambda * (ne.jtj[i][i] + 1e-9 * max_diag);
            }
            // Minimising |r|^2 with r = measured - sim: J^T J du = -J^T r.
            let mut rhs: Vector = [0.0; MAX_FREE];
            for i in 0..dim {
                rhs[i] = -ne.jtr[i];
            }
            let step = cholesky_solve(&a, &rhs, dim);
            let mut trial = u;
            if let Some(du) = step {
                for i in 0..dim {
                    trial[i] = (u[i] + du[i] as f32).clamp(0.0, 1.0);
                }
            }
            let trial_cost = if step.is_some() && trial[..dim] != u[..dim] {
                evaluations += 1;
                objective.cost(&space.params(&trial[..dim]))
            } else {
                None
            };
            match trial_cost {
                Some(c) if c.sse < ne.cost.sse => {
                    let gain = (ne.cost.sse - c.sse) / ne.cost.sse.max(f64::MIN_POSITIVE);
                    u = trial;
                    lambda = (lambda / 5.0).max(1e-12);
                    match objective.normal_equations(space, &u[..dim], cfg.h, false) {
                        Some(n) => {
                            evaluations += n.simulations;
                            ne = n;
                        }
                        None => break 'outer,
                    }
                    let report = LmProgress {
                        iteration: iterations,
                        evaluations,
                        cost: ne.cost,
                    };
                    if progress(&report).is_break() {
                        completed = false;
                        break 'outer;
                    }
                    if gain < cfg.rel_tol {
                        break 'outer;
                    }
                    break;
                }
                _ => {
                    lambda *= 4.0;
                    if lambda > 1e10 {
                        break 'outer;
                    }
                }
            }
        }
    }
    Some(LmResult {
        u,
        cost: ne.cost,
        evaluations,
        iterations,
        completed,
    })
}
