//! Fitting records: the options every fitting command shares (`FitOptions`), the pipelines by
//! name (`PipelineArg`), and one identification run with its progress bar (`Fit`).

use crate::csvio::OwnedRecord;
use crate::progress::FitProgress;
use crate::spec::{parse_bounds, parse_fix, problem, BoundsSpec, FixSpec};
use anyhow::{anyhow, bail, Result};
use clap::Args;
use motor_id_shared::fit::identify::{
    identify_from, Escalation, Identification, IdentifyConfig, Pipeline, SearchWhen, WIDER_GAIN,
};
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::wire::protocol::PipelineName;
use motor_id_shared::ModelParams;
use std::borrow::Cow;
use std::ops::ControlFlow;

/// Options shared by the fitting commands.
#[derive(Args, Debug, Clone, Default)]
pub struct FitOptions {
    /// Search bounds, e.g. `ra=0.5:10,j=1e-6:1e-3` (default: paper's Table 1). Bounds on an
    /// effect parameter (e.g. `tc=0:0.1`) fit that effect.
    #[arg(long, value_name = "P=LO:HI,...", value_parser = parse_bounds)]
    pub bounds: Vec<BoundsSpec>,
    /// Hold parameters at known values, e.g. `ra=3.4,la=0.00285`.
    #[arg(long, value_name = "P=V,...", value_parser = parse_fix)]
    pub fix: Vec<FixSpec>,
    /// Random seed (same seed and data, same result).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Ignore the current column (fit speed only, as the paper does).
    #[arg(long)]
    pub speed_only: bool,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// The pipelines by name (`motor_id_shared::fit::identify::Pipeline`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PipelineArg {
    /// Equation-error start and least squares; a short FFO above the noise floor, then
    /// wider ones up to the paper's.
    Default,
    /// The same within a board's memory (its escalation: the short FFO run longer).
    Board,
    /// The paper's FFO alone.
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
}

/// Identify from loaded records with the problem given on the command line, with the
/// pipeline's escalation: a fit that stays above its noise floor is not yet blamed on the
/// model, the search is widened first (`fit::identify::identify_from`); `result.widened` and the
/// evaluations count every search.
pub fn fit(records: &[OwnedRecord], opts: &FitOptions, pipeline: Pipeline) -> Result<Fit> {
    let spec = problem(&opts.bounds, &opts.fix)?;
    run_fit(records, opts, &spec, &pipeline.config(opts.seed), None)
}

/// Identify from loaded records with the problem given on the command line and the default
/// pipeline, without its escalation or the profile check: a quick look (does a corrected
/// record fit to its noise? see [`crate::hints`]), not a report's fit.
pub fn fit_quick(records: &[OwnedRecord], opts: &FitOptions) -> Result<Fit> {
    let spec = problem(&opts.bounds, &opts.fix)?;
    let cfg = IdentifyConfig {
        escalation: Escalation::None,
        profile_check: false,
        ..IdentifyConfig::default_pipeline(opts.seed)
    };
    run_fit(records, opts, &spec, &cfg, None)
}

/// Identify `spec` from loaded records with the default pipeline without its escalation:
/// the diagnosis' baseline, which it widens as it widens its final model ([`widen_from`]).
pub fn fit_spec_unwidened(
    records: &[OwnedRecord],
    opts: &FitOptions,
    spec: &ProblemSpec,
) -> Result<Fit> {
    let cfg = IdentifyConfig {
        escalation: Escalation::None,
        ..IdentifyConfig::default_pipeline(opts.seed)
    };
    run_fit(records, opts, spec, &cfg, None)
}

/// Search the basin of `spec`'s few free parameters from `initial`
/// ([`IdentifyConfig::basin`]): the diagnosis' first stage of an effect added to a model
/// fitted already, before everything is refitted from there ([`refit_from`]); its
/// uncertainties are the local (delta-method) ones, without the profile check.
pub fn fit_basin_from(
    records: &[OwnedRecord],
    opts: &FitOptions,
    spec: &ProblemSpec,
    initial: &ModelParams,
) -> Result<Fit> {
    let cfg = IdentifyConfig::basin(opts.seed);
    run_fit(records, opts, spec, &cfg, Some(initial))
}

/// Refit `spec` by least squares from `start` alone, without a global search: for a start
/// that lies in the optimum's basin already (an effect's fit continued with every parameter
/// free, a model refitted with one effect taken out). Its uncertainties are the local
/// (delta-method) ones, without the profile check.
pub fn refit_from(
    records: &[OwnedRecord],
    opts: &FitOptions,
    spec: &ProblemSpec,
    start: &ModelParams,
) -> Result<Fit> {
    local_fit(records, opts, spec, start, false)
}

/// [`refit_from`] with the profile check of a base fit (its uncertainties checked along
/// the valley where it has a flat direction): a refit whose pinned parameters are reported,
/// as the diagnosis' baseline's are.
pub fn refit_checked_from(
    records: &[OwnedRecord],
    opts: &FitOptions,
    spec: &ProblemSpec,
    start: &ModelParams,
) -> Result<Fit> {
    local_fit(records, opts, spec, start, true)
}

/// Least squares from `start` alone ([`IdentifyConfig::local`]), with or without its
/// `profile_check`.
fn local_fit(
    records: &[OwnedRecord],
    opts: &FitOptions,
    spec: &ProblemSpec,
    start: &ModelParams,
    profile_check: bool,
) -> Result<Fit> {
    let cfg = IdentifyConfig {
        profile_check,
        ..IdentifyConfig::local(opts.seed)
    };
    run_fit(records, opts, spec, &cfg, Some(start))
}

/// A refit by least squares from a start ([`refit_from`], [`refit_checked_from`]).
pub type Refit = fn(&[OwnedRecord], &FitOptions, &ProblemSpec, &ModelParams) -> Result<Fit>;

/// Samples a widened search ([`widen_from`]) simulates per evaluation at most: the records
/// are decimated to this many (the lab motor's 86,000 training samples by 9), so that the
/// escalation's 4,100 evaluations cost about what 500 do on the records themselves. The
/// diagnosis' baseline escalation searches them so, and its search of an effect's basin
/// reads them so too ([`searched_records`]).
pub const WIDENED_SAMPLES: usize = 10_000;

/// Widen the search of `spec` around its fit at `start`, which stays above its noise floor,
/// as the pipeline's escalation widens the base fit (its first wider FFO,
/// `IdentifyConfig::wider`) over the parameters `alone` frees (an effect's own, the rest
/// held at `start`: the box of the motor's parameters is far wider than their basin, known
/// already; for the diagnosis' baseline, everything `spec` frees). The search starts from
/// `start`'s own optimum on the records it searches (least squares over the same
/// parameters): where it ends no better than that by 1 % (the escalation's rule) the fit
/// stands, and nothing more is done; otherwise `spec` is refitted by least squares on
/// `records` from its best (by `refit`). With `decimate`, the search runs on the records
/// decimated to at most [`WIDENED_SAMPLES`] (as `--decimate` reads a file: readings
/// averaged over each block, the input's voltage-seconds kept): it finds the basin, the
/// refit on every sample converges in it. A record that cannot be decimated (too short, a
/// coast-down within one block) is searched whole.
pub fn widen_from(
    records: &[OwnedRecord],
    opts: &FitOptions,
    alone: &ProblemSpec,
    spec: &ProblemSpec,
    start: &ModelParams,
    decimate: bool,
    refit: Refit,
) -> Result<Widened> {
    let (searched, k) = searched_records(records, decimate);
    let pipeline = IdentifyConfig::default_pipeline(opts.seed);
    let Some((ffo, seed)) = pipeline.wider(0) else {
        bail!("the default pipeline has no wider search");
    };
    let cfg = IdentifyConfig {
        ffo,
        seed,
        search: SearchWhen::Always,
        escalation: Escalation::None,
        profile_check: false,
        ..pipeline
    };
    let local = refit_from(&searched, opts, alone, start)?.result;
    let wide = run_fit(&searched, opts, alone, &cfg, Some(&local.params))?.result;
    let moved = wide.cost.fitness() < WIDER_GAIN * local.cost.fitness();
    let fit = match moved {
        true => Some(refit(records, opts, spec, &wide.params)?),
        false => None,
    };
    Ok(Widened {
        fit,
        searched_start: local.cost.fitness(),
        searched_widened: wide.cost.fitness(),
        search_evaluations: local.evaluations + wide.evaluations,
        decimation: k,
    })
}

/// The records a widened search runs on ([`widen_from`]), with the rows of a record per
/// sample: with `decimate`, `records` decimated to at most [`WIDENED_SAMPLES`] (as
/// `--decimate` reads a file), a record that cannot be decimated (too short, a coast-down
/// within one block) whole; the records themselves, 1, where none is decimated.
pub fn searched_records(
    records: &[OwnedRecord],
    decimate: bool,
) -> (Cow<'_, [OwnedRecord]>, usize) {
    let samples: usize = records.iter().map(|r| r.omega.len()).sum();
    let k = match decimate {
        true => samples.div_ceil(WIDENED_SAMPLES).max(1),
        false => 1,
    };
    if k == 1 {
        return (Cow::Borrowed(records), 1);
    }
    let decimated: Vec<Option<OwnedRecord>> = records.iter().map(|r| r.decimated(k)).collect();
    if decimated.iter().all(Option::is_none) {
        return (Cow::Borrowed(records), 1);
    }
    let pairs = decimated.into_iter().zip(records);
    let coarse = pairs.map(|(d, r)| d.unwrap_or_else(|| r.clone())).collect();
    (Cow::Owned(coarse), k)
}

/// A fit widened by [`widen_from`].
pub struct Widened {
    /// The refit on the records themselves from the search's best, where the search
    /// gained 1 % or more (its evaluations: the refit's only).
    pub fit: Option<Fit>,
    /// The objective on the searched records at the start's own optimum there.
    pub searched_start: f32,
    /// The same at the wider search's best.
    pub searched_widened: f32,
    /// Evaluations on the searched records: least squares from the start, then the wider
    /// FFO and its least squares.
    pub search_evaluations: u32,
    /// Rows of a record per sample of the searched records (1: none decimated; a record
    /// too short for it is searched whole).
    pub decimation: usize,
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
    let result = identify_from(&borrowed, &spec, cfg, initial, None, |p| {
        bar.update(p);
        ControlFlow::Continue(())
    });
    bar.finish();
    let result = result.map_err(|e| anyhow!("identification failed: {e}"))?;
    Ok(Fit {
        spec,
        result,
        with_current,
    })
}

#[cfg(test)]
#[path = "fit_tests.rs"]
pub mod tests;
