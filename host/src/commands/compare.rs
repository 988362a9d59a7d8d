//! `motor-id compare`: the paper's Table 3 on the user's records: optimisers on the same
//! objective and budget over several seeds ([`crate::comparison`]), as a table, JSON and a
//! convergence plot.

use crate::comparison::{evaluations_to, run, Optimiser, Run};
use crate::csvio::{ReadOptions, RecordReader};
use crate::fit::FitOptions;
use crate::output::write_json;
use crate::plot::{draw, Panel, Series};
use crate::report::SCHEMA_VERSION;
use crate::spec::problem;
use anyhow::{bail, Result};
use clap::Args;
use motor_id_shared::fit::identify::IdentifyConfig;
use plotters::style::{RGBColor, BLUE, RED};
use serde::Serialize;
use std::path::PathBuf;

/// Arguments of `compare`.
#[derive(Args, Debug)]
pub struct CompareArgs {
    /// Record CSV files, fitted jointly.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    #[command(flatten)]
    pub fit: FitOptions,
    #[command(flatten)]
    pub read: ReadOptions,
    /// Evaluations each optimiser may spend (the pipelines stop earlier on their own).
    #[arg(long, default_value_t = 4000)]
    pub budget: u32,
    /// Runs per optimiser, with seeds `--seed`, `--seed + 1`, ...
    #[arg(long, default_value_t = 5)]
    pub runs: u32,
    /// Write the JSON report here.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write a PNG convergence plot (best fitness by evaluations, first seed) here.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// One optimiser's runs.
#[derive(Serialize, Debug)]
struct Row {
    name: &'static str,
    /// Runs within 1 % of the best fitness any run found.
    success_rate: f64,
    /// Median evaluations to come within 1 % of it (`null`: under half the runs did).
    median_evaluations_to_best: Option<u32>,
    /// Median evaluations spent.
    median_evaluations: u32,
    /// Median final fitness.
    median_fitness: f64,
    /// Median wall time [s].
    median_seconds: f64,
    runs: Vec<Run>,
}

/// The `compare` report.
#[derive(Serialize, Debug)]
struct CompareReport {
    schema_version: u32,
    budget: u32,
    /// The best fitness any run found: the reference of success.
    best_known_fitness: f64,
    optimisers: Vec<Row>,
}

fn median<T: Copy + PartialOrd>(mut x: Vec<T>) -> Option<T> {
    x.sort_by(|a, b| a.partial_cmp(b).unwrap_or(std::cmp::Ordering::Equal));
    x.get(x.len() / 2).copied()
}

/// Run `compare`.
pub fn run_compare(a: &CompareArgs) -> Result<()> {
    if a.runs == 0 {
        bail!("--runs must be at least 1");
    }
    // The paper's FFO cannot stop within its first iteration: its population, both of the
    // iteration's evaluations of it, and the final best (paper Eq. 8-16).
    let n = IdentifyConfig::paper_faithful(a.fit.seed).ffo.population() as u32;
    let least = 3 * n + 1;
    if a.budget < least {
        bail!(
            "--budget {} is below one iteration of the paper's FFO ({least} evaluations: a population of {n}, evaluated twice per iteration, and the final best): give --budget {least} or more",
            a.budget
        );
    }
    let records = RecordReader::new(&a.read)
        .quiet(a.fit.quiet)
        .read_all(&a.files)?;
    let spec = problem(&a.fit.bounds, &a.fit.fix)?;
    let with_current = !a.fit.speed_only && records.iter().all(|r| r.current.is_some());
    let mut all: Vec<(Optimiser, Vec<Run>)> = Vec::new();
    for o in Optimiser::ALL {
        if !a.fit.quiet {
            eprintln!("running {} ({} runs)", o.name(), a.runs);
        }
        let runs = (0..a.runs)
            .map(|k| {
                run(
                    o,
                    &records,
                    with_current,
                    &spec,
                    a.budget,
                    a.fit.seed + k as u64,
                )
            })
            .collect::<Result<Vec<Run>>>()?;
        all.push((o, runs));
    }
    let best = all
        .iter()
        .flat_map(|(_, r)| r.iter().map(|x| x.fitness))
        .fold(f64::INFINITY, f64::min);
    let rows: Vec<Row> = all
        .into_iter()
        .map(|(o, runs)| {
            let to_best: Vec<Option<u32>> = runs.iter().map(|r| evaluations_to(r, best)).collect();
            let reached = to_best.iter().filter(|x| x.is_some()).count();
            Row {
                name: o.name(),
                success_rate: reached as f64 / runs.len() as f64,
                median_evaluations_to_best: (2 * reached > runs.len())
                    .then(|| median(to_best.iter().map(|x| x.unwrap_or(u32::MAX)).collect()))
                    .flatten(),
                median_evaluations: median(runs.iter().map(|r| r.evaluations).collect())
                    .unwrap_or(0),
                median_fitness: median(runs.iter().map(|r| r.fitness).collect())
                    .unwrap_or(f64::NAN),
                median_seconds: median(runs.iter().map(|r| r.seconds).collect()).unwrap_or(0.0),
                runs,
            }
        })
        .collect();
    println!(
        "{:<40} {:>8} {:>16} {:>12} {:>14} {:>10}",
        "optimiser", "success", "evals to best", "evals spent", "fitness", "time s"
    );
    for r in &rows {
        let to = r
            .median_evaluations_to_best
            .map_or("-".to_string(), |n| n.to_string());
        println!(
            "{:<40} {:>7.0}% {:>16} {:>12} {:>14.6} {:>10.3}",
            r.name,
            100.0 * r.success_rate,
            to,
            r.median_evaluations,
            r.median_fitness,
            r.median_seconds
        );
    }
    println!(
        "success: within 1 % of the best fitness any run found ({best:.6}); medians over {} runs, budget {} evaluations",
        a.runs, a.budget
    );
    let report = CompareReport {
        schema_version: SCHEMA_VERSION,
        budget: a.budget,
        best_known_fitness: best,
        optimisers: rows,
    };
    if let Some(path) = &a.json {
        write_json(path, &report)?;
    }
    if let Some(path) = &a.plot {
        let colors = [
            RED,
            BLUE,
            RGBColor(0, 140, 0),
            RGBColor(160, 0, 160),
            RGBColor(200, 120, 0),
        ];
        let traces: Vec<(Vec<f64>, Vec<f32>)> = report
            .optimisers
            .iter()
            .map(|r| {
                let t = &r.runs[0].trace;
                (
                    t.iter().map(|p| p.0 as f64).collect(),
                    t.iter().map(|p| p.1 as f32).collect(),
                )
            })
            .collect();
        let series = report
            .optimisers
            .iter()
            .zip(&traces)
            .zip(colors)
            .map(|((r, (x, y)), color)| Series {
                label: r.name,
                x,
                y,
                color,
            })
            .collect();
        draw(
            path,
            &[Panel {
                title: "best fitness by evaluations (first seed)".into(),
                x_label: "evaluations",
                y_label: "fitness [rad/s]",
                series,
                log_y: true,
                categories: None,
                spans: vec![],
            }],
        )?;
    }
    Ok(())
}
