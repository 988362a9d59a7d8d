//! A simulated experiment: its description (the arguments of `simulate`, also built by
//! `demo`) and the record it produces.

use crate::csvio::OwnedRecord;
use crate::spec::{parse_effect, parse_motor, EffectSpec};
use anyhow::{anyhow, bail, Result};
use clap::Args;
use motor_id_shared::model::profile::{
    default_load_torque, settling_duration, Experiment, Profile,
};
use motor_id_shared::model::synth::{synthesize, Buffers, Noise};
use motor_id_shared::ModelParams;
use std::path::PathBuf;

/// Most samples one simulation may write.
const MAX_SAMPLES: usize = 20_000_000;

/// The experiments by name (`motor_id_shared::model::profile::Profile`).
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum ProfileArg {
    /// Voltage step from rest (paper's Figs. 9, 11).
    Start,
    /// Half voltage, up to full at 1/3, down to a quarter at 2/3 (paper's Figs. 13-14).
    Steps,
    /// Full voltage, a known load torque step at half time (paper's Fig. 12).
    Load,
    /// Full voltage, reversed to minus full voltage at half time.
    Reversal,
}

impl From<ProfileArg> for Profile {
    fn from(p: ProfileArg) -> Profile {
        match p {
            ProfileArg::Start => Profile::Start,
            ProfileArg::Steps => Profile::Steps,
            ProfileArg::Load => Profile::Load,
            ProfileArg::Reversal => Profile::Reversal,
        }
    }
}

/// A simulated experiment (the arguments of `simulate`).
#[derive(Args, Debug, Clone)]
pub struct SimulateArgs {
    /// Motor parameters `ra=..,la=..,j=..,b=..,kv=..` (default: the paper's identified motor
    /// ra=3.412,la=0.0573,j=0.0424,b=0.00267,kv=0.1604).
    #[arg(long, value_name = "ra=..,la=..,j=..,b=..,kv=..", value_parser = parse_motor)]
    pub motor: Option<ModelParams>,
    /// Experiment.
    #[arg(long, value_enum, default_value_t = ProfileArg::Start)]
    pub profile: ProfileArg,
    /// Output record CSV.
    #[arg(long)]
    pub out: PathBuf,
    /// Add an effect, e.g. `coulomb_friction:tc=0.05` (repeatable).
    #[arg(long, value_name = "NAME:key=val,...", value_parser = parse_effect)]
    pub effect: Vec<EffectSpec>,
    /// Standard deviation of white noise on the speed reading [rad/s].
    #[arg(long, default_value_t = 0.0)]
    pub noise_omega: f32,
    /// Standard deviation of white noise on the current reading [A].
    #[arg(long, default_value_t = 0.0)]
    pub noise_current: f32,
    /// Sample rate [Hz].
    #[arg(long, default_value_t = 1000.0)]
    pub rate: f64,
    /// Noise seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Length [s] (default: five slowest time constants per profile segment).
    #[arg(long)]
    pub duration: Option<f64>,
    /// Full armature voltage [V].
    #[arg(long, default_value_t = 50.0)]
    pub voltage: f32,
    /// Load torque of the `load` profile [N m] (default: 20 % of stall torque).
    #[arg(long)]
    pub load_torque: Option<f32>,
    /// Leave the current column out of the CSV (a tacho-only record, as in the seed).
    #[arg(long)]
    pub speed_only: bool,
    /// After the experiment, open the bridge for this many seconds: a coast-down, in which
    /// friction alone slows the shaft (the CSV gets a `bridge` column: 1 driven, 0 open).
    #[arg(long, value_name = "S")]
    pub coast: Option<f64>,
    /// No message on stderr (no progress either).
    #[arg(long, short)]
    pub quiet: bool,
}

/// Build the simulated record described by `a`.
pub fn simulate(a: &SimulateArgs) -> Result<OwnedRecord> {
    let mut p = a.motor.unwrap_or(ModelParams::PAPER_MOTOR);
    crate::spec::apply_effects(&a.effect, &mut p)?;
    let profile = Profile::from(a.profile);
    if !(a.rate.is_finite() && a.rate > 0.0) {
        bail!("--rate must be a positive number of Hz");
    }
    for (name, x) in [
        ("--noise-omega", a.noise_omega),
        ("--noise-current", a.noise_current),
    ] {
        if !(x.is_finite() && x >= 0.0) {
            bail!("{name} must be >= 0");
        }
    }
    if !a.voltage.is_finite() {
        bail!("--voltage must be finite");
    }
    let duration = match a.duration {
        Some(d) if d.is_finite() && d > 0.0 => d,
        Some(_) => bail!("--duration must be > 0"),
        None => (settling_duration(&p, profile) as f64).clamp(0.05, 120.0),
    };
    let coast = match a.coast {
        Some(c) if c.is_finite() && c > 0.0 => c,
        Some(_) => bail!("--coast must be a positive number of seconds"),
        None => 0.0,
    };
    let driven = (duration * a.rate).round() as usize;
    let n = ((duration + coast) * a.rate).round() as usize;
    let coast_from = (a.coast.is_some() && n > driven).then_some(driven);
    if n < motor_id_shared::model::record::MIN_SAMPLES {
        bail!("{duration} s at {} Hz gives only {n} samples", a.rate);
    }
    if n > MAX_SAMPLES {
        bail!(
            "{duration} s at {} Hz gives {n} samples (at most {MAX_SAMPLES})",
            a.rate
        );
    }
    let load_torque = match a.load_torque {
        Some(t) if t.is_finite() => t,
        Some(_) => bail!("--load-torque must be finite"),
        None => default_load_torque(&p, a.voltage),
    };
    let experiment = Experiment {
        profile,
        voltage: a.voltage,
        duration: duration as f32,
        load_torque,
    };
    let dt = (1.0 / a.rate) as f32;
    let (mut v, mut tl, mut omega, mut current) =
        (vec![0.0; n], vec![0.0; n], vec![0.0; n], vec![0.0; n]);
    let noise = Noise {
        omega: a.noise_omega,
        current: a.noise_current,
    };
    let buffers = Buffers {
        v: &mut v,
        tl: &mut tl,
        omega: &mut omega,
        current: &mut current,
    };
    let bar = crate::progress::simulating(n, a.quiet);
    let synthesized = synthesize(&p, &experiment, dt, noise, a.seed, coast_from, buffers);
    bar.finish_and_clear();
    synthesized.map_err(|e| anyhow!("{e}"))?;
    if let Some(k) = omega.iter().position(|x| !x.is_finite()) {
        bail!("the simulation gave non-finite numbers at sample {k}: check the motor parameters");
    }
    Ok(OwnedRecord {
        path: a.out.clone(),
        t0: 0.0,
        dt,
        v,
        omega,
        current: (!a.speed_only).then_some(current),
        load: experiment.has_load().then_some(tl),
        coast_from,
        averaged: 1,
    })
}
