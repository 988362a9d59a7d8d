//! `motor-id identify`, `import-scope` and `demo`.

use crate::cli::FitOptions;
use crate::csvio::{import_scope as read_scope, OwnedRecord, ScopeImport};
use crate::plot::{draw, Panel, Series};
use crate::progress::FitProgress;
use crate::report::{identify_json, summary};
use crate::simulate_cmd::{simulate, SimulateArgs};
use crate::spec::problem;
use anyhow::{anyhow, Context, Result};
use clap::Args;
use motor_id_shared::fit::identify::{identify_from, Identification, IdentifyConfig, Pipeline};
use motor_id_shared::fit::objective::Objective;
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::wire::protocol::PipelineName;
use motor_id_shared::{ModelParams, Record};
use plotters::style::{RGBColor, BLUE, RED};
use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

/// Arguments of `identify`.
#[derive(Args, Debug)]
pub struct IdentifyArgs {
    /// Record CSV files (columns t, v, omega, optional i, tl), fitted jointly.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    #[command(flatten)]
    pub fit: FitOptions,
    /// Pipeline: `default` (equation-error start, short FFO, least squares), `board` (what
    /// a drive board runs: start and least squares, FFO only when that stays above the
    /// noise floor) or `paper` (the seed's FFO alone).
    #[arg(long, value_enum, default_value_t = PipelineArg::Default)]
    pub pipeline: PipelineArg,
    /// Paper-faithful mode, short for `--pipeline paper`: the seed's FFO (k=4, n=25,
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

/// Everything one identification produced.
pub struct Fit {
    /// Problem solved.
    pub spec: ProblemSpec,
    /// Result.
    pub result: Identification,
    /// Whether current was fitted.
    pub with_current: bool,
}

/// Identify from loaded records with the problem given on the command line.
pub fn fit(records: &[OwnedRecord], opts: &FitOptions, pipeline: Pipeline) -> Result<Fit> {
    let spec = problem(&opts.bounds, &opts.fix)?;
    run_fit(records, opts, &spec, &pipeline.config(opts.seed), None)
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

fn run_fit(
    records: &[OwnedRecord],
    opts: &FitOptions,
    spec: &ProblemSpec,
    cfg: &IdentifyConfig,
    initial: Option<&ModelParams>,
) -> Result<Fit> {
    let spec = *spec;
    let with_current = !opts.speed_only && records.iter().all(|r| r.current.is_some());
    let borrowed: Vec<Record> = records.iter().map(|r| r.as_record(with_current)).collect();
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
    })
}

fn load(files: &[PathBuf]) -> Result<Vec<OwnedRecord>> {
    files.iter().map(|f| OwnedRecord::read(f)).collect()
}

/// Run `identify`.
pub fn run(a: &IdentifyArgs) -> Result<()> {
    let records = load(&a.files)?;
    let pipeline = a.pipeline();
    let f = fit(&records, &a.fit, pipeline)?;
    let samples: usize = records.iter().map(|r| r.len()).sum();
    print!("{}", summary(&f.result, &f.spec, samples, f.with_current));
    let names: Vec<String> = records.iter().map(|r| r.name()).collect();
    if let Some(path) = &a.json {
        let json = identify_json(&f.result, &f.spec, &names, a.fit.seed, pipeline.name());
        write_json(path, &json)?;
    }
    if let Some(path) = &a.plot {
        plot_fit(path, &records, &f)?;
    }
    Ok(())
}

/// Write pretty JSON.
pub fn write_json(path: &Path, value: &serde_json::Value) -> Result<()> {
    let text = serde_json::to_string_pretty(value).expect("JSON values always serialise");
    std::fs::write(path, text + "\n").with_context(|| format!("cannot write {}", path.display()))
}

/// Measured vs fitted speed, residual, convergence.
pub fn plot_fit(path: &Path, records: &[OwnedRecord], f: &Fit) -> Result<()> {
    let borrowed: Vec<Record> = records
        .iter()
        .map(|r| r.as_record(f.with_current))
        .collect();
    let objective = Objective::new(&borrowed).map_err(|e| anyhow!("{e}"))?;
    // Records side by side on one time axis.
    let (mut t, mut measured, mut fitted, mut residual) = (vec![], vec![], vec![], vec![]);
    let mut offset = 0.0;
    for (k, r) in records.iter().enumerate() {
        let mut w = vec![0.0; r.len()];
        let mut i = vec![0.0; r.len()];
        objective
            .simulate(&f.result.params, k, &mut w, &mut i)
            .map_err(|e| anyhow!("{e}"))?;
        for (s, (&m, &sim)) in r.omega.iter().zip(w.iter()).enumerate() {
            t.push(offset + s as f64 * r.dt as f64);
            measured.push(m);
            fitted.push(sim);
            residual.push(m - sim);
        }
        offset += r.len() as f64 * r.dt as f64;
    }
    let evals: Vec<f64> = f
        .result
        .trace
        .iter()
        .map(|p| p.evaluations as f64)
        .collect();
    let best: Vec<f32> = f.result.trace.iter().map(|p| p.best).collect();
    let green = RGBColor(0, 140, 0);
    let panels = [
        Panel {
            title: format!(
                "speed: measured vs fitted (rmse {:.4} rad/s)",
                f.result.cost.rmse_omega
            ),
            x_label: "t [s] (records side by side)",
            y_label: "omega [rad/s]",
            series: vec![
                Series {
                    label: "measured",
                    x: &t,
                    y: &measured,
                    color: BLUE,
                },
                Series {
                    label: "fitted",
                    x: &t,
                    y: &fitted,
                    color: RED,
                },
            ],
            log_y: false,
            categories: None,
        },
        Panel {
            title: "residual (measured - fitted)".into(),
            x_label: "t [s]",
            y_label: "omega error [rad/s]",
            series: vec![Series {
                label: "residual",
                x: &t,
                y: &residual,
                color: green,
            }],
            log_y: false,
            categories: None,
        },
        Panel {
            title: "convergence (seed Fig. 10)".into(),
            x_label: "model evaluations",
            y_label: "best fitness [rad/s]",
            series: vec![Series {
                label: "best",
                x: &evals,
                y: &best,
                color: BLUE,
            }],
            log_y: true,
            categories: None,
        },
    ];
    draw(path, &panels)
}

/// Arguments of `import-scope`.
#[derive(Args, Debug)]
pub struct ScopeArgs {
    /// Oscilloscope CSV (time and channel columns; header and settings lines are skipped).
    pub file: PathBuf,
    /// Output record CSV.
    #[arg(long)]
    pub out: PathBuf,
    /// Tacho gain [rad/s per V] (the seed's tacho: 35).
    #[arg(long)]
    pub tacho_gain: f32,
    /// The trace was captured with the scope's inverted option: negate it.
    #[arg(long)]
    pub inverted: bool,
    /// Armature voltage applied [V].
    #[arg(long)]
    pub voltage: f32,
    /// Time at which the voltage was switched on [s] (before it: 0 V).
    #[arg(long, default_value_t = 0.0)]
    pub step_at: f64,
    /// Zero-based column of time.
    #[arg(long, default_value_t = 0)]
    pub time_column: usize,
    /// Zero-based column of the tacho channel.
    #[arg(long, default_value_t = 1)]
    pub channel: usize,
}

/// Run `import-scope`.
pub fn import_scope(a: &ScopeArgs) -> Result<()> {
    if !(a.tacho_gain.is_finite() && a.tacho_gain != 0.0) {
        return Err(anyhow!("--tacho-gain must be a non-zero number"));
    }
    if !a.voltage.is_finite() || !a.step_at.is_finite() {
        return Err(anyhow!("--voltage and --step-at must be finite"));
    }
    let s = ScopeImport {
        gain: a.tacho_gain,
        inverted: a.inverted,
        time_column: a.time_column,
        channel: a.channel,
        voltage: a.voltage,
        step_at: a.step_at,
    };
    let rec = read_scope(&a.file, &s)?;
    rec.write(&a.out)?;
    eprintln!(
        "wrote {} samples at {} s step to {}",
        rec.len(),
        rec.dt,
        a.out.display()
    );
    Ok(())
}

/// Arguments of `demo`.
#[derive(Args, Debug)]
pub struct DemoArgs {
    /// Directory for the demo's CSV, JSON and PNG files.
    #[arg(long, default_value = "demo-out")]
    pub out_dir: PathBuf,
    /// Random seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// No progress bar.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Run `demo`.
pub fn demo(a: &DemoArgs) -> Result<()> {
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("cannot create {}", a.out_dir.display()))?;
    let csv = a.out_dir.join("seed_motor_steps.csv");
    let sim = SimulateArgs {
        motor: None,
        profile: "steps".into(),
        out: csv.clone(),
        effect: vec![],
        noise_omega: 0.5,
        noise_current: 0.02,
        rate: 100.0,
        seed: a.seed,
        duration: Some(30.0),
        voltage: 50.0,
        load_torque: None,
        speed_only: false,
    };
    let rec = simulate(&sim)?;
    rec.write(&csv)?;
    println!(
        "simulated the seed's motor (ra 3.412, la 0.0573, j 0.0424, b 0.00267, kv 0.1604): \
         voltage steps 25 -> 50 -> 12.5 V, {} samples at 100 Hz, noise 0.5 rad/s and 0.02 A -> {}",
        rec.len(),
        csv.display()
    );
    let records = [rec];
    for (label, speed_only, stem) in [
        ("speed only, as the seed paper fits", true, "speed_only"),
        (
            "speed and current, as a drive board measures",
            false,
            "with_current",
        ),
    ] {
        println!("\n== identify from {label}");
        let opts = FitOptions {
            seed: a.seed,
            speed_only,
            quiet: a.quiet,
            ..FitOptions::default()
        };
        let f = fit(&records, &opts, Pipeline::Default)?;
        print!(
            "{}",
            summary(&f.result, &f.spec, records[0].len(), f.with_current)
        );
        let json = a.out_dir.join(format!("{stem}.json"));
        let names = vec![csv.display().to_string()];
        write_json(
            &json,
            &identify_json(&f.result, &f.spec, &names, a.seed, Pipeline::Default.name()),
        )?;
        let png = a.out_dir.join(format!("{stem}.png"));
        plot_fit(&png, &records, &f)?;
        println!("report {} and plot {}", json.display(), png.display());
    }
    Ok(())
}
