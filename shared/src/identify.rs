//! Identification: FFO over the bounds, then Levenberg-Marquardt to the noise floor, then the
//! identifiability analysis (DESIGN.md data flow, steps 3-5).

use crate::error::Error;
use crate::ffo::{Ffo, FfoConfig};
use crate::identifiability::{analyse, Identifiability};
use crate::objective::{Cost, Objective};
use crate::params::ModelParams;
use crate::record::Record;
use crate::refine::{levenberg_marquardt, LmConfig};
use crate::space::{ProblemSpec, Space, MAX_FREE};
use core::ops::ControlFlow;

/// Largest FFO population (the seed's 4 x 25).
pub const MAX_POPULATION: usize = 100;
/// Longest convergence trace kept (the seed's 200 iterations plus refinement).
pub const TRACE_CAPACITY: usize = 256;
/// A refinement that ends above this multiple of the measured noise is restarted from the
/// next best FFO member, while restarts remain.
const NOISE_FLOOR_FACTOR: f32 = 1.05;

/// How to identify.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifyConfig {
    /// Global search.
    pub ffo: FfoConfig,
    /// Local refinement after it (`None`: FFO only, as the seed).
    pub refine: Option<LmConfig>,
    /// Search log-scaled where bounds are positive (false: linear, seed Eq. 9).
    pub log_scale: bool,
    /// Random seed.
    pub seed: u64,
    /// Extra refinements from the next best FFO members when the first stops above the noise.
    pub restarts: u32,
}

impl IdentifyConfig {
    /// The default pipeline: a short FFO in log scale, then least squares.
    pub fn default_pipeline(seed: u64) -> Self {
        IdentifyConfig {
            ffo: FfoConfig::QUICK,
            refine: Some(LmConfig::default()),
            log_scale: true,
            seed,
            restarts: 3,
        }
    }

    /// The seed's workflow: FFO with the seed's settings (40,100 evaluations) in linear
    /// scale over Table 1, no refinement.
    pub fn paper_faithful(seed: u64) -> Self {
        IdentifyConfig {
            ffo: FfoConfig::SEED,
            refine: None,
            log_scale: false,
            seed,
            restarts: 0,
        }
    }
}

/// Which stage is running.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Stage {
    /// FFO iterations.
    Search,
    /// Levenberg-Marquardt iterations.
    Refine,
}

/// Progress report, after every FFO or refinement iteration.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Progress {
    /// Stage.
    pub stage: Stage,
    /// Iteration within the stage.
    pub iteration: u32,
    /// Iterations the stage will run at most.
    pub iterations: u32,
    /// Evaluations spent so far in total.
    pub evaluations: u32,
    /// Best fitness so far (RMSE of speed for speed-only records).
    pub best: f32,
}

/// One point of the convergence trace (seed Fig. 10).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TracePoint {
    /// Evaluations spent.
    pub evaluations: u32,
    /// Best fitness then.
    pub best: f32,
}

/// Outcome of an identification.
#[derive(Clone, Debug, PartialEq)]
pub struct Identification {
    /// Identified parameters (fixed ones as given).
    pub params: ModelParams,
    /// Cost at them.
    pub cost: Cost,
    /// Evaluations of the search and refinement.
    pub evaluations: u32,
    /// Evaluations spent by the identifiability analysis.
    pub analysis_evaluations: u32,
    /// Best fitness after the initial population and every iteration.
    pub trace: heapless::Vec<TracePoint, TRACE_CAPACITY>,
    /// What the data pins.
    pub identifiability: Identifiability,
    /// Measured speed noise [rad/s].
    pub sigma_omega: f32,
    /// Measured current noise [A], when current was fitted.
    pub sigma_current: Option<f32>,
    /// False when the caller stopped it early (the result is the best so far).
    pub completed: bool,
}

fn push_trace(trace: &mut heapless::Vec<TracePoint, TRACE_CAPACITY>, point: TracePoint) {
    if trace.push(point).is_err() {
        // Full: keep the newest point in the last slot.
        if let Some(last) = trace.last_mut() {
            *last = point;
        }
    }
}

/// Identify the free parameters of `spec` from `records`. `progress` is called after every
/// iteration; returning `Break` stops and returns the best result so far.
pub fn identify(
    records: &[Record],
    spec: &ProblemSpec,
    cfg: &IdentifyConfig,
    mut progress: impl FnMut(&Progress) -> ControlFlow<()>,
) -> Result<Identification, Error> {
    let objective = Objective::new(records)?;
    let space = Space::new(spec, cfg.log_scale)?;
    let dim = space.dim();
    let fitness = |u: &[f32]| objective.fitness(&space, u);
    let mut ffo = Ffo::<MAX_POPULATION, MAX_FREE>::new(cfg.ffo, dim, cfg.seed, fitness)?;
    let mut trace = heapless::Vec::new();
    push_trace(
        &mut trace,
        TracePoint {
            evaluations: ffo.evaluations(),
            best: ffo.best().1,
        },
    );
    let mut completed = true;
    while !ffo.done() {
        let p = ffo.step(fitness);
        push_trace(
            &mut trace,
            TracePoint {
                evaluations: p.evaluations,
                best: p.best_cost,
            },
        );
        let report = Progress {
            stage: Stage::Search,
            iteration: p.iteration,
            iterations: cfg.ffo.iterations,
            evaluations: p.evaluations,
            best: p.best_cost,
        };
        if progress(&report).is_break() {
            completed = false;
            break;
        }
    }
    let (best_u, best_fit) = ffo.best();
    if !best_fit.is_finite() {
        return Err(Error::NoFiniteCandidate);
    }
    let mut u = [0.0f32; MAX_FREE];
    u[..dim].copy_from_slice(best_u);
    let mut cost = objective
        .cost(&space.params(&u[..dim]))
        .ok_or(Error::NoFiniteCandidate)?;
    let mut evaluations = ffo.evaluations() + 1;
    if let (Some(lm), true) = (cfg.refine, completed) {
        let floor = NOISE_FLOOR_FACTOR * objective.sigma_omega();
        let mut refine_iterations = 0;
        for start in 0..=cfg.restarts as usize {
            let (u0, _) = ffo.ranked(start);
            let base_evaluations = evaluations;
            let best_so_far = cost.fitness();
            let result = levenberg_marquardt(&objective, &space, u0, &lm, |lp| {
                refine_iterations += 1;
                let best = lp.cost.fitness().min(best_so_far);
                let report = Progress {
                    stage: Stage::Refine,
                    iteration: refine_iterations,
                    iterations: lm.max_iterations * (cfg.restarts + 1),
                    evaluations: base_evaluations + lp.evaluations,
                    best,
                };
                push_trace(
                    &mut trace,
                    TracePoint {
                        evaluations: report.evaluations,
                        best,
                    },
                );
                progress(&report)
            });
            let Some(r) = result else { continue };
            evaluations += r.evaluations;
            if r.cost.sse < cost.sse {
                u = r.u;
                cost = r.cost;
            }
            if !r.completed {
                completed = false;
                break;
            }
            if cost.fitness() <= floor {
                break;
            }
        }
    }
    let identifiability = analyse(&objective, &space, &u[..dim], &cost)?;
    Ok(Identification {
        params: space.params(&u[..dim]),
        cost,
        evaluations,
        analysis_evaluations: identifiability.evaluations,
        trace,
        identifiability,
        sigma_omega: objective.sigma_omega(),
        sigma_current: objective.sigma_current(),
        completed,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::params::ParamId;
    use crate::profile::{default_load_torque, Experiment, Profile};
    use crate::synth::{synthesize, Buffers, Noise};
    use std::vec::Vec;

    pub struct Owned {
        pub dt: f32,
        pub v: Vec<f32>,
        pub tl: Vec<f32>,
        pub omega: Vec<f32>,
        pub current: Vec<f32>,
    }

    impl Owned {
        pub fn new(
            p: &ModelParams,
            exp: Experiment,
            dt: f32,
            n: usize,
            noise: Noise,
            seed: u64,
        ) -> Owned {
            let mut o = Owned {
                dt,
                v: vec![0.0; n],
                tl: vec![0.0; n],
                omega: vec![0.0; n],
                current: vec![0.0; n],
            };
            let buffers = Buffers {
                v: &mut o.v,
                tl: &mut o.tl,
                omega: &mut o.omega,
                current: &mut o.current,
            };
            synthesize(p, &exp, dt, noise, seed, buffers).unwrap();
            o
        }
        pub fn record(&self, with_current: bool, with_load: bool) -> Record<'_> {
            Record {
                dt: self.dt,
                v: &self.v,
                omega: &self.omega,
                current: with_current.then_some(&self.current[..]),
                load: with_load.then_some(&self.tl[..]),
            }
        }
    }

    fn assert_within(p: &ModelParams, truth: &ModelParams, rel: f32) {
        for id in ParamId::MOTOR {
            let (a, b) = (p.get(id), truth.get(id));
            assert!(
                (a / b - 1.0).abs() <= rel,
                "{}: {a} vs {b} (all: {p:?})",
                id.name()
            );
        }
    }

    #[test]
    fn seed_motor_with_current_recovered_within_one_percent() {
        let truth = ModelParams::SEED_MOTOR;
        let exp = Experiment {
            profile: Profile::Steps,
            voltage: 50.0,
            duration: 30.0,
            load_torque: 0.0,
        };
        let data = Owned::new(
            &truth,
            exp,
            0.015,
            2000,
            Noise {
                omega: 0.5,
                current: 0.02,
            },
            11,
        );
        let rec = [data.record(true, false)];
        let id = identify(
            &rec,
            &ProblemSpec::default(),
            &IdentifyConfig::default_pipeline(1),
            |_| ControlFlow::Continue(()),
        )
        .unwrap();
        std::println!(
            "{:?} evals {} rmse {}",
            id.params,
            id.evaluations,
            id.cost.rmse_omega
        );
        assert_within(&id.params, &truth, 0.01);
        assert!(id.identifiability.all_pinned(), "{:?}", id.identifiability);
        let floor = Objective::new(&rec)
            .unwrap()
            .cost(&truth)
            .unwrap()
            .rmse_omega;
        assert!(
            id.cost.rmse_omega <= 1.01 * floor,
            "{} vs floor {floor}",
            id.cost.rmse_omega
        );
    }

    #[test]
    fn speed_only_step_pins_three_combinations() {
        let truth = ModelParams::SEED_MOTOR;
        let exp = Experiment {
            profile: Profile::Start,
            voltage: 50.0,
            duration: 20.0,
            load_torque: 0.0,
        };
        let data = Owned::new(
            &truth,
            exp,
            0.01,
            2000,
            Noise {
                omega: 0.2,
                current: 0.0,
            },
            5,
        );
        let rec = [data.record(false, false)];
        let id = identify(
            &rec,
            &ProblemSpec::default(),
            &IdentifyConfig::default_pipeline(2),
            |_| ControlFlow::Continue(()),
        )
        .unwrap();
        let ident = &id.identifiability;
        std::println!("{:?}", ident);
        assert_eq!(ident.rank, 3);
        assert!(ident.params.iter().all(|p| !p.pinned));
        assert!(ident.combinations.iter().all(|c| c.pinned));
        assert_eq!(ident.unpinned.len(), 2);
        let floor = Objective::new(&rec)
            .unwrap()
            .cost(&truth)
            .unwrap()
            .rmse_omega;
        assert!(
            id.cost.rmse_omega <= 1.01 * floor,
            "{} vs floor {floor}",
            id.cost.rmse_omega
        );
        let _ = default_load_torque(&truth, 50.0);
    }
}
#[cfg(test)]
mod probe {
    use super::tests::Owned;
    use super::*;
    use crate::profile::{Experiment, Profile};
    use crate::synth::Noise;
    #[test]
    fn probe_eigs() {
        for noise in [0.2f32, 0.01] {
            let truth = ModelParams::SEED_MOTOR;
            let exp = Experiment {
                profile: Profile::Start,
                voltage: 50.0,
                duration: 20.0,
                load_torque: 0.0,
            };
            let data = Owned::new(
                &truth,
                exp,
                0.01,
                2000,
                Noise {
                    omega: noise,
                    current: 0.0,
                },
                5,
            );
            let rec = [data.record(false, false)];
            let id = identify(
                &rec,
                &ProblemSpec::default(),
                &IdentifyConfig::default_pipeline(2),
                |_| ControlFlow::Continue(()),
            )
            .unwrap();
            let floor = Objective::new(&rec)
                .unwrap()
                .cost(&truth)
                .unwrap()
                .rmse_omega;
            std::eprintln!(
                "noise {noise} rank {} rmse {} floor {floor} evals {} params {:?}",
                id.identifiability.rank,
                id.cost.rmse_omega,
                id.evaluations,
                id.params
            );
            for t in id.trace.iter() {
                std::eprint!("({},{}) ", t.evaluations, t.best);
            }
            std::eprintln!();
        }
    }
}
