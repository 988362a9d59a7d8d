//! The profile check of a local uncertainty: where the fit has flat directions, or a wide
//! deviation, is a parameter the local analysis calls pinned pinned along the whole valley?
//!
//! The Fisher information ([`super::identifiability`]) is local: a parameter whose gradient
//! has no component along the flat directions at the optimum is called pinned with the
//! delta-method deviation `s`. When the equal-fit set is curved (a speed-only record, where
//! paper Eq. 6 leaves two directions of (Ra, La, J, B, Kv) free and `Kv` is `c3/c1` only while
//! back-EMF dominates viscous friction), the valley bends towards that parameter away from
//! the optimum, and `s` is optimistic: over 10,000 speed-only benchmark motors, 54 % of the
//! parameters so pinned lay within 3 `s` of the truth.
//!
//! The check is the profile likelihood at `p +- 3 s`: the parameter fixed there, every other
//! free parameter refitted by least squares from where the local quadratic puts it (the
//! parameter's profile line, [`ProfileLines`]; from the optimum with the
//! others unmoved a refit along a narrow valley starts high on its wall: the line took the
//! profiles' cost on the commissioning benchmark down by a quarter, 149 to 113
//! simulations per checked motor without a flat direction, the verdicts alike), the rise of the cost measured
//! in units of the residual variance (`d chi^2`). For a parameter the data pins as the local
//! analysis says, `d chi^2` is about 9; where it is less, the deviation that the profile
//! implies, `3 s / sqrt(d chi^2)`, is larger than `s`, and the larger of the two sides is
//! reported instead. A parameter whose deviation so widened exceeds
//! [`super::identifiability::PINNED_STD`] in its natural coordinate is not pinned.
//!
//! The profile refits along a valley that bends slowly; one that bends far from the optimum
//! escapes a least-squares refit that starts at the optimum (it stops on the valley's side
//! in small steps). So the valley is also walked: from the optimum along each flat
//! direction to half way to the box's edge, both ways, and least squares from there back
//! down onto the valley (across it, where the fit is stiff, which it does well); where
//! that lands on the valley away from the optimum, from all the way to the edge too (where
//! the descent from half way already ends above the optimum's fit, the valley holds no
//! equal fit that far out, and one from farther up ends higher: on the commissioning
//! benchmark, stopping there changed no verdict of the 1,000 motors and spared 8 % of the
//! 90th percentile's simulations; where it comes back to the optimum, [`walk::CAME_BACK`], the
//! valley is a bowl that does not reach half way, and one from the edge comes back too:
//! stopping there changed no verdict of the benchmarks and spared 18-23 % of the
//! commissioning benchmark's 90th percentile at the QEMU plant's settings and on instant
//! readings; a descent ends at its first point that came back, sparing 8-13 % more).
//! Each point it lands on that fits as well as the optimum (a rise of at most
//! [`walk::VALLEY_FIT`] in chi^2) is an equally good answer the data cannot tell apart: a
//! parameter that differs there from the optimum by more than three local deviations is
//! touched by the flat direction after all (the valley bends into it), and it is not
//! pinned.
//!
//! The walk runs only when the local analysis found a direction it does not pin. The
//! profiles run then for every pinned parameter where that direction is numerically flat;
//! where it is informed, only more loosely than pinned allows (B beside a Coulomb torque a
//! hundred times its viscous one), for a pinned parameter whose profile reaches along it
//! by one of its deviations or more ([`reaches_along`]: on the MCU table's motors 14 and
//! 72, whose B is loose, the fits 224 -> 142 and 200 -> 167 M instructions; the
//! commissioning benchmark's verdicts alike, one parameter of the identification
//! benchmark's 39,676 newly beyond 3 σ, docs/measurements/commissioning.md). And, with full rank (a
//! record with current, on a drive board) or beside a loose direction, for a pinned
//! parameter whose deviation exceeds [`CURVED_STD`]: there too the
//! valley can bend within `+- 3 s` (a motor whose viscous loss dwarfs its back-EMF, where
//! J, B, Kv and tc slide together). On the commissioning benchmark (1,000 motors of the
//! box, docs/measurements/commissioning.md) that took the pinned estimates within 3 `s` of
//! the truth from 98.8 % to 99.1 %, at a median of 97 simulations on the 13 % of the
//! motors it runs on. Where every deviation is smaller, the local analysis stands and
//! nothing is spent.

use crate::capacity::MAX_FREE;
use crate::fit::identifiability::{
    Direction, Identifiability, ParamCertainty, ProfileLines, PINNED_STD,
};
use crate::fit::objective::{Cost, Objective};
use crate::fit::refine::{levenberg_marquardt, LmConfig, LmResult};
use crate::fit::space::Space;
use crate::model::params::ModelParams;
use crate::param_id::ParamId;
use core::ops::ControlFlow;
use walk::{walk_the_valley, WALK};

#[path = "profile_check_walk.rs"]
mod walk;

/// How many local standard deviations the profile steps to each side.
const STEPS: f64 = 3.0;
/// A profile's refit stops once an accepted step lowers the cost by less than this, in
/// units of the residual variance: the rise it measures is compared with 9, and a tenth
/// of it is within the rise's own scatter.
const PROFILE_TOL: f64 = 0.5;
/// [`PROFILE_TOL`] where the fit has a numerically flat direction (a speed-only record's
/// paper Eq. 6 valley): a refit along such a valley crawls in steps that each gain less
/// than a tenth of a residual variance while together they gain several, and stopped at
/// the first, it overstated the rise and left the deviation too narrow. On the
/// identification benchmark's speed-only records (docs/measurements/benchmark.md) the
/// parameters pinned within 3 deviations went from 97.4 % to 99.5 % with this; where every
/// direction not pinned is informed (a board's records with current), refits stop in a
/// step or two, and the coarser tolerance stands.
const PROFILE_TOL_FLAT: f64 = 0.002;
/// A profile's refit, where the fit has no numerically flat direction, stops once the cost
/// it can still reach ([`LmConfig::needed_below`]) is this many residual variances above
/// the optimum's: a rise of 9 or more widens nothing (`3 s / sqrt(rise) <= s`), and 18
/// leaves the local model's prediction a margin of 9. Where a deviation holds the batch
/// means' wider spread ([`crate::fit::identifiability`]), its profile starts far above 9:
/// on the virtual board's run of the MCU table's motor 72 (B loosely informed), 25-900
/// residual variances, and the ten refits took 264 simulations to end there, 97 now; on
/// the MCU that fit went from 317 to 259 M instructions
/// (docs/measurements/commissioning.md). Not where a direction is numerically flat: a
/// refit there crawls along the valley in many small steps (as [`PROFILE_TOL_FLAT`]), and
/// the local model sees one at a time.
const PROFILE_NEEDED: f64 = 18.0;

/// A pinned parameter whose local deviation exceeds this (in its natural coordinate: 3 %
/// for a log coordinate) is profiled even where the fit has no flat direction: its
/// `+- 3 s` steps are long enough for the valley's bend to show. Where every deviation is
/// smaller (the median motor on a board's records: 0.01-0.2 %), the model is close to
/// linear over the steps and nothing is spent. At 1 % the check ran on 28 % of the
/// commissioning benchmark's motors for 99.2 % within 3 `s`, at 3 % on 13 % for 99.1 %.
const CURVED_STD: f64 = 0.03;

/// Whether `certainty` is profiled: pinned, and either its deviation is wide enough for
/// the valley to bend within the steps ([`CURVED_STD`]) or its profile (`lines`, the
/// parameters' profile lines of [`ProfileLines`]) reaches along a direction the data does
/// not pin ([`reaches_along`]).
fn profiled(
    id: &Identifiability,
    space: &Space,
    lines: &ProfileLines,
    certainty: &ParamCertainty,
) -> bool {
    let Some(std) = certainty.std.filter(|_| certainty.pinned) else {
        return false;
    };
    let Some(k) = space.position(certainty.id) else {
        return false;
    };
    let natural = f64::from(std) / space.free()[k].natural_scale(certainty.value);
    natural > CURVED_STD
        || id
            .unpinned
            .iter()
            .any(|d| reaches_along(d, &lines[k], natural))
}

/// Whether a profile at `+- 3 s` (`s` the parameter's local deviation `natural`, in its
/// natural coordinate) along its profile `line` (natural coordinates per unit of its own)
/// reaches along `direction` by one of its deviations `s_d` or more: always where the
/// direction is numerically flat; where it is informed loosely, the profile's start moves
/// along it by `3 s |line . c| / s_d` of them (`c` the direction's unit vector). Less, and
/// the profile stays within a deviation of the optimum along it, where the valley has no
/// room to bend; a parameter so profiled before measured its rise at 9 to the profile's
/// own scatter (docs/measurements/commissioning.md).
fn reaches_along(direction: &Direction, line: &[f32; MAX_FREE], natural: f64) -> bool {
    if !direction.std.is_finite() {
        return true;
    }
    let along: f64 = line
        .iter()
        .zip(&direction.components)
        .map(|(l, c)| f64::from(*l) * f64::from(*c))
        .sum();
    STEPS * natural * along.abs() >= f64::from(direction.std)
}

/// Whether the check has work: a parameter to profile ([`profiled`]; `lines` the profile
/// lines of the analysis that made `id`).
pub fn applies(id: &Identifiability, space: &Space, lines: &ProfileLines) -> bool {
    id.params.iter().any(|c| profiled(id, space, lines, c))
}

/// Most least-squares runs the check of `id` makes: the walk's (both ways along each
/// direction not pinned, from each of [`WALK`], and along a loose one from nearer first,
/// [`walk::NEAR`]) and two profiles per profiled parameter.
pub fn runs(id: &Identifiability, space: &Space, lines: &ProfileLines) -> u32 {
    let profiles = id
        .params
        .iter()
        .filter(|c| profiled(id, space, lines, c))
        .count();
    let walks: usize = id
        .unpinned
        .iter()
        .map(|d| 2 * (WALK.len() + usize::from(d.std.is_finite())))
        .sum();
    (walks + 2 * profiles) as u32
}

/// The check's least-squares runs, one after another: the evaluations they spent and the
/// caller's progress, called after every iteration with the evaluations spent so far (a
/// board feeds its watchdog there and hears an abort). Once the caller stops the check, no
/// run starts.
struct Runs<'p> {
    spent: u32,
    progress: &'p mut dyn FnMut(u32) -> ControlFlow<()>,
    stopped: bool,
}

impl Runs<'_> {
    /// Least squares on `space` from `start`, ended at the first point that `done` accepts
    /// (with its cost); None when it cannot start or the check was stopped (before or
    /// during it).
    fn refine(
        &mut self,
        objective: &Objective,
        space: &Space,
        start: &[f32],
        lm: &LmConfig,
        done: &dyn Fn(&[f32]) -> bool,
    ) -> Option<LmResult> {
        if self.stopped {
            return None;
        }
        let base = self.spent;
        let progress = &mut *self.progress;
        let mut stop = false;
        let r = levenberg_marquardt(objective, space, start, lm, &mut |lp| {
            let flow = progress(base + lp.evaluations);
            stop |= flow.is_break();
            match done(lp.u) {
                true => ControlFlow::Break(()),
                false => flow,
            }
        });
        if let Some(r) = &r {
            self.spent = base + r.evaluations;
        }
        // A report after every run too, one that could not start included.
        stop = stop || (self.progress)(self.spent).is_break();
        self.stopped |= stop;
        r.filter(|_| !stop)
    }
}

/// Widen the deviations of `id`'s pinned parameters by the profile check (module doc), for
/// the fit `at` with cost `cost`, searched in `space` (its bounds and scales); the
/// evaluations it spends are added to `id.evaluations`. `progress` is called after every
/// least-squares iteration with the evaluations the check has spent; when it stops the
/// check, no parameter is left pinned (none was confirmed) and the result is false.
/// Not inlined, nor the walk and the profiles: their frames are on the stack only while
/// they run, one at a time, not throughout the identification's.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
pub fn widen(
    id: &mut Identifiability,
    lines: &ProfileLines,
    objective: &Objective,
    space: &Space,
    at: &ModelParams,
    cost: &Cost,
    lm: &LmConfig,
    progress: &mut dyn FnMut(u32) -> ControlFlow<()>,
) -> bool {
    if !applies(id, space, lines) {
        return true;
    }
    let dof = (cost.residuals as f64 - space.dim() as f64).max(1.0);
    let sigma2 = (cost.sse / dof).max(f64::MIN_POSITIVE);
    let mut runs = Runs {
        spent: 0,
        progress,
        stopped: false,
    };
    let farthest = walk_the_valley(id, objective, space, at, cost, sigma2, lm, &mut runs);
    let flat = id.unpinned.iter().any(|d| d.std.is_infinite());
    // The rise is wanted to a tenth of the 9 it is compared with, and only under 9.
    let profile_lm = match flat {
        true => stopping_at(lm, PROFILE_TOL_FLAT, sigma2),
        false => LmConfig {
            needed_below: cost.sse + PROFILE_NEEDED * sigma2,
            ..stopping_at(lm, PROFILE_TOL, sigma2)
        },
    };
    let mut profile = [false; MAX_FREE];
    for (k, certainty) in id.params.iter().enumerate() {
        profile[k] = profiled(id, space, lines, certainty);
    }
    for (certainty, _) in id.params.iter_mut().zip(profile).filter(|(_, p)| *p) {
        let Some(std) = certainty.std else {
            continue;
        };
        let Some(k) = space.position(certainty.id) else {
            continue;
        };
        let free = &space.free()[k];
        let (lo, hi) = (free.lo, free.hi);
        let line = lines[k];
        if farthest[k] > STEPS * f64::from(std) {
            certainty.pinned = false;
            certainty.std = None;
            continue;
        }
        let mut widest = f64::from(std);
        for side in [-1.0, 1.0] {
            let value = f64::from(certainty.value) + side * STEPS * f64::from(std);
            if value <= f64::from(lo) || value >= f64::from(hi) {
                // The bound ends the valley on this side before the step.
                continue;
            }
            let Some(rise) = profile_rise(
                objective,
                space,
                at,
                certainty.id,
                value,
                &line,
                cost,
                sigma2,
                &profile_lm,
                &mut runs,
            ) else {
                continue;
            };
            widest = widest.max(STEPS * f64::from(std) / libm::sqrt(rise));
        }
        if widest > f64::from(std) {
            let natural = widest / free.natural_scale(certainty.value);
            certainty.pinned = natural <= PINNED_STD;
            certainty.std = certainty.pinned.then_some(widest as f32);
        }
    }
    id.evaluations += runs.spent;
    if runs.stopped {
        unchecked(id, space, lines);
    }
    !runs.stopped
}

/// What a check that had work but did not run (or was stopped) leaves: no parameter
/// pinned, since none was confirmed. Without work for it, the local analysis stands.
pub fn unchecked(id: &mut Identifiability, space: &Space, lines: &ProfileLines) {
    if !applies(id, space, lines) {
        return;
    }
    for certainty in id.params.iter_mut() {
        certainty.pinned = false;
        certainty.std = None;
    }
}

/// `lm` for the check's refits: they stop once an accepted step lowers the cost by less
/// than `chi2` residual variances (`sigma2`) from about `cost`, not at the fit's own
/// tolerance (the check compares rises of the cost with 9 and 1, not its last digits).
/// The tolerance is absolute: a refit from high up the valley's wall does not stop with
/// more than that still to gain (a tolerance relative to the cost, `chi2` units at the
/// optimum, grew with the start's height).
fn stopping_at(lm: &LmConfig, chi2: f64, sigma2: f64) -> LmConfig {
    LmConfig {
        abs_tol: chi2 * sigma2,
        ..*lm
    }
}

/// The profile at one side: `id` fixed at `value`, the other free parameters of `space`
/// refitted by least squares from where the local quadratic puts them (`line`, the
/// parameter's profile line of [`ProfileLines`], from `at`); the rise of
/// the cost over `cost` in units of the residual variance `sigma2`, refitted with `lm`
/// (its tolerance in those units, [`stopping_at`]). (Started from `at`
/// with the others unmoved, a refit along a narrow valley, J, B, Kv and tc sliding
/// together, begins far up its wall and descends in many iterations.) None when the profile cannot be set up (a value the
/// parameter may not take) or not simulated, or the check was stopped: the local figure
/// stands.
/// A frame of its own (the profile's space), beside the walk's rather than on top of it.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn profile_rise(
    objective: &Objective,
    space: &Space,
    at: &ModelParams,
    id: ParamId,
    value: f64,
    line: &[f32; MAX_FREE],
    cost: &Cost,
    sigma2: f64,
    lm: &LmConfig,
    runs: &mut Runs,
) -> Option<f64> {
    let (profile, start) = profile_start(space, at, id, value as f32, line)?;
    let r = runs.refine(objective, &profile, &start, lm, &|_| false)?;
    Some(((r.cost.sse - cost.sse) / sigma2).max(1e-12))
}

/// The space of `id`'s profile at `value` and its refit's start there: every other free
/// parameter of `space` moved from `at` along `id`'s profile `line` (clamped to its
/// bounds). None when `id` is not free or the profile cannot be set up.
fn profile_start(
    space: &Space,
    at: &ModelParams,
    id: ParamId,
    value: f32,
    line: &[f32; MAX_FREE],
) -> Option<(Space, [f32; MAX_FREE])> {
    let free = space.free();
    let k = space.position(id)?;
    let mut u = space.unit(at);
    // The held parameter's step in natural units, and each other's along the line, in
    // unit coordinates (linear in them for a log scale).
    let natural = f64::from(free[k].unit(value) - u[k]) * free[k].natural_per_unit(at.get(id));
    for (j, f) in free.iter().enumerate() {
        let step = f64::from(line[j]) * natural / f.natural_per_unit(at.get(f.id));
        u[j] = (u[j] + step as f32).clamp(0.0, 1.0);
    }
    let along = space.params(&u[..free.len()]);
    let profile = space.fixing(&along, id, value).ok()?;
    let start = profile.unit(&along);
    Some((profile, start))
}

#[cfg(test)]
#[path = "profile_check_tests.rs"]
mod tests;
