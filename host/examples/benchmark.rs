//! Benchmark of the identification pipelines (not a test): random motors drawn log-uniformly
//! from the seed's Table 1 box, a `steps` experiment of 2,000 samples with 1 % noise, and for
//! each pipeline the success rate (fit RMSE within 1 % of the noise floor) and the median
//! evaluations to get there, plus host time per identification.
//!
//! The noise floor of a record is the RMSE of the true parameters on it (the realised noise;
//! a 2,000-sample realisation differs from the nominal sigma by about 1.6 %, so the nominal
//! sigma would be a coin toss, not a criterion).
//!
//! `cargo run --release -p motor-id --example benchmark -- [MOTORS] [--skip-paper]`

use motor_id_shared::fit::ffo::{FfoConfig, Soil};
use motor_id_shared::fit::identify::{identify, IdentifyConfig};
use motor_id_shared::fit::objective::Objective;
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::model::params::ModelParams;
use motor_id_shared::model::profile::{settling_duration, Experiment, Profile};
use motor_id_shared::model::synth::{synthesize, Buffers, Noise};
use motor_id_shared::param_id::ParamId;
use motor_id_shared::rng;
use motor_id_shared::Record;
use std::ops::ControlFlow;
use std::time::Instant;

const SAMPLES: usize = 2000;

struct Case {
    truth: ModelParams,
    dt: f32,
    v: Vec<f32>,
    omega: Vec<f32>,
    current: Vec<f32>,
}

fn random_motor(seed: u64) -> ModelParams {
    let mut r = rng::seeded(seed);
    let mut p = ModelParams::SEED_MOTOR;
    for id in ParamId::MOTOR {
        let (lo, hi) = id.default_bounds();
        p.set(id, lo * (hi / lo).powf(rng::unit(&mut r)));
    }
    p
}

fn make_case(seed: u64) -> Case {
    let truth = random_motor(seed);
    let duration = settling_duration(&truth, Profile::Steps);
    let dt = duration / SAMPLES as f32;
    let exp = Experiment {
        profile: Profile::Steps,
        voltage: 50.0,
        duration,
        load_torque: 0.0,
    };
    let (mut v, mut tl, mut omega, mut current) = (
        vec![0.0; SAMPLES],
        vec![0.0; SAMPLES],
        vec![0.0; SAMPLES],
        vec![0.0; SAMPLES],
    );
    // Noise-free first, to scale the noise to 1 % of the peak signals.
    let b = Buffers {
        v: &mut v,
        tl: &mut tl,
        omega: &mut omega,
        current: &mut current,
    };
    synthesize(&truth, &exp, dt, Noise::default(), 0, None, b).unwrap();
    let peak = |x: &[f32]| x.iter().fold(0.0f32, |m, y| m.max(y.abs()));
    let noise = Noise {
        omega: 0.01 * peak(&omega),
        current: 0.01 * peak(&current),
    };
    let b = Buffers {
        v: &mut v,
        tl: &mut tl,
        omega: &mut omega,
        current: &mut current,
    };
    synthesize(&truth, &exp, dt, noise, seed ^ 0x5eed, None, b).unwrap();
    Case {
        truth,
        dt,
        v,
        omega,
        current,
    }
}

struct Outcome {
    success: bool,
    evals_to_floor: Option<u32>,
    evaluations: u32,
    seconds: f64,
    param_error: f32,
    /// Motor parameters reported as pinned, and how many of them lie within 3 reported
    /// standard deviations of the truth.
    pinned: usize,
    pinned_within_3_std: usize,
}

fn run(case: &Case, cfg: &IdentifyConfig, with_current: bool) -> Outcome {
    let rec = [Record {
        dt: case.dt,
        v: &case.v,
        omega: &case.omega,
        current: with_current.then_some(&case.current[..]),
        load: None,
        coast_from: None,
    }];
    let objective = Objective::new(&rec).unwrap();
    let floor = objective.cost(&case.truth).unwrap();
    let start = Instant::now();
    let id = identify(&rec, &ProblemSpec::default(), cfg, |_| {
        ControlFlow::Continue(())
    })
    .unwrap();
    let seconds = start.elapsed().as_secs_f64();
    let target = 1.01 * floor.fitness();
    let evals_to_floor = id
        .trace
        .iter()
        .find(|t| t.best <= target)
        .map(|t| t.evaluations);
    let param_error = ParamId::MOTOR
        .iter()
        .map(|&p| (id.params.get(p) / case.truth.get(p) - 1.0).abs())
        .fold(0.0, f32::max);
    let pinned: Vec<_> = id
        .identifiability
        .params
        .iter()
        .filter_map(|c| c.std.map(|sd| (c, sd)))
        .collect();
    let pinned_within_3_std = pinned
        .iter()
        .filter(|(c, sd)| (c.value - case.truth.get(c.id)).abs() <= 3.0 * sd)
        .count();
    Outcome {
        pinned: pinned.len(),
        pinned_within_3_std,
        success: id.cost.rmse_omega <= 1.01 * floor.rmse_omega,
        evals_to_floor,
        evaluations: id.evaluations,
        seconds,
        param_error,
    }
}

fn median(mut x: Vec<f64>) -> f64 {
    if x.is_empty() {
        return f64::NAN;
    }
    x.sort_by(f64::total_cmp);
    let n = x.len();
    if n % 2 == 1 {
        x[n / 2]
    } else {
        0.5 * (x[n / 2 - 1] + x[n / 2])
    }
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let motors: u64 = args.iter().find_map(|a| a.parse().ok()).unwrap_or(50);
    let skip_paper = args.iter().any(|a| a == "--skip-paper");
    let cases: Vec<Case> = (1..=motors).map(make_case).collect();
    println!("{motors} motors log-uniform in seed Table 1, steps profile, {SAMPLES} samples, 1 % noise\n");
    println!("| pipeline | data | success (RMSE <= 1.01 floor) | median evaluations to floor | median evaluations total | all params within 1 % | all 5 pinned | pinned params within 3 reported std | median host time |");
    println!("|---|---|---|---|---|---|---|---|---|");
    let mut pipelines = vec![
        (
            "default: start + FFO 2x8, 8 it. + LM",
            IdentifyConfig::default_pipeline(1),
        ),
        (
            "board: start + LM, FFO only above noise",
            IdentifyConfig::board(1),
        ),
    ];
    if !skip_paper {
        pipelines.push((
            "paper-faithful FFO (soil away from best)",
            IdentifyConfig::paper_faithful(1),
        ));
        let towards = IdentifyConfig {
            ffo: FfoConfig {
                soil: Soil::TowardsBest,
                ..FfoConfig::SEED
            },
            ..IdentifyConfig::paper_faithful(1)
        };
        pipelines.push(("seed settings, soil towards best", towards));
    }
    for (name, cfg) in pipelines {
        for with_current in [true, false] {
            let outcomes: Vec<Outcome> = std::thread::scope(|s| {
                let handles: Vec<_> = cases
                    .chunks(cases.len().div_ceil(2))
                    .map(|chunk| {
                        s.spawn(move || {
                            chunk
                                .iter()
                                .map(|c| run(c, &cfg, with_current))
                                .collect::<Vec<_>>()
                        })
                    })
                    .collect();
                handles
                    .into_iter()
                    .flat_map(|h| h.join().unwrap())
                    .collect()
            });
            let n = outcomes.len() as f64;
            let ok = outcomes.iter().filter(|o| o.success).count() as f64;
            let accurate = outcomes.iter().filter(|o| o.param_error < 0.01).count() as f64;
            let all_pinned = outcomes.iter().filter(|o| o.pinned == 5).count() as f64;
            let pinned: usize = outcomes.iter().map(|o| o.pinned).sum();
            let covered: usize = outcomes.iter().map(|o| o.pinned_within_3_std).sum();
            let to_floor = median(
                outcomes
                    .iter()
                    .filter_map(|o| o.evals_to_floor.map(f64::from))
                    .collect(),
            );
            let total = median(outcomes.iter().map(|o| o.evaluations as f64).collect());
            let secs = median(outcomes.iter().map(|o| o.seconds).collect());
            let reached = outcomes
                .iter()
                .filter(|o| o.evals_to_floor.is_some())
                .count();
            println!(
                "| {name} | {} | {:.1} % ({}/{}) | {} ({reached} reached) | {total:.0} | {} | {:.1} % | {:.1} % of {pinned} | {:.1} ms |",
                if with_current { "speed + current" } else { "speed only" },
                100.0 * ok / n,
                ok as usize,
                n as usize,
                if to_floor.is_nan() { "-".to_string() } else { format!("{to_floor:.0}") },
                if with_current { format!("{:.1} %", 100.0 * accurate / n) } else { "n/a (not identifiable)".into() },
                100.0 * all_pinned / n,
                100.0 * covered as f64 / pinned.max(1) as f64,
                secs * 1e3,
            );
            for (i, o) in outcomes.iter().enumerate() {
                if !o.success && std::env::var_os("BENCH_VERBOSE").is_some() {
                    eprintln!("  failed motor {}: {:?}", i + 1, cases[i].truth);
                }
            }
        }
    }
}
