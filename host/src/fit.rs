//! Fitting records: the options every fitting command shares (`FitOptions`), the pipelines by
//! name (`PipelineArg`), and one identification run with its progress bar (`Fit`).

use crate::csvio::OwnedRecord;
use crate::progress::FitProgress;
use crate::report::identify::FitQuality;
use crate::spec::{parse_bounds, parse_fix, problem, BoundsSpec, FixSpec};
use anyhow::{anyhow, Result};
use clap::Args;
use motor_id_shared::fit::ffo::{FfoConfig, Soil};
use motor_id_shared::fit::identify::{identify_from, Identification, IdentifyConfig, Pipeline};
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::wire::protocol::PipelineName;
use motor_id_shared::ModelParams;
use std::ops::ControlFlow;

/// Options shared by the fitting commands.
#[derive(Args, Debug, Clone, Default)]
pub struct FitOptions {
    /// Search bounds, e.g. `ra=0.5:10,j=1e-6:1e-3` (default: seed Table 1). Bounds on an
    /// effect parameter (e.g. `tc=0:0.1`) fit that effect.
    #[arg(long, value_name = "P=LO:HI,...", value_parser = parse_bounds)]
    pub bounds: Vec<BoundsSpec>,
    /// Hold parameters at known values, e.g. `ra=3.4,la=0.00285`.
    #[arg(long, value_name = "P=V,...", value_parser = parse_fix)]
    pub fix: Vec<FixSpec>,
    /// Random seed (same seed and data, same result).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Ignore the current column (fit speed only, as the seed does).
    #[arg(long)]
    pub speed_only: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The pipelines by name (`motor_id_shared::fit::identify::Pipeline`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PipelineArg {
    /// Equation-error start, short FFO, least squares.
    Default,
    /// Start and least squares; FFO only above the noise floor (the board's).
    Board,
    /// The seed's FFO alone.
    Paper,
}

impl From<PipelineArg> for PipelineName {
    fn from(p: PipelineArg) -> PipelineName {
        match p {
            PipelineArg::Default => PipelineName::Default,
            PipelineArg::Board => PipelineName::Board,
            PipelineArg::Paper => PipelineName::Paper,
        }
    }
}

impl From<PipelineArg> for Pipeline {
    fn from(p: PipelineArg) -> Pipeline {
        match p {
            PipelineArg::Default => Pipeline::Default,
            PipelineArg::Board => Pipeline::Board,
            PipelineArg::Paper => Pipeline::Paper,
        }
    }
}

/// Everything one identification produced.
#[derive(Clone)]
pub struct Fit {
    /// Problem solved.
    pub spec: ProblemSpec,
    /// Result.
    pub result: Identification,
    /// Whether current was fitted.
    pub with_current: bool,
    /// Widened searches run after the pipeline, because its fit stayed above the noise
    /// (see [`fit`]).
    pub widened: u32,
}

/// The wider searches [`fit`] escalates to, in order: an FFO of the seed's population for 20
/// iterations (about 2,000 evaluations) and then the seed's whole FFO (40,100), each with
/// the soil step towards the best and followed by least squares from its best members.
fn widened_searches(seed: u64) -> [IdentifyConfig; 2] {
    let towards = |iterations| FfoConfig {
        iterations,
        soil: Soil::TowardsBest,
        ..FfoConfig::SEED
    };
    let wide = |iterations| IdentifyConfig {
        ffo: towards(iterations),
        ..IdentifyConfig::default_pipeline(seed)
    };
    [wide(20), wide(FfoConfig::SEED.iterations)]
}

/// Identify from loaded records with the problem given on the command line. With the
/// default pipeline, a fit that stays above its noise floor (the rule of `fit_quality`)
/// is not yet blamed on the model: the search is widened ([`widened_searches`]) until a fit
/// reaches the floor, or a wider search finds no fit better by 1 % (it agrees: the misfit is
/// the model's), or the widest has run; the best fit is kept, and `widened` and the
/// evaluations count every search.
pub fn fit(records: &[OwnedRecord], opts: &FitOptions, pipeline: Pipeline) -> Result<Fit> {
    let spec = problem(&opts.bounds, &opts.fix)?;
    let mut best = run_fit(records, opts, &spec, &pipeline.config(opts.seed), None)?;
    if pipeline != Pipeline::Default {
        return Ok(best);
    }
    let mut evaluations = best.result.evaluations;
    for (k, cfg) in widened_searches(opts.seed).iter().enumerate() {
        if FitQuality::of(&best.result).model_adequate {
            break;
        }
        let wider = run_fit(records, opts, &spec, cfg, None)?;
        evaluations += wider.result.evaluations;
        let before = best.result.cost.fitness();
        let gained = wider.result.cost.fitness() < before;
        if gained {
            best = wider;
        }
        best.widened = k as u32 + 1;
        // A wider search that finds no better fit (within 1 %) agrees with the pipeline: the
        // misfit is the model's, and a still wider one would only cost time.
        if best.result.cost.fitness() > 0.99 * before {
            break;
        }
    }
    best.result.evaluations = evaluations;
    Ok(best)
}

/// Identify `spec` from loaded records with the default pipeline, starting from `initial`
/// when given.
pub fn fit_from(
    records: &[OwnedRecord],
    opts: &FitOptions,
    spec: &ProblemSpec,
    initial: Option<&ModelParams>,
) -> Result<Fit> {
    run_fit(
        records,
        opts,
        spec,
        &IdentifyConfig::default_pipeline(opts.seed),
        initial,
    )
}

/// Refit `spec` by least squares from `start` alone, without a global search: for a start
/// that lies in the optimum's basin already (an effect's fit continued with every parameter
/// free, a model refitted with one effect taken out).
pub fn refit_from(
    records: &[OwnedRecord],
    opts: &FitOptions,
    spec: &ProblemSpec,
    start: &ModelParams,
) -> Result<Fit> {
    run_fit(
        records,
        opts,
        spec,
        &IdentifyConfig::local(opts.seed),
        Some(start),
    )
}

fn run_fit(
    records: &[OwnedRecord],
    opts: &FitOptions,
    spec: &ProblemSpec,
    cfg: &IdentifyConfig,
    initial: Option<&ModelParams>,
) -> Result<Fit> {
    let spec = *spec;
    let with_current = !opts.speed_only && records.iter().all(|r| r.current.is_some());
    let borrowed = OwnedRecord::as_records(records, with_current);
    let bar = FitProgress::new(opts.quiet);
    let result = identify_from(&borrowed, &spec, cfg, initial, |p| {
        bar.update(p);
        ControlFlow::Continue(())
    });
    bar.finish();
    let result = result.map_err(|e| anyhow!("identification failed: {e}"))?;
    Ok(Fit {
        spec,
        result,
        with_current,
        widened: 0,
    })
}
