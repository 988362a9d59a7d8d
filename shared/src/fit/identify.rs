//! The run of an identification: the equation-error start and least squares, the FFO when
//! the configuration asks for it (always, or when least squares stays above the noise
//! floor), restarts from its best members, the escalation's wider searches, then the
//! identifiability analysis and its profile check (`docs/ARCHITECTURE.md`, data flow). The
//! configurations are in [`crate::fit::pipeline`].

use crate::error::Error;
use crate::fit::ffo::{Ffo, FfoConfig};
use crate::fit::identifiability::{analyse, Identifiability, ProfileLines};
use crate::fit::initial::start;
use crate::fit::objective::{Cost, Objective};
pub use crate::fit::pipeline::{Escalation, IdentifyConfig, Pipeline, SearchWhen};
use crate::fit::profile_check;
use crate::fit::progress::push_trace;
pub use crate::fit::progress::{Progress, Stage, TracePoint};
use crate::fit::refine::levenberg_marquardt;
use crate::fit::scale_resolution;
use crate::fit::space::{ProblemSpec, Space};
use crate::fit::workspace::FitWorkspace;
use crate::model::params::ModelParams;
use crate::model::record::Record;
use core::ops::ControlFlow;

use crate::capacity::{MAX_FREE, MAX_POPULATION, MAX_RESTARTS, TRACE_CAPACITY};

/// Starting points of refinement taken from the FFO's final population.
type RefineStarts = heapless::Vec<[f32; MAX_FREE], { MAX_RESTARTS + 1 }>;
/// A refinement that ends above this multiple of the measured noise is restarted from the
/// next best FFO member, while restarts remain.
const NOISE_FLOOR_FACTOR: f32 = 1.05;

/// The fitness at or below which a fit reaches the noise floor, for measured speed noise
/// `sigma_omega`: no restart and no wider search runs from there.
fn noise_floor(sigma_omega: f32) -> f32 {
    NOISE_FLOOR_FACTOR * sigma_omega
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
    /// Wider searches of the escalation run after the pipeline's own.
    pub widened: u32,
}

impl Identification {
    /// Whether the fit reaches the noise floor ([`NOISE_FLOOR_FACTOR`] times the measured
    /// speed noise): a pipeline's escalation runs no wider search from such a fit.
    pub fn at_noise_floor(&self) -> bool {
        self.cost.fitness() <= noise_floor(self.sigma_omega)
    }
}

/// Identify the free parameters of `spec` from `records`. `progress` is called after every
/// iteration; returning `Break` stops and returns the best result so far.
pub fn identify(
    records: &[Record],
    spec: &ProblemSpec,
    cfg: &IdentifyConfig,
    progress: impl FnMut(&Progress) -> ControlFlow<()>,
) -> Result<Identification, Error> {
    identify_from(records, spec, cfg, None, None, progress)
}

/// As [`identify`], starting from `initial` (free parameters taken from it, e.g. a previous
/// fit when an effect is added) instead of the equation-error estimate, with the Jacobian's
/// simulators in `workspace` when given (a board's static RAM, [`crate::fit::workspace`];
/// the result is the same either way). Both escalate as
/// the pipeline says ([`Escalation`]): while the fit stays above the noise floor
/// ([`NOISE_FLOOR_FACTOR`] times the measured noise), the wider searches of
/// [`IdentifyConfig::wider`] in turn, until one reaches the floor, or gains under 1 %, or the
/// widest has run; `evaluations` counts every search and `widened` how many wider ones ran.
/// A stuck search is thus not reported as a model that misses something.
pub fn identify_from(
    records: &[Record],
    spec: &ProblemSpec,
    cfg: &IdentifyConfig,
    initial: Option<&ModelParams>,
    workspace: Option<&FitWorkspace>,
    mut progress: impl FnMut(&Progress) -> ControlFlow<()>,
) -> Result<Identification, Error> {
    if cfg.restarts as usize > MAX_RESTARTS {
        return Err(Error::InvalidConfig);
    }
    let objective = Objective::new(records)?.with_workspace(workspace);
    let space = Space::new(spec, cfg.log_scale)?;
    objective.averaged_readings_modelled(&space)?;
    let searched = pipeline(
        records,
        spec,
        cfg,
        initial,
        &objective,
        &space,
        &mut progress,
    )?;
    let mut lines: ProfileLines = [[0.0; MAX_FREE]; MAX_FREE];
    let mut result = conclude(&objective, &space, searched, cfg.adc_readings, &mut lines);
    // The profile check works on the result in place (never a second copy of it), beside
    // the analysis's frame rather than on it. It is entered only when it has work (a flat
    // direction beside a pinned parameter, or a pinned parameter whose local deviation
    // exceeds `profile_check::CURVED_STD`), and reports its iterations as the fit does
    // (a board feeds its watchdog there). Stopped, or not started because the caller
    // stopped the fit, it leaves nothing pinned.
    if let (Some(lm), true, Ok(r)) = (&cfg.refine, cfg.profile_check, &mut result) {
        if !r.completed {
            profile_check::unchecked(&mut r.identifiability, &space, &lines);
        } else if profile_check::applies(&r.identifiability, &space, &lines) {
            let iterations =
                profile_check::runs(&r.identifiability, &space, &lines) * lm.max_iterations;
            let before = r.evaluations + r.identifiability.evaluations;
            let best = r.cost.fitness();
            let mut iteration = 0;
            let checked = profile_check::widen(
                &mut r.identifiability,
                &lines,
                &objective,
                &space,
                &r.params,
                &r.cost,
                lm,
                &mut |spent| {
                    iteration += 1;
                    progress(&Progress {
                        stage: Stage::Check,
                        iteration,
                        iterations,
                        evaluations: before + spent,
                        best,
                    })
                },
            );
            r.completed &= checked;
            r.analysis_evaluations = r.identifiability.evaluations;
        }
    }
    // An ADC's readings: a scale of J, B, Kv and friction under the current reading's
    // resolution is not pinned, whatever the local analysis says.
    if let (true, Ok(r), Some(sigma)) = (cfg.adc_readings, &mut result, objective.sigma_current()) {
        scale_resolution::unpin_scale(&mut r.identifiability, records, &r.params, sigma);
    }
    result
}

/// What the pipeline leaves: its best point and the run's counters.
struct Searched {
    u: [f32; MAX_FREE],
    cost: Cost,
    evaluations: u32,
    trace: heapless::Vec<TracePoint, TRACE_CAPACITY>,
    completed: bool,
    widened: u32,
}

/// The pipeline of [`identify_from`]: refinement of the start, the search when it is
/// called for, then the escalation's wider searches. A frame of its own (the run's state),
/// gone before [`conclude`] builds the result: on a board, only one of the two is on the
/// stack under the refinement's (docs/measurements/footprint.md).
#[inline(never)]
fn pipeline(
    records: &[Record],
    spec: &ProblemSpec,
    cfg: &IdentifyConfig,
    initial: Option<&ModelParams>,
    objective: &Objective,
    space: &Space,
    progress: impl FnMut(&Progress) -> ControlFlow<()>,
) -> Result<Searched, Error> {
    let mut run = Run {
        objective,
        space,
        cfg,
        ffo: cfg.ffo,
        seed: cfg.seed,
        progress,
        widened: 0,
        trace: heapless::Vec::new(),
        evaluations: 0,
        refine_iterations: 0,
        best: None,
        completed: true,
    };
    let dim = space.dim();
    // The default pipeline starts from an equation-error estimate (or the caller's point); the
    // paper-faithful one from random points only, as the paper does.
    let start_params = match initial {
        Some(p) => Some(*p),
        None if cfg.equation_error_start => start(records, spec),
        None => None,
    };
    let start_u = start_params.map(|p| {
        let mut full = spec.base;
        for f in space.free() {
            full.set(f.id, p.get(f.id));
        }
        space.unit(&full)
    });
    let floor = noise_floor(objective.floor_sigma());
    let refine_first = cfg.search != SearchWhen::Always;
    if let (true, Some(u0), Some(_)) = (refine_first, start_u, cfg.refine) {
        run.refine(&u0[..dim]);
    }
    let at_floor = run.best.is_some_and(|(_, c)| c.fitness() <= floor);
    let search = match cfg.search {
        SearchWhen::Always => true,
        SearchWhen::AboveFloor => !at_floor,
        // Without a start to refine, the search is the only way to a point.
        SearchWhen::Never => run.best.is_none(),
    };
    if search && run.completed {
        // Seed the search with the better of the start and its refinement.
        let seed_point = run.best.map(|(u, _)| u).or(start_u);
        run.search(seed_point.as_ref().map(|u| &u[..dim]))?;
    }
    // A fit still above the noise floor is not yet blamed on the model: the wider searches
    // of the escalation, each seeded with the same start, until one reaches the floor or
    // gains under 1 % over the fit before it (it agrees: the misfit is the model's, and a
    // still wider one would only cost time). The best fit so far is kept throughout.
    while let Some((ffo, seed)) = cfg.wider(run.widened as usize) {
        let before = run.best_fitness();
        if !run.completed || before <= floor {
            break;
        }
        run.ffo = ffo;
        run.seed = seed;
        run.widened += 1;
        run.search(start_u.as_ref().map(|u| &u[..dim]))?;
        if run.best_fitness() > WIDER_GAIN * before {
            break;
        }
    }
    let (u, cost) = run.best.ok_or(Error::NoFiniteCandidate)?;
    Ok(Searched {
        u,
        cost,
        evaluations: run.evaluations,
        trace: run.trace,
        completed: run.completed,
        widened: run.widened,
    })
}

/// The result at the pipeline's best point, with the identifiability analysis (of ADC
/// readings: [`IdentifyConfig::adc_readings`]). A frame of its own (see [`pipeline`]).
#[inline(never)]
fn conclude(
    objective: &Objective,
    space: &Space,
    searched: Searched,
    adc_readings: bool,
    lines: &mut ProfileLines,
) -> Result<Identification, Error> {
    let dim = space.dim();
    let (u, cost) = (searched.u, searched.cost);
    let identifiability = analyse(objective, space, &u[..dim], &cost, adc_readings, lines)?;
    Ok(Identification {
        params: space.params(&u[..dim]),
        cost,
        evaluations: searched.evaluations,
        analysis_evaluations: identifiability.evaluations,
        trace: searched.trace,
        identifiability,
        sigma_omega: objective.sigma_omega(),
        sigma_current: objective.sigma_current(),
        completed: searched.completed,
        widened: searched.widened,
    })
}

/// A fit this many times better than the one before a wider search counts as a gain; less,
/// and the wider search agrees that the misfit is the model's.
pub const WIDER_GAIN: f32 = 0.99;

/// State of one identification run: the best point so far, the trace and the counters.
struct Run<'o, 'r, 'a, P> {
    objective: &'o Objective<'r, 'a>,
    space: &'o Space,
    cfg: &'o IdentifyConfig,
    /// The FFO and random seed of the search: the pipeline's, a wider search's on escalation.
    ffo: FfoConfig,
    seed: u64,
    progress: P,
    /// Wider searches of the escalation run so far.
    widened: u32,
    trace: heapless::Vec<TracePoint, TRACE_CAPACITY>,
    evaluations: u32,
    refine_iterations: u32,
    best: Option<([f32; MAX_FREE], Cost)>,
    completed: bool,
}

impl<P: FnMut(&Progress) -> ControlFlow<()>> Run<'_, '_, '_, P> {
    fn best_fitness(&self) -> f32 {
        self.best.map_or(f32::INFINITY, |(_, c)| c.fitness())
    }

    fn offer(&mut self, u: &[f32; MAX_FREE], cost: Cost) {
        if self.best.is_none_or(|(_, c)| cost.sse < c.sse) {
            self.best = Some((*u, cost));
        }
    }

    /// Report one iteration; false when the caller asked to stop.
    fn report(&mut self, stage: Stage, iteration: u32, iterations: u32, best: f32) -> bool {
        push_trace(
            &mut self.trace,
            TracePoint {
                evaluations: self.evaluations,
                best,
            },
        );
        let p = Progress {
            stage,
            iteration,
            iterations,
            evaluations: self.evaluations,
            best,
        };
        let go_on = (self.progress)(&p).is_continue();
        self.completed &= go_on;
        go_on
    }

    /// Levenberg-Marquardt from `u0`.
    fn refine(&mut self, u0: &[f32]) {
        let Some(lm) = self.cfg.refine else { return };
        let iterations = lm.max_iterations * (self.cfg.restarts + 2);
        let base = self.evaluations;
        let before = self.best_fitness();
        let result = levenberg_marquardt(self.objective, self.space, u0, &lm, &mut |lp| {
            self.refine_iterations += 1;
            self.evaluations = base + lp.evaluations;
            let best = lp.cost.fitness().min(before);
            if self.report(Stage::Refine, self.refine_iterations, iterations, best) {
                ControlFlow::Continue(())
            } else {
                ControlFlow::Break(())
            }
        });
        if let Some(r) = result {
            self.evaluations = base + r.evaluations;
            self.offer(&r.u, r.cost);
        }
    }

    /// FFO (paper Eq. 8-16) from random points (and `seed_point`), then refinement of the best
    /// members until one reaches the noise floor or the restarts are spent.
    fn search(&mut self, seed_point: Option<&[f32]>) -> Result<(), Error> {
        let starts = self.explore(seed_point)?;
        let dim = self.space.dim();
        let floor = noise_floor(self.objective.floor_sigma());
        for u0 in &starts {
            if !self.completed || self.cfg.refine.is_none() {
                break;
            }
            self.refine(&u0[..dim]);
            if self.best_fitness() <= floor {
                break;
            }
        }
        Ok(())
    }

    /// The FFO (paper Eq. 8-16) from random points (and `seed_point`); returns the starts of
    /// refinement, the best `restarts + 1` members (best first, finite cost only). A frame
    /// of its own, so that the population is gone while refinement runs.
    #[inline(never)]
    fn explore(&mut self, seed_point: Option<&[f32]>) -> Result<RefineStarts, Error> {
        let (objective, space) = (self.objective, self.space);
        let fitness = |u: &[f32], bound: f32| objective.fitness_below(space, u, bound);
        let (iterations, restarts) = (self.ffo.iterations, self.cfg.restarts);
        let mut ffo = Ffo::<MAX_POPULATION, MAX_FREE>::with_start(
            self.ffo,
            space.dim(),
            self.seed,
            seed_point,
            fitness,
        )?;
        let base = self.evaluations;
        self.evaluations = base + ffo.evaluations();
        let first = ffo.best().1.min(self.best_fitness());
        push_trace(
            &mut self.trace,
            TracePoint {
                evaluations: self.evaluations,
                best: first,
            },
        );
        while !ffo.done() {
            let p = ffo.step(fitness);
            self.evaluations = base + p.evaluations;
            let best = p.best_cost.min(self.best_fitness());
            if !self.report(Stage::Search, p.iteration, iterations, best) {
                break;
            }
        }
        let (best_u, best_fit) = ffo.best();
        if best_fit.is_finite() {
            let mut u = [0.0f32; MAX_FREE];
            u[..space.dim()].copy_from_slice(best_u);
            if let Some(c) = objective.cost(&space.params(&u[..space.dim()])) {
                self.evaluations += 1;
                self.offer(&u, c);
            }
        }
        if self.best.is_none() {
            return Err(Error::NoFiniteCandidate);
        }
        let mut starts = RefineStarts::new();
        for rank in 0..=restarts as usize {
            let (u0, c0) = ffo.ranked(rank);
            if !c0.is_finite() {
                break;
            }
            let mut u = [0.0f32; MAX_FREE];
            u[..space.dim()].copy_from_slice(u0);
            // Never full: `restarts` is checked against the capacity up front.
            if starts.push(u).is_err() {
                break;
            }
        }
        Ok(starts)
    }
}

#[cfg(test)]
#[path = "identify_tests.rs"]
mod tests;
