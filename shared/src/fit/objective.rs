//! The fit objective: RMSE of speed (paper Eq. 7) and, when every record has a current
//! column, speed and current residuals weighted by their measured noise. Its normal
//! equations (the Jacobian's sums for least squares and the analysis) are in
//! [`crate::fit::normal_equations`].
//!
//! Residuals are streamed: no buffer of record length is ever allocated. For least squares
//! the nominal and perturbed parameter sets are simulated in lockstep and `J^T J`, `J^T r`
//! accumulated per sample (fixed memory `O(dim^2)`, whatever the record length).

use crate::capacity::MAX_FREE;
use crate::error::Error;

use crate::fit::space::Space;
use crate::fit::sums::{pooled_sigma, Partial, RecordSums, Totals, CHECK_EVERY, SHIFT};
use crate::fit::workspace::FitWorkspace;
use crate::model::params::ModelParams;
use crate::model::record::Record;
use crate::model::rounding::Rounding;
use crate::model::sim::{InitialState, Simulator};

/// Goodness of fit of one parameter set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cost {
    /// Weighted sum of squared residuals, in (rad/s)^2 (current residuals scaled by
    /// `sigma_omega / sigma_current`).
    pub sse: f64,
    /// Number of residuals in `sse`.
    pub residuals: usize,
    /// RMSE of speed [rad/s] (paper Eq. 7).
    pub rmse_omega: f32,
    /// RMSE of current [A], when the records have current.
    pub rmse_current: Option<f32>,
}

impl Cost {
    /// The scalar the optimisers minimise: `sqrt(sse / residuals)`, in rad/s. For speed-only
    /// records this is exactly the RMSE of paper Eq. 7.
    pub fn fitness(&self) -> f32 {
        libm::sqrt(self.sse / self.residuals as f64) as f32
    }
}

/// The objective over a set of records.
#[derive(Clone, Copy, Debug)]
pub struct Objective<'r, 'a> {
    pub(crate) records: &'r [Record<'a>],
    /// Weight of current residuals: `sigma_omega / sigma_current`, or 0 without current.
    pub(crate) current_weight: f32,
    sigma_omega: f32,
    sigma_current: Option<f32>,
    /// Memory for the Jacobian's simulators, when lent ([`Objective::with_workspace`]).
    pub(crate) workspace: Option<&'r FitWorkspace>,
}

impl<'r, 'a> Objective<'r, 'a> {
    /// Validate the records and measure their noise. Not inlined: its temporaries stay off
    /// the frame of an identification (a board's stack).
    #[inline(never)]
    pub fn new(records: &'r [Record<'a>]) -> Result<Self, Error> {
        if records.is_empty() {
            return Err(Error::NoRecords);
        }
        for r in records {
            r.validate()?;
        }
        let sigma_omega = pooled_sigma(records.iter().map(|r| r.omega));
        let with_current = records.iter().all(|r| r.current.is_some());
        let sigma_current = if with_current {
            Some(pooled_sigma(records.iter().filter_map(|r| r.current)))
        } else {
            None
        };
        let current_weight = sigma_current.map_or(0.0, |sc| sigma_omega / sc);
        Ok(Objective {
            records,
            current_weight,
            sigma_omega,
            sigma_current,
            workspace: None,
        })
    }

    /// The objective with the Jacobian's simulators in `workspace` (a board's static RAM)
    /// rather than on the frames of its evaluations.
    pub fn with_workspace(self, workspace: Option<&'r FitWorkspace>) -> Self {
        Objective { workspace, ..self }
    }

    /// The records.
    pub fn records(&self) -> &'r [Record<'a>] {
        self.records
    }

    /// Records of averaged readings ([`Record::averaged`]) are simulated with no effect but
    /// Coulomb friction: refused with [`Error::AveragedReadingsNotModelled`] when the
    /// problem of `space` holds another effect (as the middle of the space does), rather
    /// than every candidate rejected one by one. (Out of line: its simulator stays off a
    /// board's deepest frames.)
    #[inline(never)]
    pub fn averaged_readings_modelled(&self, space: &Space) -> Result<(), Error> {
        if self.records.iter().all(|r| r.averaged <= 1) {
            return Ok(());
        }
        let middle = space.params(&[0.5; MAX_FREE][..space.dim()]);
        for r in self.records {
            Simulator::for_record(&middle, r, InitialState::REST)?;
        }
        Ok(())
    }

    /// The cost of the sums over all records.
    pub(crate) fn cost_of(&self, totals: &Totals) -> Option<Cost> {
        let n = self.samples();
        let w = self.current_weight as f64;
        let cost = Cost {
            sse: totals.omega_sq + w * w * totals.current_sq,
            residuals: n * self.residuals_per_sample(),
            rmse_omega: libm::sqrt(totals.omega_sq / n as f64) as f32,
            rmse_current: (self.current_weight > 0.0)
                .then(|| libm::sqrt(totals.current_sq / n as f64) as f32),
        };
        cost.sse.is_finite().then_some(cost)
    }

    /// Estimated speed noise [rad/s] (floored, see [`pooled_sigma`]).
    pub fn sigma_omega(&self) -> f32 {
        self.sigma_omega
    }

    /// The fitness a fit at its noise floor leaves [rad/s]: the measured speed noise, and for
    /// records of averaged readings ([`Record::averaged`]) the rounding error a reading held
    /// within one count keeps ([`Rounding::of_means`]), which noise measured on means does
    /// not see (the current's weighted into speed, as in [`Cost::fitness`]). Without it a
    /// fit of averaged ADC readings stayed above its floor and escalated on a quarter of the
    /// commissioning benchmark's motors (`docs/measurements/commissioning.md`).
    pub fn floor_sigma(&self) -> f32 {
        if self.records.iter().all(|r| r.averaged <= 1) {
            return self.sigma_omega;
        }
        let w = self.current_weight as f64;
        let (mut held, mut n) = (0.0f64, 0usize);
        for r in self.records {
            n += r.len();
            if r.averaged <= 1 {
                continue;
            }
            let e_omega = Rounding::of_means(r.omega, self.sigma_omega, r.averaged).error as f64;
            let e_current = match (r.current, self.sigma_current) {
                (Some(c), Some(sc)) if w > 0.0 => {
                    Rounding::of_means(c, sc, r.averaged).error as f64
                }
                _ => 0.0,
            };
            let per_sample = e_omega * e_omega + w * w * e_current * e_current;
            held += r.len() as f64 * per_sample / self.residuals_per_sample() as f64;
        }
        let s = self.sigma_omega as f64;
        libm::sqrt(s * s + held / n.max(1) as f64) as f32
    }

    /// Estimated current noise [A], when fitting current.
    pub fn sigma_current(&self) -> Option<f32> {
        self.sigma_current
    }

    /// Total samples over all records.
    pub fn samples(&self) -> usize {
        self.records.iter().map(|r| r.len()).sum()
    }

    /// Residuals per sample (1 speed-only, 2 with current).
    fn residuals_per_sample(&self) -> usize {
        if self.current_weight > 0.0 {
            2
        } else {
            1
        }
    }

    /// The initial state of record `r` for `p` from the data (see [`Record::initial_state`])
    /// and, unless the record [starts at rest](Record::starts_at_rest), the same with the
    /// speed raised by [`SHIFT`] to fit the initial speed (a known start at rest is
    /// information that is kept).
    pub(crate) fn initial_pair(
        &self,
        r: &Record,
        p: &ModelParams,
    ) -> (InitialState, Option<InitialState>) {
        let at_rest = r.starts_at_rest(p, self.sigma_omega, self.sigma_current);
        let init = r.initial_state(p, at_rest, self.sigma_current);
        let shifted = (!at_rest).then_some(InitialState {
            omega: init.omega + SHIFT,
            ..init
        });
        (init, shifted)
    }

    /// Cost of `p`; `None` when `p` cannot be simulated or gives a non-finite cost
    /// (a rejected candidate, never a crash). The initial speed of each record is the
    /// least-squares one for `p` (see [`RecordSums`]).
    pub fn cost(&self, p: &ModelParams) -> Option<Cost> {
        self.cost_below(p, f64::INFINITY).ok()?
    }

    /// [`Objective::cost`], abandoned as soon as the weighted SSE is known to reach
    /// `sse_limit` (`Err(())`; exact: the partial sums only grow, see [`Partial`]).
    fn cost_below(&self, p: &ModelParams, sse_limit: f64) -> Result<Option<Cost>, ()> {
        let mut totals = Totals::default();
        for r in self.records {
            let partial = Partial {
                limit: sse_limit,
                omega_sq: totals.omega_sq,
                current_sq: totals.current_sq,
                w2: (self.current_weight as f64) * (self.current_weight as f64),
            };
            if self.record_sums(r, p, &partial, &mut totals)?.is_none() {
                return Ok(None);
            }
        }
        Ok(self.cost_of(&totals))
    }

    /// Simulate record `index` with `p` from the least-squares initial speed the cost uses,
    /// writing the speed and current readings.
    pub fn simulate(
        &self,
        p: &ModelParams,
        index: usize,
        out_omega: &mut [f32],
        out_current: &mut [f32],
    ) -> Result<(), Error> {
        let r = self.records.get(index).ok_or(Error::NoRecords)?;
        let (init, _) = self.initial_pair(r, p);
        let shift = self
            .record_sums(r, p, &Partial::UNBOUNDED, &mut Totals::default())
            .ok()
            .flatten()
            .ok_or(Error::NoFiniteCandidate)?;
        let best = InitialState {
            omega: init.omega + shift,
            ..init
        };
        crate::model::record::simulate(p, r, best, true, out_omega, out_current)
    }

    /// Residual sums of record `r` simulated with `p` (no Jacobian), added to `totals`;
    /// returns the least-squares correction of its initial speed (see
    /// [`RecordSums::finish_into`]), `Err(())` once the SSE reaches the limit of `partial`
    /// (`totals` untouched then). The record's sums never leave this frame. Not inlined: a frame of its own keeps the hot
    /// loop's simulators and sums next to the stack pointer (on the M4, within reach of one
    /// `vldr`, which the callers' larger frames had pushed out: 11 % more instructions).
    fn record_sums(
        &self,
        r: &Record,
        p: &ModelParams,
        partial: &Partial,
        totals: &mut Totals,
    ) -> Result<Option<f32>, ()> {
        match Simulator::averaged_path(core::slice::from_ref(r)) {
            true => self.record_sums_of::<true>(r, p, partial, totals),
            false => self.record_sums_of::<false>(r, p, partial, totals),
        }
    }

    /// [`Objective::record_sums`], of averaged readings with `AVERAGED`
    /// ([`Simulator::sample`]).
    #[inline(never)]
    fn record_sums_of<const AVERAGED: bool>(
        &self,
        r: &Record,
        p: &ModelParams,
        partial: &Partial,
        totals: &mut Totals,
    ) -> Result<Option<f32>, ()> {
        let (init, shifted) = self.initial_pair(r, p);
        let Ok(mut sim) = Simulator::for_record(p, r, init) else {
            return Ok(None);
        };
        let with_current = r.current.is_some() && self.current_weight > 0.0;
        let mut sums = RecordSums::new(0, with_current, shifted.is_some());
        let tracks = sim.tracks_angle();
        let w = self.current_weight;
        match shifted {
            // A record that starts at rest: no initial speed to project out, and the SSE
            // grows monotonically, so a candidate can be abandoned early.
            None => {
                for k in 0..r.len() {
                    sums.add_residuals(r, k, sim.sample::<AVERAGED>(), w);
                    if sums.end_sample()
                        && k % CHECK_EVERY == CHECK_EVERY - 1
                        && partial.reached(&sums)
                    {
                        return Err(());
                    }
                    sim.apply_record::<AVERAGED>(&r.step_input(k, tracks));
                }
            }
            Some(s) => {
                let Ok(mut sim_s) = Simulator::for_record_like(p, r, s, Some((p, &sim))) else {
                    return Ok(None);
                };
                for k in 0..r.len() {
                    let y = sim.sample::<AVERAGED>();
                    sums.add_residuals(r, k, y, w);
                    sums.add_shift_response(r, k, y, sim_s.sample::<AVERAGED>(), w, &[], &[]);
                    sums.end_sample();
                    let input = r.step_input(k, tracks);
                    sim.apply_record::<AVERAGED>(&input);
                    sim_s.apply_record::<AVERAGED>(&input);
                }
            }
        }
        Ok(Some(sums.finish_into(w, totals, None)))
    }

    /// Fitness at unit point `u` when it is below `bound`, otherwise any value not below
    /// `bound` (`INFINITY` when rejected or abandoned): what a search that keeps a candidate
    /// only if it beats `bound` needs, at a fraction of the simulation for poor candidates.
    pub fn fitness_below(&self, space: &Space, u: &[f32], bound: f32) -> f32 {
        // fitness = sqrt(sse / n) >= bound whenever sse >= bound^2 n (1 + 1e-9): the margin
        // covers the rounding of the division, the square root and the cast to f32.
        let residuals = (self.samples() * self.residuals_per_sample()) as f64;
        let limit = (bound as f64) * (bound as f64) * residuals * (1.0 + 1e-9);
        match self.cost_below(&space.params(u), limit) {
            Ok(Some(c)) => c.fitness(),
            _ => f32::INFINITY,
        }
    }

    /// Fitness ([`Cost::fitness`]) at unit point `u` of `space`, `INFINITY` if rejected.
    pub fn fitness(&self, space: &Space, u: &[f32]) -> f32 {
        self.fitness_below(space, u, f32::INFINITY)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::normal_equations::NormalEquations;
    use crate::model::profile::Profile;
    use crate::model::synth::Noise;
    use crate::testkit::Owned;

    #[test]
    fn the_floor_of_averaged_readings_counts_the_rounding_their_mean_keeps() {
        // A slow speed ramp read on a grid of 0.25 rad/s with a noise of a fifth of a count,
        // in means of 8: the held rounding (about 0.1 count) is not in their measured noise
        // (about 0.05 / sqrt 8 count).
        let (q, m) = (0.25f32, 8u32);
        let mut rng = crate::rng::seeded(9);
        let omega: std::vec::Vec<f32> = (0..600)
            .map(|k| {
                let x = 20.0 + 0.002 * k as f32;
                let sum: f32 = (0..m)
                    .map(|_| libm::roundf((x + 0.05 * crate::rng::normal(&mut rng)) / q) * q)
                    .sum();
                sum / m as f32
            })
            .collect();
        let v = std::vec![1.0f32; 600];
        let r = Record {
            dt: 1e-3,
            v: &v,
            omega: &omega,
            current: None,
            load: None,
            coast_from: None,
            averaged: m,
        };
        let records = [r];
        let averaged = Objective::new(&records).unwrap();
        let (floor, sigma) = (averaged.floor_sigma(), averaged.sigma_omega());
        assert!(
            floor > 1.5 * sigma && floor > 0.08 * q,
            "{floor} against {sigma}"
        );
        // The same readings taken as instants: the measured noise alone.
        let records = [Record { averaged: 1, ..r }];
        let instant = Objective::new(&records).unwrap();
        assert_eq!(instant.floor_sigma(), instant.sigma_omega());
    }

    #[test]
    fn normal_equations_that_fail_leave_the_cost_as_it_was() {
        let noise = Noise {
            omega: 0.5,
            current: 0.02,
        };
        let data = Owned::paper_motor(Profile::Steps, 0.01, 2000, noise, 3);
        let records = [data.record(true, false)];
        let objective = Objective::new(&records).unwrap();
        let space = Space::new(&crate::fit::space::ProblemSpec::default(), true).unwrap();
        let mut ne = NormalEquations::EMPTY;
        assert!(objective.normal_equations(&space, &[0.5; 5], 1e-4, false, &mut ne));
        let (cost, simulations) = (ne.cost, ne.simulations);
        assert!(
            cost.sse.is_finite() && simulations == 6,
            "{cost:?}, {simulations}"
        );
        // A point that cannot be simulated (its parameters NaN).
        assert!(!objective.normal_equations(&space, &[f32::NAN; 5], 1e-4, true, &mut ne));
        assert_eq!((ne.cost, ne.simulations), (cost, simulations));
    }

    #[test]
    fn fitness_below_a_bound_is_exact_and_never_falls_below_it_when_abandoned() {
        let noise = Noise {
            omega: 0.5,
            current: 0.02,
        };
        let mut data = Owned::paper_motor(Profile::Steps, 0.01, 2000, noise, 3);
        // Exactly at rest at first (this noise draw starts 3.3 sigma off).
        data.omega[0] = 0.0;
        let at_rest = data.record(true, false);
        // A second record that starts turning: its initial speed is projected out.
        let turning = Record {
            v: &data.v[700..],
            omega: &data.omega[700..],
            current: Some(&data.current[700..]),
            ..at_rest
        };
        for records in [&[at_rest][..], &[at_rest, turning][..], &[turning][..]] {
            let objective = Objective::new(records).unwrap();
            let space = Space::new(&crate::fit::space::ProblemSpec::default(), true).unwrap();
            let mut rng = crate::rng::seeded(5);
            let mut abandoned = 0;
            for _ in 0..40 {
                let u: [f32; 5] = core::array::from_fn(|_| crate::rng::unit(&mut rng));
                let f = objective.fitness(&space, &u);
                for bound in [0.5 * f, 0.999 * f, f, 1.001 * f, 2.0 * f, f32::INFINITY] {
                    let g = objective.fitness_below(&space, &u, bound);
                    if f < bound {
                        assert_eq!(g.to_bits(), f.to_bits(), "bound {bound}, fitness {f}");
                    } else {
                        assert!(g >= bound, "{g} below the bound {bound} (fitness {f})");
                        abandoned += u32::from(g == f32::INFINITY);
                    }
                }
            }
            if records[0].omega[0] == 0.0 {
                assert!(abandoned > 0, "no candidate was abandoned early");
            }
        }
    }
}
