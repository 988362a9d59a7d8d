//! `motor-id demo`: the whole job on a built-in default: the paper's motor simulated, then
//! identified from speed only (the paper's workflow) and from speed and current, and the
//! latter checked on the paper's validation experiments.

use crate::fit::{fit, FitOptions};
use crate::fit_plot::plot_fit;
use crate::output::write_json;
use crate::report::identify::IdentifyReport;
use crate::report::summary::summary;
use crate::simulation::{simulate, ProfileArg, SimulateArgs};
use crate::validation::{check, plot};
use anyhow::{Context, Result};
use clap::Args;
use motor_id_shared::fit::identify::Pipeline;
use motor_id_shared::ModelParams;
use std::path::PathBuf;

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
pub fn run(a: &DemoArgs) -> Result<()> {
    std::fs::create_dir_all(&a.out_dir)
        .with_context(|| format!("cannot create {}", a.out_dir.display()))?;
    let csv = a.out_dir.join("paper_motor_steps.csv");
    let sim = SimulateArgs {
        motor: None,
        profile: ProfileArg::Steps,
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
        coast: None,
        quiet: true,
    };
    let rec = simulate(&sim)?;
    rec.write(&csv)?;
    println!(
        "simulated the paper's motor (ra 3.412, la 0.0573, j 0.0424, b 0.00267, kv 0.1604): \
         voltage steps 25 -> 50 -> 12.5 V, {} samples at 100 Hz, noise 0.5 rad/s and 0.02 A -> {}",
        rec.len(),
        csv.display()
    );
    let records = [rec];
    let mut identified = ModelParams::PAPER_MOTOR;
    for (label, speed_only, stem) in [
        ("speed only, as the paper fits", true, "speed_only"),
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
        identified = f.result.params;
        print!(
            "{}",
            summary(&f.result, &f.spec, records[0].len(), f.with_current,)
        );
        let json = a.out_dir.join(format!("{stem}.json"));
        let names = vec![csv.display().to_string()];
        let report =
            IdentifyReport::new(&f.result, &f.spec, names, a.seed, Pipeline::Default.name());
        write_json(&json, &report)?;
        let png = a.out_dir.join(format!("{stem}.png"));
        plot_fit(&png, &records, &f)?;
        println!("report {} and plot {}", json.display(), png.display());
    }
    validation_set(a, &sim, &identified)
}

/// The paper's validation experiments (Figs. 11-14: starting at two voltages, a load
/// change, a change of voltage to its opposite), simulated on the paper's motor with other
/// noise, and the parameters identified from speed and current checked on them.
fn validation_set(a: &DemoArgs, base: &SimulateArgs, p: &ModelParams) -> Result<()> {
    println!("\n== validate the parameters identified with current on new experiments");
    let experiments = [
        ("start_25V", ProfileArg::Start, 25.0),
        ("start_50V", ProfileArg::Start, 50.0),
        ("load_change", ProfileArg::Load, 50.0),
        ("voltage_reversal", ProfileArg::Reversal, 50.0),
    ];
    let mut records = Vec::new();
    for (k, (name, profile, voltage)) in experiments.into_iter().enumerate() {
        let out = a.out_dir.join(format!("validation_{name}.csv"));
        let args = SimulateArgs {
            profile,
            voltage,
            duration: None,
            out: out.clone(),
            seed: a.seed.wrapping_add(100 + k as u64),
            ..base.clone()
        };
        let rec = simulate(&args)?;
        rec.write(&out)?;
        records.push(rec);
    }
    let (report, predicted) = check(p, &records, false)?;
    print!("{}", report.text());
    let json = a.out_dir.join("validation.json");
    write_json(&json, &report)?;
    let png = a.out_dir.join("validation.png");
    plot(&png, &records, &predicted)?;
    println!("report {} and plot {}", json.display(), png.display());
    Ok(())
}
