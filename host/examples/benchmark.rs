//! Benchmark of the identification pipelines (not a test): random motors drawn log-uniformly
//! from the paper's Table 1 box, a `steps` experiment of 2,000 samples with 1 % noise, and for
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
use motor_id_shared::model::synth::TableOneCase;
use motor_id_shared::param_id::ParamId;
use std::ops::ControlFlow;
use std::time::Instant;

const SAMPLES: usize = 2000;

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
    /// Wider searches run after the pipeline's own (its escalation).
    widened: u32,
}

fn run(case: &TableOneCase, cfg: &IdentifyConfig, with_current: bool) -> Outcome {
    let rec = [case.record(with_current)];
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
    if std::env::var_os("BENCH_VERBOSE").is_some() {
        for (c, sd) in &pinned {
            let off = (c.value - case.truth.get(c.id)) / sd;
            if off.abs() > 3.0 {
                eprintln!(
                    "  {:?} {} vs truth {} ({off:+.1} std of {sd}), current {with_current}, rank {}",
                    c.id,
                    c.value,
                    case.truth.get(c.id),
                    id.identifiability.rank
                );
            }
        }
    }
    Outcome {
        pinned: pinned.len(),
        pinned_within_3_std,
        success: id.cost.rmse_omega <= 1.01 * floor.rmse_omega,
        evals_to_floor,
        evaluations: id.evaluations,
        seconds,
        param_error,
        widened: id.widened,
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
    let motors: u64 = args
        .iter()
        .find_map(|a| a.parse().ok())
        .unwrap_or(50)
        .max(1);
    let skip_paper = args.iter().any(|a| a == "--skip-paper");
    let cases: Vec<TableOneCase> = (1..=motors)
        .map(|seed| TableOneCase::new(seed, SAMPLES))
        .collect();
    println!("{motors} motors log-uniform in paper's Table 1, steps profile, {SAMPLES} samples, 1 % noise\n");
    println!("| pipeline | data | success (RMSE <= 1.01 floor) | median evaluations to floor | median evaluations total | all params within 1 % | all 5 pinned | pinned params within 3 reported std | motors whose search was widened | median host time |");
    println!("|---|---|---|---|---|---|---|---|---|---|");
    let mut pipelines = vec![
        (
            "default: start + LM; FFO 2x8, 8 it. + LM above noise; then wider (seed population)",
            IdentifyConfig::default_pipeline(1),
        ),
        (
            "board: start + LM; FFO 2x8, 8 it. + LM above noise; then 5x and 25x longer",
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
                ..FfoConfig::PAPER
            },
            ..IdentifyConfig::paper_faithful(1)
        };
        pipelines.push(("paper's settings, soil towards best", towards));
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
            let widened = outcomes.iter().filter(|o| o.widened > 0).count();
            let reached = outcomes
                .iter()
                .filter(|o| o.evals_to_floor.is_some())
                .count();
            println!(
                "| {name} | {} | {:.1} % ({}/{}) | {} ({reached} reached) | {total:.0} | {} | {:.1} % | {:.1} % of {pinned} | {widened} | {:.1} ms |",
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
