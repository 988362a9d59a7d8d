//! The fit objective: RMSE of speed (seed Eq. 7) and, when every record has a current
//! column, speed and current residuals weighted by their measured noise.
//!
//! Residuals are streamed: no buffer of record length is ever allocated. For least squares
//! the nominal and perturbed parameter sets are simulated in lockstep and `J^T J`, `J^T r`
//! accumulated per sample (fixed memory `O(dim^2)`, whatever the record length).

use crate::error::Error;
use crate::linalg::{Mat, Vector};
use crate::params::{ModelParams, ParamId};
use crate::record::{noise_sigma, Record};
use crate::sim::Simulator;
use crate::space::{Space, MAX_FREE};

/// Samples summed in f32 before the partial sum is added to the f64 total.
const BLOCK: usize = 64;

/// Goodness of fit of one parameter set.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Cost {
    /// Weighted sum of squared residuals, in (rad/s)^2 (current residuals scaled by
    /// `sigma_omega / sigma_current`).
    pub sse: f64,
    /// Number of residuals in `sse`.
    pub residuals: usize,
    /// RMSE of speed [rad/s] (seed Eq. 7).
    pub rmse_omega: f32,
    /// RMSE of current [A], when the records have current.
    pub rmse_current: Option<f32>,
}

impl Cost {
    /// The scalar the optimisers minimise: `sqrt(sse / residuals)`, in rad/s. For speed-only
    /// records this is exactly the RMSE of seed Eq. 7.
    pub fn fitness(&self) -> f32 {
        libm::sqrt(self.sse / self.residuals as f64) as f32
    }
}

/// Gauss-Newton normal equations at one point of the unit cube.
#[derive(Clone, Debug)]
pub struct NormalEquations {
    /// `J^T J` (Jacobian of the weighted residuals w.r.t. unit coordinates).
    pub jtj: Mat,
    /// `J^T r` with `r = measured - simulated`.
    pub jtr: Vector,
    /// Cost at the point.
    pub cost: Cost,
    /// Model evaluations spent: parameter sets simulated, each over all records.
    pub simulations: u32,
}

/// The objective over a set of records.
#[derive(Clone, Copy, Debug)]
pub struct Objective<'r, 'a> {
    records: &'r [Record<'a>],
    /// Weight of current residuals: `sigma_omega / sigma_current`, or 0 without current.
    current_weight: f32,
    sigma_omega: f32,
    sigma_current: Option<f32>,
}

impl<'r, 'a> Objective<'r, 'a> {
    /// Validate the records and measure their noise.
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
        })
    }

    /// The records.
    pub fn records(&self) -> &'r [Record<'a>] {
        self.records
    }

    /// Estimated speed noise [rad/s] (floored, see [`pooled_sigma`]).
    pub fn sigma_omega(&self) -> f32 {
        self.sigma_omega
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

    /// Cost of `p`; `None` when `p` cannot be simulated or gives a non-finite cost
    /// (a rejected candidate, never a crash).
    pub fn cost(&self, p: &ModelParams) -> Option<Cost> {
        let mut omega = SumSq::default();
        let mut current = SumSq::default();
        for r in self.records {
            let mut sim = Simulator::new(
                p,
                r.dt,
                r.initial_state(p.get(ParamId::Kv), p.get(ParamId::B), self.sigma_omega),
            )
            .ok()?;
            for k in 0..r.len() {
                let y = sim.reading();
                omega.add(r.omega[k] - y.omega);
                if let Some(c) = r.current {
                    current.add(c[k] - y.current);
                }
                sim.advance(r.v[k], r.load_at(k));
            }
        }
        let n = self.samples();
        let so = omega.total();
        let sc = current.total();
        let w = self.current_weight as f64;
        let cost = Cost {
            sse: so + w * w * sc,
            residuals: n * self.residuals_per_sample(),
            rmse_omega: libm::sqrt(so / n as f64) as f32,
            rmse_current: (self.current_weight > 0.0).then(|| libm::sqrt(sc / n as f64) as f32),
        };
        cost.sse.is_finite().then_some(cost)
    }

    /// Simulate record `index` with `p` from the same initial state the cost uses, writing
    /// the speed and current readings.
    pub fn simulate(
        &self,
        p: &ModelParams,
        index: usize,
        out_omega: &mut [f32],
        out_current: &mut [f32],
    ) -> Result<(), Error> {
        let r = self.records.get(index).ok_or(Error::NoRecords)?;
        let init = r.initial_state(p.get(ParamId::Kv), p.get(ParamId::B), self.sigma_omega);
        crate::sim::simulate(p, r.dt, init, r.v, r.load, out_omega, out_current)
    }

    /// Fitness ([`Cost::fitness`]) at unit point `u` of `space`, `INFINITY` if rejected.
    pub fn fitness(&self, space: &Space, u: &[f32]) -> f32 {
        self.cost(&space.params(u))
            .map_or(f32::INFINITY, |c| c.fitness())
    }

    /// Normal equations at unit point `u` by finite differences of step `h` in unit
    /// coordinates: forward (dim + 1 simulations per record) or central (2 dim + 1).
    pub fn normal_equations(
        &self,
        space: &Space,
        u: &[f32],
        h: f32,
        central: bool,
    ) -> Option<NormalEquations> {
        let dim = space.dim();
        let nominal = space.params(u);
        // Perturbed points: +h (and -h) per coordinate, kept inside the cube. `pairs[d]` holds
        // the indices of the upper and lower point in `points`, NOMINAL for the nominal one.
        const NOMINAL: usize = usize::MAX;
        let mut steps = [0.0f32; MAX_FREE];
        let mut pairs = [(NOMINAL, NOMINAL); MAX_FREE];
        let mut points: heapless::Vec<ModelParams, { 2 * MAX_FREE }> = heapless::Vec::new();
        for d in 0..dim {
            let (hi_u, lo_u) = if central {
                ((u[d] + h).min(1.0), (u[d] - h).max(0.0))
            } else if u[d] + h <= 1.0 {
                (u[d] + h, u[d])
            } else {
                (u[d], u[d] - h)
            };
            steps[d] = hi_u - lo_u;
            let mut index_of = |x: f32| -> Option<usize> {
                if x == u[d] {
                    return Some(NOMINAL);
                }
                let mut moved = [0.0f32; MAX_FREE];
                moved[..dim].copy_from_slice(&u[..dim]);
                moved[d] = x;
                points.push(space.params(&moved[..dim])).ok()?;
                Some(points.len() - 1)
            };
            pairs[d] = (index_of(hi_u)?, index_of(lo_u)?);
        }
        let mut jtj_acc = [[Accumulator::default(); MAX_FREE]; MAX_FREE];
        let mut jtr_acc = [Accumulator::default(); MAX_FREE];
        let mut omega_sq = SumSq::default();
        let mut current_sq = SumSq::default();
        let w = self.current_weight;
        for r in self.records {
            let init = |p: &ModelParams| {
                r.initial_state(p.get(ParamId::Kv), p.get(ParamId::B), self.sigma_omega)
            };
            let mut sim0 = Simulator::new(&nominal, r.dt, init(&nominal)).ok()?;
            let mut sims: heapless::Vec<Simulator, { 2 * MAX_FREE }> = heapless::Vec::new();
            for p in &points {
                sims.push(Simulator::new(p, r.dt, init(p)).ok()?).ok()?;
            }
            for k in 0..r.len() {
                let y0 = sim0.reading();
                let mut col_w = [0.0f32; MAX_FREE];
                let mut col_i = [0.0f32; MAX_FREE];
                let read = |i: usize| if i == NOMINAL { y0 } else { sims[i].reading() };
                for d in 0..dim {
                    let a = read(pairs[d].0);
                    let b = read(pairs[d].1);
                    // r = measured - sim, so dr/du = -(dy/du).
                    col_w[d] = -(a.omega - b.omega) / steps[d];
                    col_i[d] = -w * (a.current - b.current) / steps[d];
                }
                let rw = r.omega[k] - y0.omega;
                omega_sq.add(rw);
                let ri = r.current.map_or(0.0, |c| w * (c[k] - y0.current));
                if let Some(c) = r.current {
                    current_sq.add(c[k] - y0.current);
                }
                for a in 0..dim {
                    for b in 0..=a {
                        jtj_acc[a][b].add(col_w[a] * col_w[b] + col_i[a] * col_i[b]);
                    }
                    jtr_acc[a].add(col_w[a] * rw + col_i[a] * ri);
                }
                let (v, tl) = (r.v[k], r.load_at(k));
                sim0.advance(v, tl);
                for s in sims.iter_mut() {
                    s.advance(v, tl);
                }
            }
        }
        // One evaluation per distinct parameter set, over all records (as the FFO counts).
        let simulations = 1 + points.len() as u32;
        let mut jtj = [[0.0f64; MAX_FREE]; MAX_FREE];
        let mut jtr = [0.0f64; MAX_FREE];
        for a in 0..dim {
            for b in 0..=a {
                let x = jtj_acc[a][b].total();
                jtj[a][b] = x;
                jtj[b][a] = x;
            }
            jtr[a] = jtr_acc[a].total();
        }
        let n = self.samples();
        let so = omega_sq.total();
        let sc = current_sq.total();
        let cost = Cost {
            sse: so + (w as f64) * (w as f64) * sc,
            residuals: n * self.residuals_per_sample(),
            rmse_omega: libm::sqrt(so / n as f64) as f32,
            rmse_current: (w > 0.0).then(|| libm::sqrt(sc / n as f64) as f32),
        };
        let finite = cost.sse.is_finite()
            && jtr[..dim].iter().all(|x| x.is_finite())
            && jtj[..dim]
                .iter()
                .all(|row| row[..dim].iter().all(|x| x.is_finite()));
        finite.then_some(NormalEquations {
            jtj,
            jtr,
            cost,
            simulations,
        })
    }
}

/// Pooled noise of several signals, floored at 1e-4 of their RMS (noise-free simulations
/// would otherwise give a zero weight or a division by zero).
pub fn pooled_sigma<'s>(signals: impl Iterator<Item = &'s [f32]> + Clone) -> f32 {
    let mut var = 0.0f64;
    let mut ms = 0.0f64;
    let mut count = 0usize;
    for s in signals {
        let sig = noise_sigma(s) as f64;
        var += sig * sig * s.len() as f64;
        ms += s.iter().map(|x| (*x as f64) * (*x as f64)).sum::<f64>();
        count += s.len();
    }
    if count == 0 {
        return 1.0;
    }
    let sigma = libm::sqrt(var / count as f64);
    let floor = 1e-4 * libm::sqrt(ms / count as f64) + 1e-12;
    sigma.max(floor) as f32
}

/// f32 partial sums over blocks of [`BLOCK`] samples, added into an f64 total: f32 speed in
/// the per-sample loop, f64 accuracy over long records.
#[derive(Clone, Copy, Debug, Default)]
struct Accumulator {
    block: f32,
    count: usize,
    total: f64,
}

impl Accumulator {
    fn add(&mut self, x: f32) {
        self.block += x;
        self.count += 1;
        if self.count == BLOCK {
            self.total += self.block as f64;
            self.block = 0.0;
            self.count = 0;
        }
    }
    fn total(&self) -> f64 {
        self.total + self.block as f64
    }
}

/// Sum of squares with [`Accumulator`].
#[derive(Clone, Copy, Debug, Default)]
struct SumSq(Accumulator);

impl SumSq {
    fn add(&mut self, r: f32) {
        self.0.add(r * r);
    }
    fn total(&self) -> f64 {
        self.0.total()
    }
}
