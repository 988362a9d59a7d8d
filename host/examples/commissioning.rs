//! Benchmark of self-commissioning (not a test): motors drawn log-uniformly from the paper's
//! Table 1 box, each commissioned on the virtual board (the board's own commissioning code
//! against the simulated plant) with the default limits, 12-bit quantisation of tacho and
//! current on the limits' scales, sensor noise and Coulomb friction of 5 % of the torque the
//! drive allows.
//!
//! `cargo run --release -p motor-id --example commissioning -- [MOTORS] [--rate HZ]
//! [--adc-bits N (12; 0: no quantisation)] [--coulomb SHARE (0.05)] [--noise-omega RAD_S
//! (0.1)] [--noise-current A (0.005)] [--instant (each record
//! sample the drive's reading at its instant, not the mean of its readings over the step,
//! the board's default)] [--verbose] [--only M (motor M of the run alone)]`

use motor_id_shared::device::job::JobEnd;
use motor_id_shared::device::plant::SimulatedPlant;
use motor_id_shared::device::unpinned::{why_not_pinned, Unpinned};
use motor_id_shared::device::virtual_board::{commission, BoardRecord};
use motor_id_shared::fit::objective::Objective;
use motor_id_shared::model::record::Record;
use motor_id_shared::model::synth::table_one_motor;
use motor_id_shared::param_id::ParamId;
use motor_id_shared::wire::limits::Limits;
use motor_id_shared::wire::protocol::{BoardMessage, JobStage, Refusal};
use motor_id_shared::ModelParams;
use std::collections::BTreeMap;

/// The identifiability analysis's simulations where no profile check follows: a
/// central-difference Jacobian of the six parameters and the point itself.
const ANALYSIS_SIMULATIONS: u32 = 2 * 6 + 1;

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let motors: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(200);
    let rate: f32 = option(&args, "--rate").unwrap_or(20_000.0);
    let adc_bits: u32 = option(&args, "--adc-bits").unwrap_or(12);
    let coulomb: f32 = option(&args, "--coulomb").unwrap_or(0.05);
    // The sensors' white noise per drive reading [rad/s], [A].
    let noise_omega: f32 = option(&args, "--noise-omega").unwrap_or(0.1);
    let noise_current: f32 = option(&args, "--noise-current").unwrap_or(0.005);
    let verbose = args.iter().any(|a| a == "--verbose");
    let averaged = !args.iter().any(|a| a == "--instant");
    // One motor of the run alone (its number, as the verbose lines give it).
    let only: Option<usize> = option(&args, "--only");
    let limits = Limits::DEFAULT;
    let mut refusals: BTreeMap<String, usize> = BTreeMap::new();
    let (mut trips, mut like, mut like_ok, mut all_ok) = (0, 0, 0, 0);
    let (mut pinned, mut within) = (0, 0);
    let mut outside: BTreeMap<&str, usize> = BTreeMap::new();
    let mut unpinned: BTreeMap<String, usize> = BTreeMap::new();
    // |relative error| and |error| / sigma of the pinned parameters, by parameter.
    let mut errors: BTreeMap<&str, (Vec<f32>, Vec<f32>)> = BTreeMap::new();
    // The fit's speed RMSE of the motors whose pinned parameters all lie within 3 sigma, and
    // of those with one beyond 10 sigma (is a far-off estimate a misfit, or a good fit?).
    let (mut rmse_within, mut rmse_far) = (Vec::new(), Vec::new());
    // How much worse the truth fits the board's records than the estimate, in units of the
    // fit's residual variance (a chi-square difference: under 9 when the truth lies within
    // the 3-sigma region the fit's curvature claims).
    let (mut chi_within, mut chi_far) = (Vec::new(), Vec::new());
    let mut seconds = Vec::new();
    let mut evaluations = Vec::new();
    let mut simulations = Vec::new();
    for m in 0..motors {
        if only.is_some_and(|o| o != m + 1) {
            continue;
        }
        let motor = table_one_motor(m as u64 + 1);
        let [ra, la, j, b, kv] = ParamId::MOTOR.map(|p| motor.get(p));
        let tc = coulomb * kv * limits.current;
        let truth = motor.with(ParamId::Tc, tc);
        let tau_m = j * ra / (kv * kv + ra * b);
        let looks_like_motor = kv * kv >= 3.0 * ra * b && la / ra < tau_m;
        let mut plant =
            SimulatedPlant::new(&truth, 1.0 / rate, noise_omega, noise_current, m as u64 + 1)
                .expect("plant");
        if adc_bits > 0 {
            (plant.resolution.omega, plant.resolution.current) = limits.adc_counts(adc_bits);
        }
        let current_count = plant.resolution.current;
        // The profile check's progress counts every simulation of the fit so far (search,
        // refinement, the analysis's Jacobian, the check); the report counts the first two.
        let mut checked = None;
        let c = commission(plant, limits, averaged, 1, None, &mut |m| {
            if let BoardMessage::Progress {
                stage: JobStage::Check,
                evaluations,
                ..
            } = m
            {
                checked = Some(*evaluations);
            }
        });
        seconds.push(c.seconds);
        like += looks_like_motor as usize;
        let report = match c.result {
            Ok(r) => r,
            Err(JobEnd::Refused(Refusal::Trip)) => {
                trips += 1;
                if verbose {
                    eprintln!("motor {}: TRIP {truth:?} plan {:?}", m + 1, c.plan);
                }
                continue;
            }
            Err(e) => {
                *refusals.entry(format!("{e:?}")).or_default() += 1;
                if verbose {
                    eprintln!(
                        "motor {}: refused {e:?}: ra {ra} la {la} j {j} b {b} kv {kv} tau_m {tau_m} plan {:?}",
                        m + 1,
                        c.plan
                    );
                }
                continue;
            }
        };
        evaluations.push(report.evaluations);
        simulations.push(checked.unwrap_or(report.evaluations + ANALYSIS_SIMULATIONS));
        let mut ok = true;
        let mut worst_z = 0.0f32;
        for &id in ParamId::ALL[..=ParamId::Tc.index()].iter() {
            let e = report.get(id.index() as u8).expect("six estimates");
            let t = truth.get(id);
            let rel = (e.value / t - 1.0).abs();
            ok &= e.pinned() && rel <= 0.03;
            if let (false, Some(plan)) = (e.pinned(), &c.plan) {
                let why = why_not_pinned(id, &report, plan, current_count);
                let kind = format!("{why:?}");
                let mut kind = kind.split([' ', '{']).next().unwrap_or("").to_string();
                if let Unpinned::BackEmfBelowResolution {
                    whole_scale: false, ..
                } = why
                {
                    kind.push_str(" (part of the scale)");
                }
                if verbose && why == Unpinned::NotSeparated {
                    eprintln!(
                        "motor {}: {} not separated: ra {ra} la {la} j {j} b {b} kv {kv} tc {tc} tau_m {tau_m}\n  plan {:?}\n  {:?}",
                        m + 1,
                        id.name(),
                        c.plan,
                        report.estimates
                    );
                }
                *unpinned.entry(format!("{} {kind}", id.name())).or_default() += 1;
            }
            if e.pinned() {
                let (rel_errors, z) = errors.entry(id.name()).or_default();
                rel_errors.push(rel);
                z.push((e.value - t).abs() / e.std);
                worst_z = worst_z.max((e.value - t).abs() / e.std);
                pinned += 1;
                let inside = (e.value - t).abs() <= 3.0 * e.std;
                within += inside as usize;
                if !inside {
                    *outside.entry(id.name()).or_insert(0usize) += 1;
                }
            }
        }
        let estimate = ParamId::ALL[..=ParamId::Tc.index()]
            .iter()
            .fold(truth, |p, &id| {
                p.with(id, report.get(id.index() as u8).map_or(0.0, |e| e.value))
            });
        let chi = chi_square_gap(&c.records, &truth, &estimate);
        if worst_z <= 3.0 {
            rmse_within.push(report.rmse_omega);
            chi_within.push(chi);
        } else if worst_z > 10.0 {
            rmse_far.push(report.rmse_omega);
            chi_far.push(chi);
        }
        all_ok += ok as usize;
        like_ok += (ok && looks_like_motor) as usize;
        if verbose && worst_z > 3.0 {
            let z: Vec<String> = ParamId::ALL[..=ParamId::Tc.index()]
                .iter()
                .filter_map(|&id| {
                    let e = report.get(id.index() as u8)?;
                    let t = truth.get(id);
                    e.pinned().then(|| {
                        let (z, rel) = ((e.value - t) / e.std, 100.0 * (e.value / t - 1.0));
                        format!("{} {z:+.2}σ ({rel:+.3} %)", id.name())
                    })
                })
                .collect();
            eprintln!(
                "motor {}: beyond 3 sigma: ra {ra} la {la} j {j} b {b} kv {kv} tau_m {tau_m} (back-EMF {:.1} counts by the probe): {}",
                m + 1,
                c.plan.as_ref().map_or(f32::NAN, |p| p.back_emf_current / current_count),
                z.join(", ")
            );
        }
        if verbose && !ok && looks_like_motor {
            eprintln!(
                "motor {}: not all six: ra {ra} la {la} j {j} b {b} kv {kv} tc {tc} tau_m {tau_m}\n  plan {:?}\n  {:?}",
                m + 1,
                c.plan, report.estimates
            );
        }
    }
    seconds.sort_by(f32::total_cmp);
    evaluations.sort();
    simulations.sort();
    let quantile = |v: &[u32], q: f64| v[((v.len() - 1) as f64 * q) as usize];
    let at = |q: f64| quantile(&evaluations, q);
    let pct = |a: usize, b: usize| 100.0 * a as f64 / b.max(1) as f64;
    println!(
        "motors {motors} (look like motors {like}), drive sampled at {rate} Hz, limits {limits:?}"
    );
    match averaged {
        true => println!("each record sample the mean of the drive's readings over its step"),
        false => println!("each record sample the drive's reading at its instant"),
    }
    println!("trips {trips}; refusals {refusals:?}");
    println!(
        "all six pinned and within 3 %: whole box {:.1} %, motor-like {:.1} %",
        pct(all_ok, motors),
        pct(like_ok, like)
    );
    println!(
        "pinned within 3 reported std: {:.1} % of {pinned}; outside, by parameter: {outside:?}",
        pct(within, pinned)
    );
    println!("not pinned, by parameter and reason: {unpinned:?}");
    for (name, (rel_errors, z)) in errors.iter_mut() {
        rel_errors.sort_by(f32::total_cmp);
        z.sort_by(f32::total_cmp);
        let q = |v: &[f32], f: f64| v[((v.len() - 1) as f64 * f) as usize];
        println!(
            "{name}: |relative error| median {:.3} %, 90 % {:.3} %, 99 % {:.3} %; |error|/sigma median {:.2}, 90 % {:.2}, 99 % {:.2}",
            100.0 * q(rel_errors, 0.5),
            100.0 * q(rel_errors, 0.9),
            100.0 * q(rel_errors, 0.99),
            q(z, 0.5),
            q(z, 0.9),
            q(z, 0.99)
        );
    }
    for (what, v) in [
        ("all within 3 sigma", &mut chi_within),
        ("one beyond 10 sigma", &mut chi_far),
    ] {
        v.sort_by(f64::total_cmp);
        if !v.is_empty() {
            println!(
                "chi-square gap, truth against estimate, of the fits with {what}: median {:.1}, 90 % {:.1}, most {:.1}",
                v[v.len() / 2],
                v[v.len() * 9 / 10],
                v[v.len() - 1]
            );
        }
    }
    for (what, v) in [
        ("all within 3 sigma", &mut rmse_within),
        ("one beyond 10 sigma", &mut rmse_far),
    ] {
        v.sort_by(f32::total_cmp);
        if let (Some(first), Some(last)) = (v.first(), v.last()) {
            println!(
                "speed RMSE of the fits with {what} ({} motors): least {first:.3}, median {:.3}, most {last:.3} rad/s",
                v.len(),
                v[v.len() / 2]
            );
        }
    }
    println!(
        "fit evaluations: median {}, 90 % {}, most {}",
        at(0.5),
        at(0.9),
        at(1.0)
    );
    println!(
        "simulations of the whole fit (with the analysis and the profile check): median {}, 75 % {}, 90 % {}, most {}",
        quantile(&simulations, 0.5),
        quantile(&simulations, 0.75),
        quantile(&simulations, 0.9),
        quantile(&simulations, 1.0)
    );
    println!(
        "experiment: median {:.1} s, longest {:.1} s",
        seconds[seconds.len() / 2],
        seconds.last().unwrap()
    );
}

/// The value after `name` on the command line, if it is there and parses.
fn option<T: std::str::FromStr>(args: &[String], name: &str) -> Option<T> {
    let k = args.iter().position(|a| a == name)?;
    args.get(k + 1)?.parse().ok()
}

/// `(SSE(truth) - SSE(estimate)) / (SSE(estimate) / n)` on the board's records: how many
/// residual variances worse the truth fits them than the estimate (NaN when either cannot
/// be evaluated).
fn chi_square_gap(records: &[BoardRecord], truth: &ModelParams, estimate: &ModelParams) -> f64 {
    let recs: Vec<Record> = records.iter().map(BoardRecord::as_record).collect();
    let Ok(objective) = Objective::new(&recs) else {
        return f64::NAN;
    };
    match (objective.cost(truth), objective.cost(estimate)) {
        (Some(t), Some(e)) => (t.sse - e.sse) / (e.sse / e.residuals as f64),
        _ => f64::NAN,
    }
}
