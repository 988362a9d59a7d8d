//! The profile check's valley walk ([`super`], module doc): from the optimum along each
//! flat direction towards the box's edge and least squares back down onto the valley,
//! recording how far each parameter lies from the optimum where the valley fits as well.

use super::{stopping_at, Runs};
use crate::capacity::MAX_FREE;
use crate::fit::identifiability::Identifiability;
use crate::fit::objective::{Cost, Objective};
use crate::fit::refine::LmConfig;
use crate::fit::space::Space;
use crate::model::params::ModelParams;

/// A point of the valley walk fits as well as the optimum when its cost rises by at most
/// this much over the optimum's, in units of the residual variance (`d chi^2 <= 1`: within
/// one standard deviation, data that cannot tell the two apart). Relative to the residual's
/// variance, so that a model that misfits (a residual several times the noise) is not given
/// a wider valley than one that fits.
pub(super) const VALLEY_FIT: f64 = 1.0;
/// Fractions of the way to the box's edge the valley walk starts from, nearest first: a
/// start whose descent ends off the valley ends the walk along that way.
pub(super) const WALK: [f32; 2] = [0.5, 1.0];
/// Along a direction the data informs (loosely), the walk starts first this many of its
/// local deviations out, where that is nearer than the first of [`WALK`]: the local
/// quadratic puts the cost there 100 residual variances up. Where the valley is a bowl, the
/// descent from there comes back (and ends the walk that way) in a step or two, where one
/// from half way to the box's edge crawled back down a wall; where it bends, the descent
/// lands on it away from the optimum, and the walk goes on from [`WALK`]. (What this gives
/// up: a valley that comes back within reach of the optimum's fit only beyond ten
/// deviations, behind a rise, is no longer looked for along a loose direction; on the
/// benchmarks no verdict changed, docs/measurements/commissioning.md.)
pub(super) const NEAR: f32 = 10.0;

/// A descent of the walk that lands nearer the optimum than this share of its start's
/// distance from it (in unit coordinates) came back: the valley holds no equal fit that
/// far out that way, and a descent from farther out (the edge) comes back the same way.
/// (A landing as far out in another direction, where the valley bends, has not come
/// back: the walk goes on to the edge.) On the four MCU benchmark motors whose viscous
/// loss is a per cent of their Coulomb torque (B known to 11-15 %, not pinned), every
/// descent came back to within 3 % of the way and every other parameter to within 0.1 of
/// its local deviation; the descents from the edge had cost a third of the check's
/// 310-400 simulations (docs/measurements/commissioning.md).
pub(super) const CAME_BACK: f32 = 0.25;

/// The walk's starts along a direction of deviation `std` whose box edge lies `edge` away
/// (both in natural units along it), as fractions of the way to the edge: [`NEAR`]
/// deviations first where that is nearer than the first of [`WALK`] (never along a
/// numerically flat direction, `std` infinite), then [`WALK`].
pub(super) fn starts(std: f32, edge: f32) -> impl Iterator<Item = f32> {
    let near = NEAR * std / edge;
    (near < WALK[0]).then_some(near).into_iter().chain(WALK)
}

/// Whether the descent from `start` that landed at `landed` came back to the optimum
/// `u0` ([`CAME_BACK`]).
pub(super) fn came_back(u0: &[f32], start: &[f32], landed: &[f32]) -> bool {
    let (mut landed_sq, mut start_sq) = (0.0f32, 0.0f32);
    for ((o, s), l) in u0.iter().zip(start).zip(landed) {
        landed_sq += (l - o) * (l - o);
        start_sq += (s - o) * (s - o);
    }
    landed_sq < CAME_BACK * CAME_BACK * start_sq
}

/// The valley walk (module doc): for every free parameter, its largest distance from the
/// optimum over the points of the flat directions' valley that fit as well (in its own
/// unit; `sigma2` the residual variance).
#[inline(never)]
#[allow(clippy::too_many_arguments)]
pub(super) fn walk_the_valley(
    id: &Identifiability,
    objective: &Objective,
    space: &Space,
    at: &ModelParams,
    cost: &Cost,
    sigma2: f64,
    lm: &LmConfig,
    runs: &mut Runs,
) -> [f64; MAX_FREE] {
    let dim = space.dim();
    let free = space.free();
    let u0 = space.unit(at);
    let mut farthest = [0.0f64; MAX_FREE];
    // A point is judged against VALLEY_FIT: the descent onto the valley stops at a tenth
    // of it (the crawl along the valley's floor that follows would not change the verdict).
    let walk_lm = stopping_at(lm, 0.1 * VALLEY_FIT, sigma2);
    for direction in &id.unpinned {
        // The direction in unit coordinates (natural = per_unit * unit).
        let mut du = [0.0f32; MAX_FREE];
        for i in 0..dim {
            du[i] = (f64::from(direction.components[i])
                / free[i].natural_per_unit(at.get(free[i].id))) as f32;
        }
        for sign in [-1.0f32, 1.0] {
            // How far along `sign du` the box allows.
            let mut edge = f32::INFINITY;
            for i in 0..dim {
                let d = sign * du[i];
                if d > 0.0 {
                    edge = edge.min((1.0 - u0[i]) / d);
                } else if d < 0.0 {
                    edge = edge.min(-u0[i] / d);
                }
            }
            if !edge.is_finite() || edge <= 0.0 {
                continue;
            }
            for fraction in starts(direction.std, edge) {
                let mut start = [0.0f32; MAX_FREE];
                for i in 0..dim {
                    start[i] = (u0[i] + sign * fraction * edge * du[i]).clamp(0.0, 1.0);
                }
                // A descent that has come back goes on to the optimum, or near it: it ends
                // at its first point that came back (on the MCU's slowest motor, 31 of the
                // descent's 71 simulations; no verdict of the benchmarks changed:
                // docs/measurements/commissioning.md).
                let back = |u: &[f32]| came_back(&u0[..dim], &start[..dim], u);
                let Some(r) = runs.refine(objective, space, &start[..dim], &walk_lm, &back) else {
                    continue;
                };
                if (r.cost.sse - cost.sse) / sigma2 > VALLEY_FIT {
                    break;
                }
                for (i, f) in free.iter().enumerate() {
                    let d = f64::from((f.value(r.u[i]) - at.get(f.id)).abs());
                    farthest[i] = farthest[i].max(d);
                }
                if came_back(&u0[..dim], &start[..dim], &r.u[..dim]) {
                    break;
                }
            }
        }
    }
    farthest
}
