//! The paper's Table 3 on the user's records: several optimisers on the same objective
//! (paper Eq. 7, noise-weighted with current), in the same unit cube of the search space, with
//! the same evaluation budget, over several seeds: the paper-faithful FFO, this tool's
//! pipelines, and established optimisers of the `argmin` crate (Nelder-Mead and particle
//! swarm; its gradient methods need a gradient the simulation does not give, and finite
//! differences would spend the budget on it).

use crate::csvio::OwnedRecord;
use anyhow::{anyhow, Result};
use argmin::core::{CostFunction, Executor};
use argmin::solver::neldermead::NelderMead;
use argmin::solver::particleswarm::ParticleSwarm;
use motor_id_shared::fit::identify::{identify, IdentifyConfig, Stage};
use motor_id_shared::fit::objective::Objective;
use motor_id_shared::fit::space::{ProblemSpec, Space};
use rand::SeedableRng;
use serde::Serialize;
use std::cell::RefCell;
use std::ops::ControlFlow;
use std::time::Instant;

/// The optimisers compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Optimiser {
    /// The paper's FFO as the paper describes it (soil step away from the best), cut to the
    /// budget.
    PaperFfo,
    /// The default pipeline (start and least squares, a short FFO above the noise).
    Default,
    /// The board's pipeline (the same within a board's memory).
    Board,
    /// Nelder-Mead simplex (argmin), from the centre of the box.
    NelderMead,
    /// Particle swarm (argmin), 40 particles.
    ParticleSwarm,
}

impl Optimiser {
    /// All of them, in table order.
    pub const ALL: [Optimiser; 5] = [
        Optimiser::PaperFfo,
        Optimiser::Default,
        Optimiser::Board,
        Optimiser::NelderMead,
        Optimiser::ParticleSwarm,
    ];

    /// Name in the table and the JSON.
    pub const fn name(self) -> &'static str {
        match self {
            Optimiser::PaperFfo => "paper FFO (seed, soil away from best)",
            Optimiser::Default => "default pipeline",
            Optimiser::Board => "board pipeline",
            Optimiser::NelderMead => "Nelder-Mead (argmin)",
            Optimiser::ParticleSwarm => "particle swarm (argmin)",
        }
    }
}

/// One run of one optimiser.
#[derive(Serialize, Debug, Clone)]
pub struct Run {
    /// Random seed.
    pub seed: u64,
    /// Best fitness found (paper Eq. 7's RMSE; noise-weighted with current).
    pub fitness: f64,
    /// Evaluations spent.
    pub evaluations: u32,
    /// Wall time [s].
    pub seconds: f64,
    /// Best fitness after each evaluation that improved it: `(evaluations, fitness)`.
    #[serde(skip)]
    pub trace: Vec<(u32, f64)>,
}

/// What a counted objective has seen: evaluations, the best fitness, and the best by
/// evaluations.
type Log = (u32, f64, Vec<(u32, f64)>);

/// The objective in the unit cube, counting evaluations and keeping the best.
struct Counted<'o, 'r, 'a> {
    objective: &'o Objective<'r, 'a>,
    space: &'o Space,
    budget: u32,
    log: RefCell<Log>,
}

impl Counted<'_, '_, '_> {
    fn evaluate(&self, u: &[f64]) -> f64 {
        let mut log = self.log.borrow_mut();
        if log.0 >= self.budget {
            // Past the budget: no simulation; the solver stops at its iteration limit.
            return f64::INFINITY;
        }
        // Projected onto the box (Nelder-Mead may step outside it).
        let unit: Vec<f32> = u.iter().map(|x| x.clamp(0.0, 1.0) as f32).collect();
        let f = self.objective.fitness(self.space, &unit) as f64;
        log.0 += 1;
        let f = if f.is_finite() { f } else { f64::INFINITY };
        if f < log.1 {
            log.1 = f;
            let n = log.0;
            log.2.push((n, f));
        }
        f
    }
}

impl CostFunction for Counted<'_, '_, '_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, u: &Self::Param) -> Result<f64, argmin::core::Error> {
        Ok(self.evaluate(u))
    }
}

/// Run `optimiser` on `records` (`spec`'s free parameters, current when `with_current`) with
/// `budget` evaluations and `seed`.
pub fn run(
    optimiser: Optimiser,
    records: &[OwnedRecord],
    with_current: bool,
    spec: &ProblemSpec,
    budget: u32,
    seed: u64,
) -> Result<Run> {
    let recs = OwnedRecord::as_records(records, with_current);
    let objective = Objective::new(&recs).map_err(|e| anyhow!("{e}"))?;
    let start = Instant::now();
    let pipeline = |cfg: IdentifyConfig| -> Result<Run> {
        let mut trace = Vec::new();
        let id = identify(&recs, spec, &cfg, |p| {
            // The uncertainty's check after the fit is no part of the optimiser's convergence.
            if p.stage == Stage::Check {
                return ControlFlow::Continue(());
            }
            trace.push((p.evaluations, p.best as f64));
            if p.evaluations >= budget {
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        })
        .map_err(|e| anyhow!("{e}"))?;
        Ok(Run {
            seed,
            fitness: id.cost.fitness() as f64,
            evaluations: id.evaluations,
            seconds: start.elapsed().as_secs_f64(),
            trace,
        })
    };
    match optimiser {
        Optimiser::PaperFfo => {
            let mut cfg = IdentifyConfig::paper_faithful(seed);
            // Each iteration evaluates the population twice (paper Eq. 13-16 and the soil
            // step): the iterations that fit the budget after the first population and the
            // final evaluation of the best (the paper's 100 + 200 x 200 + 1 = 40,101).
            let n = cfg.ffo.population() as u32;
            cfg.ffo.iterations = (budget.saturating_sub(n + 1) / (2 * n)).max(1);
            pipeline(cfg)
        }
        Optimiser::Default => pipeline(IdentifyConfig::default_pipeline(seed)),
        Optimiser::Board => pipeline(IdentifyConfig::board(seed)),
        Optimiser::NelderMead | Optimiser::ParticleSwarm => {
            let space = Space::new(spec, true).map_err(|e| anyhow!("{e}"))?;
            let dim = space.dim();
            let counted = Counted {
                objective: &objective,
                space: &space,
                budget,
                log: RefCell::new((0, f64::INFINITY, Vec::new())),
            };
            if optimiser == Optimiser::NelderMead {
                // A simplex about a seeded random point of the box (the seed varies it).
                let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
                let centre: Vec<f64> = (0..dim)
                    .map(|_| 0.25 + 0.5 * rand::Rng::random::<f64>(&mut rng))
                    .collect();
                let mut simplex = vec![centre.clone()];
                for k in 0..dim {
                    let mut v = centre.clone();
                    v[k] += 0.2;
                    simplex.push(v);
                }
                let solver = NelderMead::new(simplex)
                    .with_sd_tolerance(1e-10)
                    .map_err(|e| anyhow!("{e}"))?;
                Executor::new(counted, solver)
                    .configure(|s| s.max_iters(budget as u64))
                    .run()
                    .map_err(|e| anyhow!("{e}"))
                    .map(|r| r.problem.problem.expect("the problem is returned"))
                    .map(|c| finish(c, seed, start))
            } else {
                let particles = 40;
                let solver = ParticleSwarm::new((vec![0.0; dim], vec![1.0; dim]), particles)
                    .with_rng_generator(rand::rngs::StdRng::seed_from_u64(seed));
                Executor::new(counted, solver)
                    .configure(|s| s.max_iters((budget as u64 / particles as u64).max(1)))
                    .run()
                    .map_err(|e| anyhow!("{e}"))
                    .map(|r| r.problem.problem.expect("the problem is returned"))
                    .map(|c| finish(c, seed, start))
            }
        }
    }
}

fn finish(c: Counted, seed: u64, start: Instant) -> Run {
    let (evaluations, fitness, trace) = c.log.into_inner();
    Run {
        seed,
        fitness,
        evaluations,
        seconds: start.elapsed().as_secs_f64(),
        trace,
    }
}

/// Evaluations a run took to come within 1 % of `best` (`None`: never).
pub fn evaluations_to(run: &Run, best: f64) -> Option<u32> {
    run.trace
        .iter()
        .find(|(_, f)| *f <= 1.01 * best)
        .map(|(n, _)| *n)
}
