//! Local refinement: Levenberg-Marquardt on the weighted residuals of [`crate::fit::objective`],
//! in the unit coordinates of [`crate::fit::space`], with steps projected onto the bounds.
//!
//! The seed stops at the FFO result; least squares from a good start reaches the noise
//! floor in tens of evaluations. Marquardt scaling (`diag(J^T J)`) plus a tiny multiple of
//! the identity keeps the step defined along directions the data does not pin (speed-only
//! records, see [`crate::fit::identifiability`]): they are simply left where the search put them.

use crate::capacity::MAX_FREE;
use crate::fit::linalg::{cholesky_solve, Vector};
use crate::fit::normal_equations::NormalEquations;
use crate::fit::objective::{Cost, Objective};
use crate::fit::space::Space;
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
    /// Or by less than this much (0: no absolute tolerance): a refit that needs the SSE to
    /// a set number of residual variances, not to its last digits (the profile check's).
    /// Such a refit also ends where the undamped step's local model gains under half of
    /// it, or, the damping raised from its start, the damped step's; after a step whose
    /// model held and left under half of it ([`model_held`]); and at the first stall of its
    /// forward differences (no central phase).
    pub abs_tol: f64,
    /// Initial damping.
    pub lambda0: f64,
    /// Or stop at a point whose SSE, less twice the gain its undamped Gauss-Newton step
    /// predicts, is still at least this (infinite: never): a caller that needs to know only
    /// whether the SSE comes under a level (the profile check's) spends nothing more once
    /// the local model says it will not.
    pub needed_below: f64,
}

impl Default for LmConfig {
    fn default() -> Self {
        LmConfig {
            max_iterations: 40,
            h: 1e-4,
            rel_tol: 1e-6,
            abs_tol: 0.0,
            lambda0: 1e-3,
            needed_below: f64::INFINITY,
        }
    }
}

/// Progress of one refinement iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LmProgress<'u> {
    /// Iterations (Jacobians) done.
    pub iteration: u32,
    /// Evaluations spent by the refinement so far.
    pub evaluations: u32,
    /// Current cost.
    pub cost: Cost,
    /// Current point, in unit coordinates (the cost's).
    pub u: &'u [f32],
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
    // One instance of the refinement for every caller (on the board: the pipeline's, the
    // profile check's), not one per closure type.
    progress: &mut dyn FnMut(&LmProgress) -> ControlFlow<()>,
) -> Option<LmResult> {
    let dim = space.dim();
    let mut u = [0.0f32; MAX_FREE];
    u[..dim].copy_from_slice(&u0[..dim]);
    // Forward differences while far from the optimum; central ones (twice the cost, O(h^2)
    // accurate) once forward ones stall (no damped step lowers the cost), so that the last
    // digits of an ill-conditioned fit are not lost to the O(h) error of a forward-difference
    // gradient. An accepted step that gains less than `rel_tol` has converged: neither its
    // normal equations nor a central phase follow (together they cost half of the board
    // pipeline's evaluations and changed no result measurably: docs/measurements/benchmark.md).
    let mut central = false;
    let mut ne = NormalEquations::EMPTY;
    if !objective.normal_equations(space, &u[..dim], cfg.h, central, &mut ne) {
        return None;
    }
    let mut evaluations = ne.simulations;
    let mut lambda = cfg.lambda0;
    let mut iterations = 0;
    let mut completed = true;
    while iterations < cfg.max_iterations {
        if local_model_ends(&ne, &u, dim, cfg) {
            break;
        }
        iterations += 1;
        let outcome = lm_step(objective, space, &mut u, &mut ne, &mut lambda, cfg, central);
        let (StepOutcome::Improved { evaluations: e }
        | StepOutcome::Converged { evaluations: e }
        | StepOutcome::Stalled { evaluations: e }
        | StepOutcome::Failed { evaluations: e }) = outcome;
        evaluations += e;
        // Every iteration is reported, a step taken or not: a board feeds its watchdog and
        // hears an abort there, so no run of rejected steps goes unreported.
        let report = LmProgress {
            iteration: iterations,
            evaluations,
            cost: ne.cost,
            u: &u[..dim],
        };
        if progress(&report).is_break() {
            completed = false;
            break;
        }
        let stalled = match outcome {
            StepOutcome::Improved { .. } => false,
            StepOutcome::Stalled { .. } => true,
            StepOutcome::Converged { .. } | StepOutcome::Failed { .. } => break,
        };
        if stalled {
            // A refinement to a tolerance in SSE units needs no last digits: no damped step
            // of the forward-difference model gains it, and central differences are not
            // tried (on the profile check's refits they found nothing that counted, at 2
            // dim + 1 simulations and a second run of damped steps each).
            if central || cfg.abs_tol > 0.0 {
                break;
            }
            central = true;
            lambda = cfg.lambda0;
            if !objective.normal_equations(space, &u[..dim], cfg.h, central, &mut ne) {
                break;
            }
            evaluations += ne.simulations;
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

/// Whether the local model ends the refinement at `u` before another step: the undamped
/// Gauss-Newton step (`du = -H^-1 g` with `g = J^T r`, `H = J^T J`, the bounds held as
/// [`projected_step`] holds them) predicts the gain `g^T H^-1 g`, and
/// - an SSE under [`LmConfig::needed_below`] is out of reach: the SSE less twice that gain
///   is still at least it. Twice: where the model bends the step gains other than
///   predicted (on the virtual board's run of the MCU table's motor 72, a profile's first
///   step gained 944 residual units where 1,031 were predicted);
/// - or twice that gain is under [`LmConfig::abs_tol`]: no step gains the tolerance by the
///   local model ([`too_small`]).
///
/// Never where the step cannot be solved.
fn local_model_ends(ne: &NormalEquations, u: &[f32; MAX_FREE], dim: usize, cfg: &LmConfig) -> bool {
    if !cfg.needed_below.is_finite() && cfg.abs_tol <= 0.0 {
        return false;
    }
    let Some(gain) = undamped_gain(ne, u, dim) else {
        return false;
    };
    ne.cost.sse - 2.0 * gain >= cfg.needed_below || too_small(gain, cfg)
}

/// The gain `g^T H^-1 g` the undamped Gauss-Newton step from `u` predicts (the bounds held
/// as [`projected_step`] holds them); None where it cannot be solved.
fn undamped_gain(ne: &NormalEquations, u: &[f32; MAX_FREE], dim: usize) -> Option<f64> {
    let max_diag = (0..dim).map(|i| ne.jtj[i][i]).fold(0.0f64, f64::max);
    let du = projected_step(ne, u, 0.0, max_diag, dim)?;
    Some(-(0..dim).map(|i| ne.jtr[i] * du[i]).sum::<f64>())
}

/// Whether a step that lowered the SSE by `fell` where its local model predicted `predicted`
/// ends a refinement to a tolerance ([`LmConfig::abs_tol`]) without normal equations at the
/// new point: the model held over the step (it predicted the fall to within half the
/// tolerance), and what it leaves to gain beyond it (the undamped step's `reachable` less
/// the fall) is under half the tolerance: by the old point's model, the new point's would
/// end the refinement ([`too_small`]; a guess, as every local model's). The profile check's refits that take one step, from their
/// profile line onto the valley's floor, spared the 1 + dim simulations of those normal
/// equations (docs/measurements/commissioning.md).
fn model_held(fell: f64, predicted: f64, reachable: f64, cfg: &LmConfig) -> bool {
    cfg.abs_tol > 0.0
        && 2.0 * (fell - predicted).abs() < cfg.abs_tol
        && too_small(reachable - fell, cfg)
}

/// Whether a step whose local model predicts the SSE to fall by `gain` is not worth its
/// simulation: twice the gain is under [`LmConfig::abs_tol`], so that taken, it would end
/// the refinement by the tolerance anyway (twice, as for [`LmConfig::needed_below`]: where
/// the model bends a step gains other than predicted). The check's refits start on a
/// parameter's profile line, most at their optimum already, where the damping was raised
/// step by step until no step gained, with central differences and the same again after
/// it: 25-50 simulations to learn that. Where the cost is rough at the tolerance's scale (a
/// Coulomb friction's stick or slip decided per sample: one float's step of a parameter
/// moved the SSE of the MCU table's motor 14 by 1.3 residual variances), what a refit
/// finds below it is luck, not the data's (docs/measurements/commissioning.md).
fn too_small(gain: f64, cfg: &LmConfig) -> bool {
    cfg.abs_tol > 0.0 && 2.0 * gain < cfg.abs_tol
}

#[derive(Clone, Copy)]
enum StepOutcome {
    /// A step was accepted, with its normal equations.
    Improved { evaluations: u32 },
    /// A step was accepted that lowers the SSE by less than `rel_tol`: converged. Its
    /// normal equations are not computed (nothing would use them); `ne.cost` is its cost.
    Converged { evaluations: u32 },
    /// No step lowers the cost, whatever the damping; or, in a refinement to a tolerance,
    /// none by its local model gains half of it, damped from the start ([`too_small`]).
    Stalled { evaluations: u32 },
    /// The new point's Jacobian could not be simulated.
    Failed { evaluations: u32 },
}

/// One Levenberg-Marquardt iteration: raise the damping until a step lowers the cost, then
/// take it and recompute the normal equations there (unless it converged).
fn lm_step(
    objective: &Objective,
    space: &Space,
    u: &mut [f32; MAX_FREE],
    ne: &mut NormalEquations,
    lambda: &mut f64,
    cfg: &LmConfig,
    central: bool,
) -> StepOutcome {
    let dim = space.dim();
    let mut evaluations = 0;
    let max_diag = (0..dim).map(|i| ne.jtj[i][i]).fold(0.0f64, f64::max);
    if max_diag <= 0.0 {
        return StepOutcome::Stalled { evaluations };
    }
    // What the undamped step predicts, for a refinement to a tolerance ([`model_held`]).
    let reachable = match cfg.abs_tol > 0.0 {
        true => undamped_gain(ne, u, dim),
        false => None,
    };
    // Whether the damping was changed in this iteration (it starts where the last one left it).
    let mut adjusted = false;
    while *lambda <= 1e10 {
        let mut trial = *u;
        let moved = match projected_step(ne, u, *lambda, max_diag, dim) {
            // The damped step gains less the more it is damped: once it is too small, so is
            // every later one. At a damping the last iteration left high, from the start
            // again first (the undamped step gains more, [`local_model_ends`]).
            Some(du) if too_small(predicted_gain(ne, &du, dim), cfg) => {
                if adjusted || *lambda <= cfg.lambda0 {
                    return StepOutcome::Stalled { evaluations };
                }
                *lambda = cfg.lambda0;
                adjusted = true;
                continue;
            }
            Some(du) => {
                for i in 0..dim {
                    trial[i] = (u[i] + du[i] as f32).clamp(0.0, 1.0);
                }
                trial[..dim] != u[..dim]
            }
            None => false,
        };
        let trial_cost = if moved {
            evaluations += 1;
            objective.cost(&space.params(&trial[..dim]))
        } else {
            None
        };
        match trial_cost {
            Some(c) if c.sse < ne.cost.sse => {
                let fell = ne.cost.sse - c.sse;
                let gain = fell / ne.cost.sse.max(f64::MIN_POSITIVE);
                *lambda = (*lambda / 5.0).max(1e-12);
                // Only a refinement to a tolerance asks (`reachable`): not on a fit's hot path.
                let held = reachable.is_some_and(|reachable| {
                    let mut taken: Vector = [0.0; MAX_FREE];
                    for i in 0..dim {
                        taken[i] = f64::from(trial[i]) - f64::from(u[i]);
                    }
                    model_held(fell, predicted_gain(ne, &taken, dim), reachable, cfg)
                });
                if gain < cfg.rel_tol || fell < cfg.abs_tol || held {
                    // The refinement ends here: the cost of the point is all it needs (the
                    // same value the normal equations would give, from the same sums).
                    *u = trial;
                    ne.cost = c;
                    return StepOutcome::Converged { evaluations };
                }
                // The point moves only with its normal equations, so that `u` and `ne.cost`
                // always belong together.
                return if objective.normal_equations(space, &trial[..dim], cfg.h, central, ne) {
                    evaluations += ne.simulations;
                    *u = trial;
                    StepOutcome::Improved { evaluations }
                } else {
                    StepOutcome::Failed { evaluations }
                };
            }
            _ => {
                *lambda *= 4.0;
                adjusted = true;
            }
        }
    }
    StepOutcome::Stalled { evaluations }
}

/// The fall of the SSE that the local model (`r + J du`) predicts for the step `du`:
/// `-(2 g^T du + du^T H du)` with `g = J^T r`, `H = J^T J`.
fn predicted_gain(ne: &NormalEquations, du: &Vector, dim: usize) -> f64 {
    let mut quadratic = 0.0;
    for i in 0..dim {
        for k in 0..dim {
            quadratic += du[i] * ne.jtj[i][k] * du[k];
        }
    }
    -(2.0 * (0..dim).map(|i| ne.jtr[i] * du[i]).sum::<f64>() + quadratic)
}

/// Damped Gauss-Newton step `(J^T J + lambda D) du = -J^T r` with bound constraints handled
/// by an active set: a coordinate on a bound whose step points outwards is held and the step
/// solved again for the others, so that the fit can slide along a bound (a speed-only fit
/// whose flat valley meets the edge of the box) instead of stalling there. (A frame of its
/// own: its matrices are not on the stack while the normal equations are built.)
#[inline(never)]
fn projected_step(
    ne: &NormalEquations,
    u: &[f32; MAX_FREE],
    lambda: f64,
    max_diag: f64,
    dim: usize,
) -> Option<Vector> {
    let mut held = [false; MAX_FREE];
    for _ in 0..=dim {
        let mut a = ne.jtj;
        let mut rhs: Vector = [0.0; MAX_FREE];
        for i in 0..dim {
            a[i][i] += lambda * (ne.jtj[i][i] + 1e-9 * max_diag);
            // Minimising |r|^2 with r = measured - sim.
            rhs[i] = -ne.jtr[i];
        }
        for i in 0..dim {
            if held[i] {
                for k in 0..dim {
                    a[i][k] = 0.0;
                    a[k][i] = 0.0;
                }
                a[i][i] = 1.0;
                rhs[i] = 0.0;
            }
        }
        let du = cholesky_solve(&a, &rhs, dim)?;
        let mut changed = false;
        for i in 0..dim {
            let outwards = (u[i] <= 0.0 && du[i] < 0.0) || (u[i] >= 1.0 && du[i] > 0.0);
            if outwards && !held[i] {
                held[i] = true;
                changed = true;
            }
        }
        if !changed {
            return Some(du);
        }
    }
    None
}

#[cfg(test)]
#[path = "refine_tests.rs"]
mod tests;
