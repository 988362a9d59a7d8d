//! Blind checks of `motor-id diagnose` on the independent reference plant: records with
//! given effects on a motor and at sizes drawn from a seed (a few % of the stall torque, the
//! supply voltage or the stall current), diagnosed through the CLI, and what was named.
//! Used by `examples/blind_check.rs` (the benchmark over every new entry, pair and rate) and
//! by `tests/diagnose_reference.rs`.

use crate::reference_plant::{
    csv, experiment, run, Effects, Gaussian, Motor, Sensors, Shape, SpeedSensor,
};
use crate::{diagnose, named_effects};
use serde_json::Value;
use std::collections::BTreeSet;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Supply voltage [V].
const VOLTS: f64 = 24.0;
/// Encoder lines (4 counts per line): a quantum of 2 pi / (8192 dt), 1.5 rad/s at 2 kHz.
const LINES: u32 = 2048;
/// White noise on the current reading [A] (0.2 % of a stall current near 24 A).
const NOISE_CURRENT: f64 = 0.05;

/// The new catalogue entries of this check, by the name the case line uses.
pub const SINGLES: [&str; 7] = [
    "static",
    "asymmetric",
    "deadtime",
    "offset",
    "limit",
    "cogging",
    "heating",
];

/// Effects the diagnosis is not given, by the name the case line uses: cogging without its
/// detents per revolution (`cogging-untold`; the `cogging` case is told them, as a
/// datasheet would, and the diagnosis tries cogging only when told). Nothing may be named
/// for them.
pub const WITHHELD: [&str; 1] = ["cogging-untold"];

/// The catalogue's older entries, by the name the case line uses: with [`SINGLES`] and
/// `delay`, every entry of the catalogue, for the table of each left out with `--without`.
pub const OLDER: [&str; 5] = ["coulomb", "quadratic", "reaction", "brush", "ripple"];

/// The catalogue entries whose effect the plant holds for case name `effect`: static and
/// asymmetric friction come with their Coulomb friction.
pub fn components(effect: &str) -> Vec<&'static str> {
    let mut held: Vec<&'static str> = entry(effect).into_iter().collect();
    if matches!(effect, "static" | "asymmetric") {
        held.insert(0, "coulomb_friction");
    }
    held
}

/// The case name of every catalogue entry: [`OLDER`], [`SINGLES`] and the delay.
pub fn entry_cases() -> Vec<&'static str> {
    OLDER
        .iter()
        .chain(&SINGLES)
        .chain(&["delay"])
        .copied()
        .collect()
}

/// Every catalogue entry by its catalogue name ([`entry_cases`]).
pub fn catalogue() -> Vec<&'static str> {
    entry_cases().into_iter().filter_map(entry).collect()
}

/// The entries to leave out (`--without`) so that the search holds only what the plant of
/// case `names` holds ([`components`]): a miss that this search names right is one the
/// records show and the whole catalogue's search lost to an entry the plant does not hold;
/// one it does not name is not named even among the truth's own entries.
pub fn all_but_the_truth(names: &[&str]) -> Vec<&'static str> {
    let held: Vec<&str> = names.iter().flat_map(|x| components(x)).collect();
    catalogue()
        .into_iter()
        .filter(|e| !held.contains(e))
        .collect()
}

/// White noise of the quiet tacho that reads a tacho's own effects [rad/s] (0.04 % of the
/// held-out speed's RMS, near 130 rad/s): a tacho ripple and a speed reading's delay are a
/// tacho's, and the [`LINES`]-line encoder's count difference hides them (its quantum at 5
/// kHz, 3.8 rad/s, is some thirty times a delay's trace of 0.1-0.2 rad/s;
/// docs/measurements/blind-checks.md).
pub const QUIET_TACHO: f64 = 0.05;

/// The effects of the case line that a tacho shows and the encoder hides.
pub const TACHO_EFFECTS: [&str; 2] = ["ripple", "delay"];

/// White noise of a tacho that reads the speed of case `names` instead of the encoder
/// [rad/s]: the environment's `BLIND_TACHO` (e.g. `BLIND_TACHO=0.2`) for every case, else
/// [`QUIET_TACHO`] for a case holding one of [`TACHO_EFFECTS`], else none (the encoder).
/// For the harness (`examples/blind_check.rs`); the tests give their sensor.
pub fn tacho_noise(names: &[&str]) -> Option<f64> {
    if let Ok(noise) = std::env::var("BLIND_TACHO") {
        let noise = noise
            .parse()
            .expect("BLIND_TACHO: a noise in rad/s, e.g. 0.05");
        return Some(noise);
    }
    let a_tacho_s = names.iter().any(|n| TACHO_EFFECTS.contains(n));
    a_tacho_s.then_some(QUIET_TACHO)
}

/// The speed sensor of every record: the [`LINES`]-line encoder, or a tacho with white
/// noise `tacho` (a reading whose error is white, not an encoder's count difference).
fn speed_sensor(tacho: Option<f64>) -> SpeedSensor {
    match tacho {
        Some(_) => SpeedSensor::Tacho,
        None => SpeedSensor::Encoder { lines: LINES },
    }
}

/// The catalogue name of a case's effect; `None` for a withheld one.
pub fn entry(effect: &str) -> Option<&'static str> {
    match effect {
        "static" => Some("static_friction"),
        "asymmetric" => Some("asymmetric_friction"),
        "deadtime" => Some("bridge_deadtime"),
        "offset" => Some("current_offset"),
        "limit" => Some("current_limit"),
        "cogging" => Some("cogging"),
        "cogging-untold" => None,
        "heating" => Some("winding_heating"),
        "coulomb" => Some("coulomb_friction"),
        "quadratic" => Some("quadratic_load"),
        "reaction" => Some("armature_reaction"),
        "brush" => Some("brush_drop"),
        "ripple" => Some("tacho_ripple"),
        "delay" => Some("sensor_delay"),
        other => panic!("unknown effect {other}"),
    }
}

/// A motor near the reference plant's fast one (1 ohm, 20 mH, 2e-3 kg m^2, 0.08 V s/rad),
/// each parameter scaled by a factor in [0.7, 1.4].
fn motor(g: &mut Gaussian) -> Motor {
    let mut f = || 0.7 + 0.7 * g.uniform();
    Motor {
        ra: f(),
        la: 0.02 * f(),
        j: 0.002 * f(),
        b: 0.001 * f(),
        kv: 0.08 * f(),
    }
}

/// Effect sizes for `effects` on `m`: Coulomb 2-4 % of the stall torque, a break-away excess
/// 2-5 % over 2-10 % of the top speed, an asymmetry of a third to two thirds of the Coulomb
/// torque, a dead-time error of 2-4 % of the supply over 2-5 % of the stall current, a
/// current offset of 1-3 % of the stall current (either sign), a drive's current limit at
/// 35-40 % of the stall current, cogging of 5 % of the stall torque at 12 per revolution, a
/// speed sensor's delay of half a sample to one, winding heating with a thermal time
/// constant of 10-30 s (its rise per watt set by [`heating_to`]).
fn effects(names: &[&str], m: &Motor, rate: f64, g: &mut Gaussian) -> Effects {
    let stall_torque = VOLTS / m.ra * m.kv;
    let stall_current = VOLTS / m.ra;
    let top = m.steady_speed(VOLTS);
    let mut u = |lo: f64, hi: f64| lo + (hi - lo) * g.uniform();
    let mut e = Effects::default();
    for name in names {
        match *name {
            "static" | "asymmetric" if e.tc == 0.0 => e.tc = u(0.02, 0.04) * stall_torque,
            _ => {}
        }
        match *name {
            "static" => {
                e.ts = u(0.02, 0.05) * stall_torque;
                e.ws = u(0.02, 0.1) * top;
            }
            "asymmetric" => {
                let sign = if u(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
                e.ta = sign * u(0.33, 0.67) * e.tc;
            }
            "deadtime" => {
                e.vdt = u(0.02, 0.04) * VOLTS;
                e.ib = u(0.02, 0.05) * stall_current;
            }
            "offset" => {
                let sign = if u(0.0, 1.0) < 0.5 { -1.0 } else { 1.0 };
                e.io = sign * u(0.01, 0.03) * stall_current;
            }
            "limit" => e.imax = u(0.35, 0.4) * stall_current,
            "delay" => e.td = u(0.5, 1.0) / rate,
            "cogging" | "cogging-untold" => {
                e.cog_amp = 0.05 * stall_torque;
                e.cog_cycles = 12.0;
                e.cog_phase = u(0.0, std::f64::consts::TAU);
            }
            // A placeholder rise per watt, scaled by `heating_to` to the records' loss.
            "coulomb" => e.tc = u(0.02, 0.04) * stall_torque,
            // Sized at the top speed: a few % of the stall torque there, a few % of Kv at
            // the stall current, a few % of the supply.
            "quadratic" => e.kq = u(0.03, 0.06) * stall_torque / (top * top),
            "reaction" => e.kar = u(0.05, 0.1) / stall_current,
            "brush" => e.vb = u(0.02, 0.04) * VOLTS,
            "ripple" => {
                e.ripple_amp = u(0.02, 0.05);
                e.ripple_cycles = u(8.0, 16.0).round();
                e.ripple_phase = u(0.0, std::f64::consts::TAU);
            }
            "heating" => {
                e.tau_th = u(10.0, 30.0);
                e.rth = 1.0;
            }
            other => panic!("unknown effect {other}"),
        }
    }
    e
}

/// One case's outcome.
pub struct Outcome {
    /// The effects named (`verdict.effects`).
    pub named: BTreeSet<String>,
    /// `verdict.unexplained`.
    pub unexplained: bool,
    /// Estimated over true speed noise of the held-out records.
    pub noise_ratio: f64,
    /// Wall time of the diagnosis [s].
    pub seconds: f64,
    /// The true effects of the case.
    pub truth: Effects,
    /// The report's `verdict`.
    pub verdict: Value,
}

/// Length of a record that heats the winding [s]: heating is slow, it shows over tens of
/// seconds.
pub const HEATING_S: f64 = 40.0;

/// The rise per watt that warms the winding of `m` with the effects `e` (its thermal time
/// constant among them) by `target` K by the end of a [`HEATING_S`] record of `shape`, run
/// at 2 kHz (the copper loss barely depends on the rate): the cold record's mean copper loss
/// gives a first guess, `target / (loss (1 - e^{-T/tau_th}))`, and one run with it corrects
/// for the loss that the hot resistance takes away (at a given voltage, a hotter winding
/// draws less current).
pub fn heating_to(m: Motor, e: Effects, shape: Shape, target: f64) -> f64 {
    let input = experiment(shape, VOLTS, 2000.0, HEATING_S);
    let cold = run(m, Effects { rth: 0.0, ..e }, Sensors::IDEAL, input.clone());
    let n = cold.current_true.len() as f64;
    let loss = cold.current_true.iter().map(|i| i * i * m.ra).sum::<f64>() / n;
    let guess = target / (loss * (1.0 - (-HEATING_S / e.tau_th).exp()));
    let hot = run(m, Effects { rth: guess, ..e }, Sensors::IDEAL, input);
    let reached = hot.heat_true.last().copied().unwrap_or(0.0);
    guess * target / reached
}

/// Simulate the records (train: ramp, steps, reversal; held out: reversal, ramp) and
/// diagnose them. With winding heating the reversals are [`HEATING_S`] reversing cycles
/// (four mechanical time scales each way in training, three and a half held out) whose loss
/// warms the winding by 40-50 K by the end of the training one (Ra 16-20 % up). The speed
/// is read by the [`LINES`]-line encoder.
pub fn check(dir: &Path, names: &[&str], rate: f64, seed: u64) -> Outcome {
    check_without(dir, names, rate, seed, &[], None)
}

/// [`check`] with the catalogue entries `without` left out of the diagnosis' search
/// (`--without`), and the speed read by a tacho of white noise `tacho` [rad/s] (`None`:
/// the encoder).
pub fn check_without(
    dir: &Path,
    names: &[&str],
    rate: f64,
    seed: u64,
    without: &[&str],
    tacho: Option<f64>,
) -> Outcome {
    simulate(dir, names, rate, seed, tacho).diagnose(names, without, dir)
}

/// A case's records, simulated by [`simulate`].
pub struct Simulated {
    /// The records: three to train on, two held out.
    paths: Vec<PathBuf>,
    /// The true effects.
    truth: Effects,
    /// The held-out speed reading's true noise [rad/s].
    noise: f64,
}

/// The records of case `names` at `rate` and `seed` in `dir`, the speed read by a tacho of
/// white noise `tacho` [rad/s] (`None`: the encoder): see [`check`].
pub fn simulate(dir: &Path, names: &[&str], rate: f64, seed: u64, tacho: Option<f64>) -> Simulated {
    let mut g = Gaussian::new(seed * 7919 + rate as u64);
    let m = motor(&mut g);
    let mut e = effects(names, &m, rate, &mut g);
    // Five of the slowest time constant per record (J Ra / (Ra B + Kv^2)), at least 1 s.
    let tau = m.j * m.ra / (m.ra * m.b + m.kv * m.kv);
    let duration = (5.0 * tau).max(1.0);
    let heating = names.contains(&"heating");
    let (reversal, reversal_held_out, long) = match heating {
        true => (
            Shape::Cycle { period: 8.0 * tau },
            Shape::Cycle { period: 7.0 * tau },
            HEATING_S,
        ),
        false => (Shape::Reversal, Shape::Reversal, duration),
    };
    if heating {
        let target = 40.0 + 10.0 * g.uniform();
        e.rth = heating_to(m, e, reversal, target);
    }
    let shapes = [
        ("ramp", Shape::Ramp, duration),
        ("steps", Shape::Steps, duration),
        ("reversal", reversal, long),
        ("reversal_held_out", reversal_held_out, long),
        ("ramp_held_out", Shape::Ramp, duration),
    ];
    let mut paths = Vec::new();
    let mut noise = Vec::new();
    for (k, (name, shape, length)) in shapes.into_iter().enumerate() {
        let sensors = Sensors {
            speed: speed_sensor(tacho),
            noise_omega: tacho.unwrap_or(0.0),
            noise_current: NOISE_CURRENT,
            seed: seed * 100 + k as u64,
        };
        let r = run(m, e, sensors, experiment(shape, VOLTS, rate, length));
        if k >= 3 {
            noise.push((r.speed_reading_error_rms(), r.omega.len() as f64));
        }
        let path = dir.join(format!("{name}.csv"));
        csv::write(&r, &path, true);
        paths.push(path);
    }
    // Pooled over the held-out samples, as the estimate is (records of unequal lengths).
    let (sum, count) = noise
        .iter()
        .fold((0.0, 0.0), |(s, c), (rms, n)| (s + n * rms * rms, c + n));
    // A tacho's reading error holds its ripple and delay, which are effects, not noise:
    // there the noise floor's truth is the tacho's white noise.
    let noise = tacho.unwrap_or((sum / count).sqrt());
    Simulated {
        paths,
        truth: e,
        noise,
    }
}

impl Simulated {
    /// The diagnosis of these records of case `names` with the catalogue entries `without`
    /// left out of its search (`--without`), its report written in `dir`.
    pub fn diagnose(&self, names: &[&str], without: &[&str], dir: &Path) -> Outcome {
        let start = Instant::now();
        // The cogging case is told the detents per revolution (12, as a datasheet gives them).
        let mut told: Vec<&str> = match names.contains(&"cogging") {
            true => vec!["--fix", "cog_cycles=12"],
            false => vec![],
        };
        let left_out = without.join(",");
        if !without.is_empty() {
            told.extend(["--without", &left_out]);
        }
        let paths = &self.paths;
        let (report, _) = diagnose(&paths[..3], &paths[3..], &told, &dir.join("diag.json"));
        let seconds = start.elapsed().as_secs_f64();
        let v: Value = report["verdict"].clone();
        if std::env::var_os("BLIND_VERBOSE").is_some() {
            eprintln!("truth {:?}\nverdict {v:#}", self.truth);
        }
        let named = named_effects(&v).into_iter().collect();
        Outcome {
            named,
            unexplained: v["unexplained"].as_bool().expect("verdict.unexplained"),
            noise_ratio: v["holdout_noise"].as_f64().expect("verdict.holdout_noise") / self.noise,
            seconds,
            truth: self.truth,
            verdict: v,
        }
    }
}

/// A case's name: `null`, or its effects joined by `+`.
pub fn label(case: &[&str]) -> String {
    if case.is_empty() {
        "null".into()
    } else {
        case.join("+")
    }
}
