//! Which parameters, or combinations of them, the data pins: the paper's blind spot.
//!
//! From a voltage step read only on the tacho, `w/V = Kv / (La J s^2 + (Ra J + La B) s + Ra B + Kv^2)`
//! (paper Eq. 6) has three independent coefficients, so two directions of (Ra, La, J, B, Kv)
//! leave the speed trace unchanged (e.g. Ra, La scaled by lambda and J, B by 1/lambda). The
//! analysis here is local and numerical, so it covers any record, effect and fixed set:
//! the Fisher information `F = J^T J / sigma^2` of the weighted residuals with respect to the
//! natural coordinates (`ln p` for parameters with positive bounds, whatever the search
//! scale; `p / max(|p|, 1 % of the range)` for effect parameters that may be 0, see
//! [`crate::fit::space::FreeParam::natural_per_unit`]) is eigen-decomposed; a direction is *pinned* when its standard deviation `1/sqrt(eig)` is at
//! most [`PINNED_STD`] (10 % for a log coordinate) and its eigenvalue stands clear of the
//! numerical floor of the finite-difference Jacobian (ten times the magnitude of the most
//! negative eigenvalue, which exact arithmetic would make non-negative, and at least 1e-8 of
//! the largest, or 1e-5 of the information of the columns the direction combines, the
//! diagonal of `F` along it, when that is lower: a direction of small columns, not a
//! cancellation of large ones). A parameter or combination gets the delta-method standard
//! deviation over the directions above the floor plus, along each numerically flat direction, the spread of a
//! uniform distribution over the part of that line inside the bounds (the data cannot say
//! where on it the truth lies; the bounds can). It is pinned when that is at most
//! [`PINNED_STD`] and its gradient has no more than a 1 % component along flat directions.
//! So `kv` is called pinned by a speed-only step when back-EMF dominates viscous friction
//! (`Kv^2 >> Ra B`: then `Kv` is almost `c3/c1` anywhere in the box); its spread is then
//! optimistic, since the equal-fit set is curved.
//!
//! The delta-method variance over the informed directions is the larger of the white-noise
//! one (`g^T F^+ g`) and the sandwich one, `y^T (J^T Sigma J) y / sigma^4` with `y = F^+ g`,
//! whose middle term the batch means of the residuals' scores estimate
//! ([`crate::fit::score_blocks`]): residuals correlated over many samples (a reading rounded
//! with less noise than a count, a misfit that persists) hold less information than `F`
//! claims. On the commissioning benchmark this brought the pinned estimates within 3 reported
//! deviations of the truth from 84.0 % to 94.7 % of 1,000 motors
//! (docs/measurements/commissioning.md).
//!
//! Readings an ADC rounds with less noise than a count ([`crate::fit::pipeline::IdentifyConfig::adc_readings`]:
//! a board's own records) add a term to either: while a modelled reading stays within one
//! count its rounding error is one constant ([`crate::model::rounding::Rounding`]), which no
//! number of samples averages away and which the block scores, centred per record, see only
//! in part. Its covariance, summed stretch by stretch in [`ScoreBlocks`], is added to the
//! larger of the two. On the commissioning benchmark the pinned estimates within 3 reported
//! deviations went from 98.2 % to 98.8 %, the |error|/σ medians from 0.62-0.70 to
//! 0.54-0.66 (0.67 for an honest σ).

use crate::capacity::MAX_FREE;
use crate::error::Error;
use crate::fit::linalg::symmetric_eigen;
use crate::fit::normal_equations::NormalEquations;
use crate::fit::objective::{Cost, Objective};
use crate::fit::score_blocks::ScoreBlocks;
use crate::fit::space::Space;
use crate::model::params::ModelParams;
use crate::param_id::ParamId;

/// Largest standard deviation (in natural coordinates) of a pinned direction.
pub const PINNED_STD: f64 = 0.1;
/// Largest share of a gradient's squared norm along numerically flat directions for a
/// quantity that may still be called pinned (a component of 1 %: the numerical accuracy of
/// the eigenvectors there; the paper Eq. 6 coefficients, exactly orthogonal to the flat
/// directions of a speed-only record, come out with components of up to about 0.3 %).
const FLAT_SHARE: f64 = 1e-4;
/// A pinned direction's eigenvalue must exceed the numerical floor by this factor.
const NUMERICAL_MARGIN: f64 = 10.0;
/// The numerical floor of a direction's eigenvalue, as a share of the largest eigenvalue.
const LARGEST_SHARE: f64 = 1e-9;
/// The numerical floor of a direction's eigenvalue, as a share of the information of the
/// columns the direction combines, where that is lower than [`LARGEST_SHARE`]'s (a
/// direction of small columns, not a cancellation of large ones).
const OWN_SHARE: f64 = 1e-6;
/// Finite-difference step (unit coordinates) of the central-difference Jacobian.
const STEP: f32 = 1e-3;

/// Certainty about one free parameter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ParamCertainty {
    /// Which parameter.
    pub id: ParamId,
    /// Identified value.
    pub value: f32,
    /// True when the data pins it.
    pub pinned: bool,
    /// One standard deviation, in the parameter's unit, when pinned.
    pub std: Option<f32>,
}

/// The coefficients of paper Eq. 6 that a speed record from a voltage input can pin.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Combination {
    /// `Kv / (La J)`: the gain of paper Eq. 6 per `s^2`.
    KvOverLaJ,
    /// `Ra/La + B/J`: the damping coefficient of the denominator.
    RaOverLaPlusBOverJ,
    /// `(Ra B + Kv^2) / (La J)`: the static coefficient (squared natural frequency).
    StaticCoefficient,
}

impl Combination {
    /// All three.
    pub const ALL: [Combination; 3] = [
        Combination::KvOverLaJ,
        Combination::RaOverLaPlusBOverJ,
        Combination::StaticCoefficient,
    ];

    /// Formula, as printed.
    pub const fn name(self) -> &'static str {
        match self {
            Combination::KvOverLaJ => "kv/(la*j)",
            Combination::RaOverLaPlusBOverJ => "ra/la+b/j",
            Combination::StaticCoefficient => "(ra*b+kv^2)/(la*j)",
        }
    }

    /// Value and `d ln c / d ln p` for (Ra, La, J, B, Kv).
    pub fn evaluate(self, p: &ModelParams) -> (f32, [f32; 5]) {
        let (ra, la, j, b, kv) = (
            p.get(ParamId::Ra),
            p.get(ParamId::La),
            p.get(ParamId::J),
            p.get(ParamId::B),
            p.get(ParamId::Kv),
        );
        match self {
            Combination::KvOverLaJ => (kv / (la * j), [0.0, -1.0, -1.0, 0.0, 1.0]),
            Combination::RaOverLaPlusBOverJ => {
                let (e, m) = (ra / la, b / j);
                let c = e + m;
                (c, [e / c, -e / c, -m / c, m / c, 0.0])
            }
            Combination::StaticCoefficient => {
                let (rb, kk) = (ra * b, kv * kv);
                let s = rb + kk;
                (s / (la * j), [rb / s, -1.0, -1.0, rb / s, 2.0 * kk / s])
            }
        }
    }
}

/// Certainty about one combination.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CombinationCertainty {
    /// Which combination.
    pub combination: Combination,
    /// Its value at the identified parameters.
    pub value: f32,
    /// True when the data pins it.
    pub pinned: bool,
    /// Relative standard deviation, when pinned.
    pub rel_std: Option<f32>,
}

/// A direction in natural coordinates along which the fit is (nearly) flat.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Direction {
    /// Unit vector over the free parameters (same order as [`Identifiability::params`]).
    pub components: [f32; MAX_FREE],
    /// Standard deviation along it (natural coordinates), `INFINITY` when numerically flat
    /// (its eigenvalue at the finite-difference Jacobian's floor: a speed-only record's
    /// paper Eq. 6 directions); finite for a direction the data informs more loosely than
    /// [`PINNED_STD`] (B beside a Coulomb torque a hundred times its viscous one).
    pub std: f32,
}

/// The identifiability report.
#[derive(Clone, Debug, PartialEq)]
pub struct Identifiability {
    /// Number of pinned directions.
    pub rank: usize,
    /// Per free parameter.
    pub params: heapless::Vec<ParamCertainty, MAX_FREE>,
    /// Paper Eq. 6 coefficients (when any motor parameter is free).
    pub combinations: heapless::Vec<CombinationCertainty, 3>,
    /// Directions the data does not pin.
    pub unpinned: heapless::Vec<Direction, MAX_FREE>,
    /// Model evaluations this analysis spent.
    pub evaluations: u32,
}

/// Each free parameter's local profile line (same order as [`Identifiability::params`]):
/// per unit of its natural coordinate, how far each free parameter moves (natural
/// coordinates) when it is held and the others refit on the local quadratic of the cost,
/// i.e. the column of the covariance over its diagonal (informed directions only; zeros
/// for a parameter with no informed component). The profile check starts its refits there
/// ([`super::profile_check`]). Beside the report, not in it: the report is held in several
/// frames on the board's deepest stack (576 bytes more as a field).
pub type ProfileLines = [[f32; MAX_FREE]; MAX_FREE];

impl Identifiability {
    /// True when every free parameter is pinned.
    pub fn all_pinned(&self) -> bool {
        self.params.iter().all(|p| p.pinned)
    }
}

/// Analyse the fit at unit point `u` with cost `cost`; `adc_readings`: the records' readings
/// are an ADC's, each record's steady rounding error counted ([`ScoreBlocks`]).
#[inline(never)]
pub fn analyse(
    objective: &Objective,
    space: &Space,
    u: &[f32],
    cost: &Cost,
    adc_readings: bool,
    lines: &mut ProfileLines,
) -> Result<Identifiability, Error> {
    let mut ne = NormalEquations::EMPTY;
    let mut scores = ScoreBlocks::EMPTY;
    scores.set_dim(space.dim());
    scores.set_adc_readings(adc_readings);
    let summed = objective.normal_equations_sums(space, u, STEP, true, &mut ne, Some(&mut scores));
    if summed.is_none() {
        return Err(Error::NoFiniteCandidate);
    }
    // The result is written by `interpret` straight into the caller's (no copy on this
    // frame, which holds the normal equations and the block scores).
    interpret(&ne, &scores, space, u, cost, lines)
}

/// The analysis of the normal equations `ne` at `u`. A frame of its own: the eigen
/// decomposition's matrices are not on the stack while the normal equations are built.
#[inline(never)]
fn interpret(
    ne: &NormalEquations,
    scores: &ScoreBlocks,
    space: &Space,
    u: &[f32],
    cost: &Cost,
    lines: &mut ProfileLines,
) -> Result<Identifiability, Error> {
    let dim = space.dim();
    let dof = (cost.residuals as f64 - dim as f64).max(1.0);
    let sigma2 = (cost.sse / dof).max(f64::MIN_POSITIVE);
    let free = space.free();
    let p = space.params(u);
    let mut per_unit = [1.0f64; MAX_FREE];
    for (i, f) in free.iter().enumerate() {
        per_unit[i] = f.natural_per_unit(p.get(f.id));
    }
    let mut fisher = [[0.0f64; MAX_FREE]; MAX_FREE];
    for a in 0..dim {
        for b in 0..dim {
            let scale = per_unit[a] * per_unit[b];
            fisher[a][b] = ne.jtj[a][b] / scale / sigma2;
        }
    }
    let (vals, vecs) = symmetric_eigen(&fisher, dim);
    // Numerical floor of each direction: finite differences of an f32 simulation leave
    // eigenvalues of about this size (seen as negative ones) where the fit is exactly flat,
    // at most [`LARGEST_SHARE`] of the largest. A flat direction is a cancellation between
    // the columns it combines, so a direction that holds only a small share of the
    // information ([`OWN_SHARE`] of its own columns' information, the `fisher` diagonal
    // along it, is far above what their rounding leaves) stands clear of it: a tacho delay
    // of 0.7 sample at 10 kHz, its direction the delay alone and known to 3 %, sat at 4e-9
    // of the current channel's largest eigenvalue and was called flat.
    let most_negative = (-vals[0]).max(0.0);
    let largest = vals[dim - 1].max(0.0);
    let floors: [f64; MAX_FREE] = core::array::from_fn(|k| {
        let own_information: f64 = (0..dim)
            .map(|i| vecs[i][k] * vecs[i][k] * fisher[i][i])
            .sum();
        let share = (LARGEST_SHARE * largest).min(OWN_SHARE * own_information);
        NUMERICAL_MARGIN * most_negative.max(share)
    });
    let above_floor = |k: usize| vals[k] > floors[k];
    let std_of = |k: usize| {
        if vals[k] > 0.0 {
            1.0 / libm::sqrt(vals[k])
        } else {
            f64::INFINITY
        }
    };
    let pinned_dir = |k: usize| std_of(k) <= PINNED_STD && above_floor(k);
    let rank = (0..dim).filter(|&k| pinned_dir(k)).count();
    // Along a numerically flat direction the data cannot tell where the truth lies, only the
    // bounds can: its spread is that of a uniform distribution over the segment of the line
    // through the estimate that stays inside the box.
    let flat_std = |k: usize| -> f64 {
        let (mut t_lo, mut t_hi) = (f64::NEG_INFINITY, f64::INFINITY);
        for i in 0..dim {
            let v = vecs[i][k];
            if v.abs() < 1e-12 {
                continue;
            }
            // Position in natural units measured from the lower and upper bound.
            let span = per_unit[i];
            let below = -(u[i] as f64) * span;
            let above = (1.0 - u[i] as f64) * span;
            let (a, b) = if v > 0.0 {
                (below / v, above / v)
            } else {
                (above / v, below / v)
            };
            t_lo = t_lo.max(a);
            t_hi = t_hi.min(b);
        }
        if t_hi >= t_lo && t_hi.is_finite() && t_lo.is_finite() {
            (t_hi - t_lo) / libm::sqrt(12.0)
        } else {
            0.0
        }
    };
    let mut flat_stds = [0.0f64; MAX_FREE];
    for k in 0..dim {
        if !above_floor(k) {
            flat_stds[k] = flat_std(k);
        }
    }
    // The score's covariance in natural coordinates, over sigma^4 (0 when there are too few
    // blocks): with the Fisher information F, the sandwich variance of a quantity with
    // gradient g is y^T M y with y = F^+ g (see ScoreBlocks).
    // With it, the records' steady rounding errors (zero unless the readings are an ADC's),
    // added to either: the block scores, centred per record, do not see them. Both
    // quadratic forms `y^T M y` in one pass.
    let sandwich_and_rounding = |y: &[f64; MAX_FREE]| -> (f64, f64) {
        let (mut robust, mut rounding) = (0.0, 0.0);
        for a in 0..dim {
            for b in 0..dim {
                let yy = y[a] * y[b] / (per_unit[a] * per_unit[b]) / (sigma2 * sigma2);
                robust += yy * scores.covariance(a, b).unwrap_or(0.0);
                rounding += yy * scores.rounding_covariance(a, b);
            }
        }
        (robust, rounding)
    };
    // Quantity with gradient g in natural coordinates: (pinned?, std), by the delta method
    // over the informed directions (the larger of the white-noise and the sandwich
    // variance) plus the bounded spread along the flat ones.
    // Also `y`, the covariance over the informed directions times `g` (a parameter's
    // profile line, over its own component).
    let certainty = |g: &[f64; MAX_FREE]| -> (bool, f64, [f64; MAX_FREE]) {
        let norm2: f64 = g[..dim].iter().map(|x| x * x).sum();
        let (mut informed, mut bounded) = (0.0, 0.0);
        let mut flat = 0.0;
        let mut y = [0.0f64; MAX_FREE];
        for k in 0..dim {
            let proj: f64 = (0..dim).map(|i| vecs[i][k] * g[i]).sum();
            if above_floor(k) {
                informed += proj * proj / vals[k];
                for (i, yi) in y.iter_mut().enumerate().take(dim) {
                    *yi += vecs[i][k] * proj / vals[k];
                }
            } else {
                flat += proj * proj;
                let s = proj * flat_stds[k];
                bounded += s * s;
            }
        }
        let (robust, rounding) = sandwich_and_rounding(&y);
        let std = libm::sqrt(informed.max(robust) + rounding + bounded);
        (flat <= FLAT_SHARE * norm2 && std <= PINNED_STD, std, y)
    };
    let mut params = heapless::Vec::new();
    *lines = [[0.0f32; MAX_FREE]; MAX_FREE];
    for (i, f) in free.iter().enumerate() {
        let mut g = [0.0f64; MAX_FREE];
        g[i] = 1.0;
        let (pinned, std_z, column) = certainty(&g);
        if column[i] > 0.0 {
            for (l, c) in lines[i].iter_mut().zip(column).take(dim) {
                *l = (c / column[i]) as f32;
            }
        }
        let value = p.get(f.id);
        let std = std_z * f.natural_scale(value);
        let _ = params.push(ParamCertainty {
            id: f.id,
            value,
            pinned,
            std: pinned.then_some(std as f32),
        });
    }
    let mut combinations = heapless::Vec::new();
    if free.iter().any(|f| f.id.is_motor()) {
        for c in Combination::ALL {
            let (value, dlog) = c.evaluate(&p);
            let mut g = [0.0f64; MAX_FREE];
            for (i, f) in free.iter().enumerate() {
                if f.id.is_motor() {
                    // Motor parameters have positive bounds: natural coordinate ln p.
                    g[i] = dlog[f.id.index()] as f64;
                }
            }
            let (pinned, rel, _) = certainty(&g);
            let _ = combinations.push(CombinationCertainty {
                combination: c,
                value,
                pinned,
                rel_std: pinned.then_some(rel as f32),
            });
        }
    }
    let mut unpinned = heapless::Vec::new();
    for k in 0..dim {
        if !pinned_dir(k) {
            let mut components = [0.0f32; MAX_FREE];
            // Sign convention: largest component positive.
            let mut lead = 0;
            for i in 0..dim {
                if vecs[i][k].abs() > vecs[lead][k].abs() {
                    lead = i;
                }
            }
            let sign = if vecs[lead][k] < 0.0 { -1.0 } else { 1.0 };
            for (i, c) in components.iter_mut().enumerate().take(dim) {
                *c = (sign * vecs[i][k]) as f32;
            }
            let _ = unpinned.push(Direction {
                components,
                // Numerically flat (its eigenvalue at the floor): the data says nothing
                // along it. Otherwise informed, only more loosely than PINNED_STD.
                std: match above_floor(k) {
                    true => std_of(k) as f32,
                    false => f32::INFINITY,
                },
            });
        }
    }
    Ok(Identifiability {
        rank,
        params,
        combinations,
        unpinned,
        evaluations: ne.simulations,
    })
}

#[cfg(test)]
#[path = "identifiability_tests.rs"]
mod tests;
