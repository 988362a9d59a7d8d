//! `motor-id identify`: fit one or more record CSVs jointly, print the summary, and write
//! the JSON report and the plot when asked.

use crate::csvio::{ReadOptions, RecordReader};
use crate::fit::{fit, FitOptions, PipelineArg};
use crate::fit_plot::plot_fit;
use crate::hints::cheap_explanations;
use crate::output::write_json;
use crate::report::identify::IdentifyReport;
use crate::report::summary::summary;
use anyhow::Result;
use clap::Args;
use motor_id_shared::fit::identify::Pipeline;
use std::path::PathBuf;

/// Arguments of `identify`.
#[derive(Args, Debug)]
pub struct IdentifyArgs {
    /// Record CSV files (columns t, v, omega, optional i, tl), fitted jointly.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    #[command(flatten)]
    pub fit: FitOptions,
    #[command(flatten)]
    pub read: ReadOptions,
    /// Pipeline: `default` (equation-error start and least squares; a short FFO when that
    /// stays above the noise floor, then wider searches up to the paper's FFO), `board` (what
    /// a drive board runs: the same within its memory) or `paper` (the paper's FFO alone).
    #[arg(long, value_enum, default_value_t = PipelineArg::Default)]
    pub pipeline: PipelineArg,
    /// Paper-faithful mode, short for `--pipeline paper`: the paper's FFO (k=4, n=25,
    /// alpha 0.4, beta 0.6, 200 iterations, 40,100 evaluations, linear scale), no refinement.
    #[arg(long, conflicts_with = "pipeline")]
    pub paper: bool,
    /// Write the JSON report here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write a PNG plot (measured vs fitted speed, residual, convergence) here.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

impl IdentifyArgs {
    /// The chosen pipeline (`--paper` or `--pipeline`).
    pub fn pipeline(&self) -> Pipeline {
        if self.paper {
            Pipeline::Paper
        } else {
            self.pipeline.into()
        }
    }
}

/// Run `identify`.
pub fn run(a: &IdentifyArgs) -> Result<()> {
    let records = RecordReader::new(&a.read)
        .quiet(a.fit.quiet)
        .read_all(&a.files)?;
    let pipeline = a.pipeline();
    let f = fit(&records, &a.fit, pipeline)?;
    let samples: usize = records.iter().map(|r| r.len()).sum();
    print!("{}", summary(&f.result, &f.spec, samples, f.with_current));
    // Before a misfit is left to an unmodelled effect: a sign or a unit that explains it.
    let say = |msg: &str| {
        if !a.fit.quiet {
            eprintln!("{msg}");
        }
    };
    let hints = cheap_explanations(&records, &a.fit, &f, &say)?;
    for h in &hints {
        println!("hint: {h}");
    }
    if let Some(path) = &a.json {
        let names = records.iter().map(|r| r.name()).collect();
        let report = IdentifyReport::new(&f.result, &f.spec, names, a.fit.seed, pipeline.name())
            .with_hints(hints);
        write_json(path, &report)?;
    }
    if let Some(path) = &a.plot {
        plot_fit(path, &records, &f)?;
    }
    Ok(())
}
