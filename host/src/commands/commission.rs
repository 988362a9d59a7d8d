//! `motor-id commission --sim`: the board's own commissioning (probe, experiment designed
//! from it, fit of its records; the shared device code unchanged) run on the host against a
//! simulated motor, so that a motor is tried before a board is flashed. It writes the
//! board's report, the plan, and the records the board recorded.

use crate::board_records::{check_out_dir, write_records};
use crate::limits_args::{within, LimitArgs};
use crate::output::write_json;
use crate::progress::{BarState, FitProgress};
use crate::report::board::{plan_text, unpinned_reasons, unpinned_text, BoardReport};
use crate::report::Num;
use crate::spec::{parse_effect, parse_motor, EffectSpec};
use anyhow::{bail, Result};
use clap::Args;
use motor_id_shared::device::job::JobEnd;
use motor_id_shared::device::plant::SimulatedPlant;
use motor_id_shared::device::virtual_board::commission;
use motor_id_shared::wire::limits::Limits;
use motor_id_shared::wire::protocol::{BoardMessage, Plan};
use motor_id_shared::ModelParams;
use serde::Serialize;
use std::collections::BTreeMap;
use std::path::PathBuf;

/// The arguments of `commission`.
#[derive(Args, Debug)]
pub struct CommissionArgs {
    /// Commission a simulated motor on the host (the virtual board); a real board
    /// commissions itself (`motor-id board commission`).
    #[arg(long)]
    pub sim: bool,
    /// The simulated motor `ra=..,la=..,j=..,b=..,kv=..` (default: the paper's motor).
    #[arg(long, value_name = "ra=..,la=..,j=..,b=..,kv=..", value_parser = parse_motor)]
    pub motor: Option<ModelParams>,
    /// Add an effect to the simulated motor, e.g. `coulomb_friction:tc=0.05` (repeatable).
    #[arg(long, value_name = "NAME:key=val,...", value_parser = parse_effect)]
    pub effect: Vec<EffectSpec>,
    #[command(flatten)]
    pub limits: LimitArgs,
    /// The drive's sample rate (ADC and PWM) [Hz] (100 to 100,000).
    #[arg(long, default_value_t = 20_000.0, value_parser = within(100.0, 100_000.0))]
    pub rate: f32,
    /// Bits of the ADC that reads tacho and current, over ±1.2 times the speed and current
    /// limits (0: no quantisation; 4 to 24 otherwise).
    #[arg(long, default_value_t = 12, value_parser = adc_bits)]
    pub adc_bits: u32,
    /// Record each sample as the drive's reading at its instant, not the mean of its
    /// readings over the sample step (the board's default: noise down by the square root of
    /// the readings averaged).
    #[arg(long)]
    pub instant_readings: bool,
    /// White noise on the speed reading [rad/s].
    #[arg(long, default_value_t = 0.1, value_parser = within(0.0, 1e6))]
    pub noise_omega: f32,
    /// White noise on the current reading [A].
    #[arg(long, default_value_t = 0.005, value_parser = within(0.0, 1e6))]
    pub noise_current: f32,
    /// Random seed of the identification (the sensor noise takes it plus one).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Write the report as JSON.
    #[arg(long)]
    pub json: Option<PathBuf>,
    /// Write the board's records as record CSVs (`slow.csv`, `fast.csv`) into this directory.
    #[arg(long, value_name = "DIR")]
    pub out_dir: Option<PathBuf>,
    /// No progress on stderr.
    #[arg(short, long)]
    pub quiet: bool,
}

fn adc_bits(text: &str) -> Result<u32, String> {
    match text.parse::<u32>() {
        Ok(b) if b == 0 || (4..=24).contains(&b) => Ok(b),
        _ => Err("must be 0 or a whole number from 4 to 24".into()),
    }
}

/// What `commission` reports.
#[derive(Serialize, Debug)]
struct CommissionReport {
    /// The limits it worked within.
    limits: Limits,
    /// What the probe measured and the experiment designed from it, as the board sends it
    /// (null: refused before).
    plan: Option<Plan>,
    /// Time the experiment took on the drive [s].
    experiment_seconds: Num,
    /// The board's report of the motor (null: not commissioned).
    motor: Option<BoardReport>,
    /// Why it was not commissioned (null: commissioned).
    refusal: Option<String>,
    /// Why each parameter the data did not pin is not pinned, by name (empty: all pinned).
    unpinned: BTreeMap<&'static str, String>,
}

/// Run `commission`.
pub fn run(a: &CommissionArgs) -> Result<()> {
    if !a.sim {
        bail!("commission runs on the virtual board only (--sim); a drive board commissions itself at power-up, or with `motor-id board --port PORT commission`");
    }
    let mut motor = a.motor.unwrap_or(ModelParams::PAPER_MOTOR);
    crate::spec::apply_effects(&a.effect, &mut motor)?;
    if let Some(dir) = &a.out_dir {
        check_out_dir(dir)?;
    }
    let limits = a.limits.over(Limits::DEFAULT);
    let mut plant = SimulatedPlant::new(
        &motor,
        1.0 / a.rate,
        a.noise_omega,
        a.noise_current,
        a.seed.wrapping_add(1),
    )?;
    if a.adc_bits > 0 {
        (plant.resolution.omega, plant.resolution.current) = limits.adc_counts(a.adc_bits);
    }
    // What the unpinned parameters' reasons compare the friction currents with.
    let current_count = plant.resolution.current;
    // Ctrl-C: the virtual board hears it as the host's abort.
    let interrupted = crate::interrupt::take_over();
    let bar = FitProgress::new(a.quiet);
    let averaged = !a.instant_readings;
    let outcome = commission(
        plant,
        limits,
        averaged,
        a.seed,
        Some(interrupted),
        &mut |m| {
            if let BoardMessage::Planned(plan) = m {
                if !a.quiet {
                    bar.println(&plan_text(plan));
                }
            } else if let Some(state) = BarState::of_board(m) {
                bar.show(&state);
            }
        },
    );
    bar.finish();
    let unpinned = match (&outcome.result, &outcome.plan) {
        (Ok(r), Some(plan)) => unpinned_reasons(r, plan, current_count),
        _ => BTreeMap::new(),
    };
    let (motor, refusal) = match &outcome.result {
        Ok(r) => (Some(BoardReport::new(r)?), None),
        Err(JobEnd::Aborted) => (None, Some("interrupted: the experiment was stopped".into())),
        Err(JobEnd::Refused(r)) => (None, Some(r.to_string())),
    };
    let report = CommissionReport {
        limits,
        plan: outcome.plan,
        experiment_seconds: Num(outcome.seconds),
        motor,
        refusal,
        unpinned,
    };
    if let Some(path) = &a.json {
        write_json(path, &report)?;
    }
    if let Some(dir) = &a.out_dir {
        write_records(dir, &outcome.records)?;
    }
    if let Some(why) = &report.refusal {
        bail!("not commissioned: {why}");
    }
    if let Some(m) = &report.motor {
        print!("{}{}", m.text(), unpinned_text(&report.unpinned));
        println!("experiment: {:.1} s", outcome.seconds);
    }
    Ok(())
}
