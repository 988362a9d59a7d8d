//! The commissioning fit's instructions on the MCU across the seed's box (not a test; issue
//! 21's target of 170 M, 1 s at 168 MHz). Motors are drawn as the commissioning benchmark
//! draws them (`table_one_motor`, Coulomb friction of 5 % of the torque the drive allows),
//! the motor-like ones kept (Kv² ≥ 3 Ra B, La/Ra under the mechanical time constant). Each is
//! the QEMU build's plant (its 2 kHz drive and its sensors' noise, not the benchmark's 20 kHz
//! and 12-bit ADC), commissioned by the board at power-up under `-icount shift=0`, its fit
//! metered by the board (`fit_ticks`, docs/measurements/footprint.md) and its stored report
//! read (`board params`).
//!
//! `cargo run --release -p motor-id-tests --example mcu_commissioning -- [MOTORS (12)]
//! [--only M (motor M alone; its report on stderr)] [--records DIR (the
//! board's records of each motor commissioned, downloaded into DIR/M/ as `board record`
//! writes them: for `identify --pipeline board`, `validate`)]` (some 15 s a motor on 2
//! cores).

use motor_id_shared::model::synth::table_one_motor;
use motor_id_shared::param_id::ParamId;
use motor_id_tests::footprint::{power_up_footprint, TICKS_PER_INSTRUCTION};
use motor_id_tests::{json as json_file, param, run, s, Qemu};

fn main() {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let wanted: usize = args.first().and_then(|a| a.parse().ok()).unwrap_or(12);
    // The value after option `name`, if given.
    let option = |name: &str| {
        let k = args.iter().position(|a| a == name)?;
        args.get(k + 1).map(String::as_str)
    };
    // One motor alone (its number in the table).
    let only: Option<u64> = option("--only").and_then(|m| m.parse().ok());
    let records = option("--records").map(std::path::PathBuf::from);
    let dir = tempfile::tempdir().expect("temporary directory");
    let json = dir.path().join("board.json");
    println!("| motor | tau_m [s] | La/Ra [ms] | outcome | largest error of the six, of a pinned one in its σ; all pinned | evaluations | fit [M instructions] |");
    println!("|---|---|---|---|---|---|---|");
    let mut fits = Vec::new();
    let mut within = 0;
    let (mut seed, mut tried) = (0u64, 0usize);
    while tried < wanted {
        seed += 1;
        if only.is_some_and(|o| seed > o) {
            // Past the motor asked for, whatever MOTORS says.
            break;
        }
        let m = table_one_motor(seed);
        let [ra, la, j, b, kv] = ParamId::MOTOR.map(|p| m.get(p));
        let tau_m = j * ra / (kv * kv + ra * b);
        if kv * kv < 3.0 * ra * b || la / ra >= tau_m || only.is_some_and(|o| o != seed) {
            continue;
        }
        tried += 1;
        let plant = [
            ("ra", ra),
            ("la", la),
            ("j", j),
            ("b", b),
            ("kv", kv),
            ("tc", 0.05 * kv * 40.0),
        ];
        let q = Qemu::with_plant_and(&plant, &["-icount", "shift=0"]);
        // The board commissions its plant at power-up, metered while the host is silent
        // (a second commissioning on request would meet a slow shaft still coasting from
        // the first); its report is the one stored.
        let power_up = power_up_footprint(&q);
        let port = ["board", "--port", &q.pty, "--timeout", "600", "-q"];
        let ask = match power_up {
            Some(_) => "params",
            // Asked again for the refusal's reason (the power-up's is in the log).
            None => "commission",
        };
        let out = run(&[&port[..], &["--json", s(&json), ask]].concat());
        let (outcome, accuracy, evaluations, fit) = match (out.status.success(), power_up) {
            (true, Some(field)) => {
                let r = json_file(&json);
                if only.is_some() {
                    eprintln!("truth {plant:?}\n{r:#}");
                }
                if let Some(root) = &records {
                    let to = root.join(seed.to_string());
                    std::fs::create_dir_all(&to).expect("the records' directory");
                    let got = run(&[&port[..], &["record", "--out-dir", s(&to)]].concat());
                    assert!(got.status.success(), "board record: {got:?}");
                }
                let fit = field("fit_ticks") / TICKS_PER_INSTRUCTION / 1e6;
                fits.push(fit);
                let worst = plant
                    .iter()
                    .map(|(name, truth)| (param(&r, name) / *truth as f64 - 1.0).abs())
                    .fold(0.0, f64::max);
                let estimate = |name: &str| &r["identifiability"]["parameters"][name];
                let pinned = plant
                    .iter()
                    .all(|(name, _)| estimate(name)["pinned"] == true);
                // The largest error of a pinned estimate in its reported deviations.
                let sigmas = plant
                    .iter()
                    .filter(|(name, _)| estimate(name)["pinned"] == true)
                    .filter_map(|(name, truth)| {
                        let std = estimate(name)["std"].as_f64()?;
                        Some((param(&r, name) - *truth as f64).abs() / std)
                    })
                    .fold(0.0, f64::max);
                within += usize::from(pinned && worst < 0.03);
                let accuracy = format!("{:.2} %, {sigmas:.1} σ; {pinned}", 100.0 * worst);
                let evaluations = r["evaluations"].to_string();
                (
                    "commissioned".into(),
                    accuracy,
                    evaluations,
                    format!("{fit:.1}"),
                )
            }
            (_, power_up) => {
                let err = String::from_utf8_lossy(&out.stderr);
                let why = err.lines().last().unwrap_or("").trim();
                let why = match power_up {
                    Some(_) => format!("commissioned, but its parameters not read: {why}"),
                    None if out.status.success() => {
                        "refused at power-up; commissioned when asked again".into()
                    }
                    None => format!("refused at power-up; asked again: {why}"),
                };
                (why, "-".into(), "-".into(), "-".into())
            }
        };
        println!(
            "| {seed} | {tau_m:.3} | {:.2} | {outcome} | {accuracy} | {evaluations} | {fit} |",
            1e3 * la / ra
        );
    }
    fits.sort_by(f64::total_cmp);
    let at = |q: f64| fits[((fits.len() - 1) as f64 * q).round() as usize];
    if !fits.is_empty() {
        let over = fits.iter().filter(|&&f| f > 170.0).count();
        println!(
            "commissioned {} of {tried}, all six pinned and within 3 %: {within}; fit median {:.1} M, 90th percentile {:.1} M, most {:.1} M; over 170 M: {over}",
            fits.len(),
            at(0.5),
            at(0.9),
            at(1.0)
        );
    }
}
