//! `motor-id validate`: identified parameters checked on new experiments (paper's Figs. 11-14:
//! start-up, load change, speed change); the checking itself is [`crate::validation`].

use crate::csvio::{ReadOptions, RecordReader};
use crate::output::write_json;
use crate::validation::{check, plot, read_params};
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

/// Arguments of `validate`.
#[derive(Args, Debug)]
pub struct ValidateArgs {
    /// The parameters: a JSON report of `identify` or `board` (its `params`) or of
    /// `diagnose` (its verdict's model, `verdict.params`).
    #[arg(long, value_name = "REPORT.json")]
    pub params: PathBuf,
    /// Record CSVs to check the parameters on.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    #[command(flatten)]
    pub read: ReadOptions,
    /// Judge the speed only, even where a record has current.
    #[arg(long)]
    pub speed_only: bool,
    /// Write the JSON report here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write a PNG plot (measured vs predicted speed of each record) here.
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// No progress on stderr. This command's work is short and shows none; the option is
    /// taken as on every command, so that scripts can pass it everywhere.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Run `validate`.
pub fn run(a: &ValidateArgs) -> Result<()> {
    let p = read_params(&a.params)?;
    let records = RecordReader::new(&a.read)
        .quiet(a.quiet)
        .read_all(&a.files)?;
    let (report, predicted) = check(&p, &records, a.speed_only)?;
    print!("{}", report.text());
    if let Some(path) = &a.json {
        write_json(path, &report)?;
    }
    if let Some(path) = &a.plot {
        plot(path, &records, &predicted)?;
    }
    match report.all_adequate {
        true => Ok(()),
        false => Err(crate::cli::CheckFailed(
            "the parameters do not predict every record to its noise floor".into(),
        )
        .into()),
    }
}
