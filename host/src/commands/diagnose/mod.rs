//! `motor-id diagnose`: where the model misfits, which unmodelled effect causes it, how far
//! the misfit shrinks once it is modelled — judged on held-out records the fit never saw.
//!
//! This module holds the arguments and runs the steps: [`search`] fits the baseline and the
//! catalogue's effects ([`first_round`] the baseline and each effect added to it, by
//! [`effect_fit`]) on the records of [`data`] (where the baseline misfits: [`regimes`]
//! and [`spectrum`]; whether an effect is real: [`verdict`]), [`coverage`] names the regimes
//! only the held-out records visit, [`repeatability`] measures how far repeat runs differ
//! (what no model can remove), [`naming`] decides whether the effects found may be named
//! as causes or only stand in for part of the misfit, [`report`] says what was found (its
//! text: [`report_text`]), [`plot`] draws it.

mod coverage;
mod data;
mod drift;
mod effect_fit;
mod first_round;
mod found;
mod naming;
mod parallel;
mod plot;
mod regime_shares;
mod regimes;
mod remainder;
mod repeatability;
mod report;
mod report_text;
mod search;
mod search_context;
mod spectrum;
mod stalled;
mod stand_ins;
mod verdict;
mod widening;

use crate::csvio::{ReadOptions, RecordReader};
use crate::fit::FitOptions;
use crate::output::write_json;
use anyhow::{bail, Result};
use clap::builder::{PossibleValuesParser, TypedValueParser};
use clap::Args;
use data::Data;
use motor_id_shared::model::effects::Effect;
use report::DiagnoseReport;
use std::path::PathBuf;

/// Arguments of `diagnose`.
#[derive(Args, Debug)]
pub struct DiagnoseArgs {
    /// Records to fit on.
    #[arg(long, required = true, num_args = 1..)]
    pub train: Vec<PathBuf>,
    /// Records the fits never see, to judge them on.
    #[arg(long, required = true, num_args = 1..)]
    pub holdout: Vec<PathBuf>,
    #[command(flatten)]
    pub fit: FitOptions,
    #[command(flatten)]
    pub read: ReadOptions,
    /// Runs of one experiment (same input), comma-separated: a group of repeats whose
    /// run-to-run spread is the repeatability floor (repeatable; files not among the
    /// training or held-out records are read for this only).
    #[arg(long, value_name = "A.csv,B.csv,...")]
    pub repeats: Vec<String>,
    /// Leave these effects of the catalogue out of the search, comma-separated (e.g. to see
    /// what is left of the misfit without them).
    #[arg(long, value_name = "EFFECT,...", value_delimiter = ',', value_parser = effect_name())]
    pub without: Vec<Effect>,
    /// Write the JSON report here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write a PNG plot (measured vs baseline vs with-effect speed, residuals, misfit by
    /// regime, and a zoom on the worst periods of each chirp- or sine-like held-out record,
    /// shaded on the overview) here.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// The effects of the catalogue by name, as clap parses them (the names are its possible
/// values).
fn effect_name() -> impl TypedValueParser<Value = Effect> {
    PossibleValuesParser::new(Effect::ALL.map(|e| e.name()))
        .map(|name| Effect::from_name(&name).expect("a possible value names an effect"))
}

/// Run `diagnose`.
pub fn run(a: &DiagnoseArgs) -> Result<()> {
    let mut reader = RecordReader::new(&a.read).quiet(a.fit.quiet);
    let train = reader.read_all(&a.train)?;
    let holdout = reader.read_all(&a.holdout)?;
    // Judging on a record the fit saw says nothing about what it never saw.
    for h in &holdout {
        if let Some(t) = train.iter().find(|t| t.same_data(h)) {
            bail!(
                "held-out record {} is the training record {}: hold out a record the fit does not see",
                h.name(),
                t.name()
            );
        }
    }
    // The catalogue's effects are simulated on readings at the instants only (a mean over
    // the step is modelled with no effect but Coulomb friction, `model::step_mean`).
    if let Some(r) = train.iter().chain(&holdout).find(|r| r.averaged > 1) {
        bail!(
            "{}: its readings are means of {} drive readings over each step (its averaged column), on which the catalogue's effects are not simulated: diagnose needs readings at the instants (`commission --sim --instant-readings` records them)",
            r.name(),
            r.averaged
        );
    }
    let with_current =
        !a.fit.speed_only && train.iter().chain(&holdout).all(|r| r.current.is_some());
    let data = Data {
        train,
        holdout,
        with_current,
    };
    // The repeats first: a file given by --repeats that cannot be read fails before the fits.
    let repeats = repeatability::Repeats::find(&data, &a.repeats, &mut reader)?;
    let repeat_floor = repeats.holdout_floor().map(|f| f as f32);
    let found = search::search(&data, &a.fit, &a.without, repeat_floor)?;
    let after = found.last();
    let repeats = repeats.report(&data, &after.fit.result.params)?;
    let current_noise = found.holdout.current_noise;
    let left = what_is_left(&data, &found, &a.fit, &repeats, current_noise)?;
    let warnings = data.foreign_holdouts(&found.baseline)?;
    for w in &warnings {
        eprintln!("warning: {w}");
    }
    let report = DiagnoseReport::new(&data, &found, repeats, left, current_noise, warnings);
    print!("{}", report.text());
    if let Some(path) = &a.json {
        write_json(path, &report)?;
    }
    if let Some(path) = &a.plot {
        let base = &found.baseline.fit.result.params;
        // The verdict's model: every named effect (what `holdout_rmse_after` judges).
        let chosen = found
            .chosen()
            .filter(|_| report.verdict.partial.is_empty())
            .map(|_| &found.last().fit.result.params);
        plot::plot(path, &data, base, chosen, &report)?;
    }
    Ok(())
}

/// What the final model leaves on the held-out records, for the verdict.
pub struct WhatIsLeft {
    /// The speed's remainder above the floor, where it lies (None when explained).
    pub remainder: Option<remainder::Remainder>,
    /// Where the current's misfit lies, when it alone is unexplained.
    pub current_where: Option<(Vec<regime_shares::RegimeShare>, Vec<String>)>,
    /// Named effects whose own regime keeps the misfit ([`naming`]).
    pub where_it_acts: Vec<naming::MisfitWhereItActs>,
}

/// What the final model of `found` leaves on the held-out records of `data`: the speed's
/// remainder above its floor (the noise, or `repeats`' run-to-run floor), where the
/// current's misfit lies when it alone is unexplained (against `current_noise`), and the
/// named effects whose own regime keeps the misfit ([`naming::misfit_where_it_acts`]).
fn what_is_left(
    data: &Data,
    found: &found::Search,
    opts: &FitOptions,
    repeats: &repeatability::Repeatability,
    current_noise: Option<f32>,
) -> Result<WhatIsLeft> {
    let after = found.last();
    let repeat_floor = repeats.holdout_floor().map(|f| f.0);
    // The final model's held-out residuals, simulated once for every question below.
    let traces = data.holdout_traces(&after.fit.result.params)?;
    let remainder = remainder::remainder(
        data,
        &traces,
        &after.fit,
        opts,
        after.holdout_rmse,
        found.holdout.noise,
        repeat_floor,
    )?;
    // The speed's remainder says where both channels' misfit lies.
    let current_alone = remainder.is_none()
        && after
            .holdout_rmse_current
            .zip(current_noise)
            .is_some_and(|(rmse, noise)| remainder::unexplained(rmse, noise));
    let current_where = current_alone
        .then(|| regime_shares::current_where(&traces))
        .flatten();
    let named: Vec<Effect> = found.named().map(|(e, _)| e).collect();
    let where_it_acts = regime_shares::misfit_where_named_act(
        &traces,
        &named,
        remainder::floor(found.holdout.noise, repeat_floor).0,
        current_noise.filter(|_| data.with_current),
    );
    Ok(WhatIsLeft {
        remainder,
        current_where,
        where_it_acts,
    })
}
