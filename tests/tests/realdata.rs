//! The real lab motor (`../shared/realdata/fibo-lab-motor`, speed only, 2 kHz): Ra and La
//! measured by the lab are fixed, the bounds widened (J, B, Kv far below paper's Table 1).

use motor_id_tests::{json, param, realdata, run_ok, s};
use std::path::PathBuf;

/// Ra and La as measured by the lab, held fixed.
const FIX: [&str; 2] = ["--fix", "ra=3.4,la=0.00285"];
/// J, B and Kv are far below the paper's Table 1.
const BOUNDS: [&str; 2] = ["--bounds", "j=1e-7:1e-3,b=1e-8:1e-2,kv=1e-3:1"];

#[test]
fn lab_motor_kv_and_inertia_agree_with_the_lab_and_the_misfit_is_flagged() {
    let Some(dir) = realdata() else { return };
    let out = tempfile::tempdir().unwrap();
    let report = out.path().join("lab.json");
    run_ok(&[
        "identify",
        s(&dir.join("step_1.csv")),
        s(&dir.join("ramp_1.csv")),
        FIX[0],
        FIX[1],
        BOUNDS[0],
        BOUNDS[1],
        "--json",
        s(&report),
        "-q",
    ]);
    let r = json(&report);
    // The lab's own fit (with a 0.95 efficiency fudge): Kv ~ 0.048 V s/rad, J ~ 9.9e-6.
    let kv = param(&r, "kv");
    assert!((0.043..0.055).contains(&kv), "kv {kv}");
    let j = param(&r, "j");
    assert!((5e-6..2e-5).contains(&j), "j {j}");
    assert_eq!(param(&r, "ra"), 3.4);
    // Speeds reach 250 rad/s; the linear model gets within a few rad/s ...
    let rmse = r["rmse_omega"].as_f64().unwrap();
    assert!(rmse < 10.0, "rmse {rmse}");
    // ... but not to the encoder noise: stiction and the direction asymmetry are not in the
    // model, and the report must say so rather than print confident numbers only.
    assert_eq!(
        r["fit_quality"]["model_adequate"], false,
        "{}",
        r["fit_quality"]
    );
}

#[test]
fn lab_motor_diagnosis_finds_coulomb_friction_on_held_out_runs() {
    let Some(dir) = realdata() else { return };
    let out = tempfile::tempdir().unwrap();
    let report = out.path().join("diag.json");
    run_ok(&[
        "diagnose",
        "--train",
        s(&dir.join("step_1.csv")),
        s(&dir.join("ramp_1.csv")),
        "--holdout",
        s(&dir.join("step_2.csv")),
        s(&dir.join("sine_1.csv")),
        FIX[0],
        FIX[1],
        BOUNDS[0],
        BOUNDS[1],
        "--json",
        s(&report),
        "-q",
    ]);
    let r = json(&report);
    let v = &r["verdict"];
    // The lab saw the motor start only at 0.7-1.8 V: static/Coulomb friction.
    assert_eq!(v["effect"], "coulomb_friction", "{v}");
    let (before, after) = (
        v["holdout_rmse_before"].as_f64().unwrap(),
        v["holdout_rmse_after"].as_f64().unwrap(),
    );
    assert!(after < 0.8 * before, "held-out {before} -> {after}");
    // Friction torque below the stall torque at the breakaway voltage (Kv 1.8 V / Ra).
    let tc = v["effect_params"]["tc"].as_f64().unwrap();
    assert!(tc > 0.0 && tc < 0.05 * 1.8 / 3.4, "tc {tc}");
    assert_eq!(r["data"]["current"], false);
}

/// `diagnose` on the lab records `train` and `holdout` (file names) with `extra` arguments;
/// returns the JSON report and the text summary (`None`: the data is not there, see
/// [`realdata`]).
fn lab_diagnose(
    train: &[&str],
    holdout: &[&str],
    extra: &[&str],
) -> Option<(serde_json::Value, String)> {
    let dir = realdata()?;
    let out = tempfile::tempdir().unwrap();
    let path = |f: &&str| dir.join(f);
    let (train, holdout): (Vec<PathBuf>, Vec<PathBuf>) = (
        train.iter().map(path).collect(),
        holdout.iter().map(path).collect(),
    );
    let mut options: Vec<&str> = FIX.iter().chain(&BOUNDS).copied().collect();
    options.extend(extra);
    Some(motor_id_tests::diagnose(
        &train,
        &holdout,
        &options,
        &out.path().join("diag.json"),
    ))
}

/// The coverage gaps' regime names.
fn gaps(r: &serde_json::Value) -> Vec<&str> {
    let list = r["coverage_gaps"].as_array().expect("coverage_gaps");
    list.iter().map(|g| g["regime"].as_str().unwrap()).collect()
}

#[test]
fn lab_motor_reversals_held_out_from_forward_training_are_a_coverage_gap_and_repeats_set_a_floor() {
    let Some(dir) = realdata() else { return };
    let group = |e: &str| {
        (1..=3)
            .map(|k| dir.join(format!("{e}_{k}.csv")).display().to_string())
            .collect::<Vec<_>>()
            .join(",")
    };
    let (chirps, sines) = (group("chirp"), group("sine"));
    let Some((r, text)) = lab_diagnose(
        &["step_2.csv", "stair_2.csv"],
        &["chirp_3.csv", "sine_3.csv"],
        &["--repeats", &chirps, "--repeats", &sines],
    ) else {
        return;
    };
    // 0..12 V without reversal in training; the chirp and the sine reverse at ±12 V.
    let found = gaps(&r);
    assert!(found.contains(&"reversal"), "{found:?}");
    assert!(found.contains(&"negative_voltage"), "{found:?}");
    for g in r["coverage_gaps"].as_array().unwrap() {
        if ["reversal", "negative_voltage"].contains(&g["regime"].as_str().unwrap()) {
            assert_eq!(g["records"].as_array().unwrap().len(), 2, "{g}");
            assert!(g["holdout_share"].as_f64().unwrap() > 0.1, "{g}");
        }
    }
    assert!(text.contains("coverage: reversal ("), "{text}");
    // Two given groups of three runs; runs 1 and 2 predict run 3 to 4.4-4.8 rad/s RMS.
    let groups = r["repeatability"]["groups"].as_array().unwrap();
    assert_eq!(groups.len(), 2, "{groups:?}");
    let (mut sse, mut n) = (0.0, 0.0);
    for (g, len) in groups.iter().zip([40001.0, 20001.0]) {
        assert_eq!(g["found"], "given");
        let run3 = &g["runs"][2];
        assert_eq!(run3["set"], "holdout");
        sse += run3["vs_others_rms_rad_s"].as_f64().unwrap().powi(2) * len;
        n += len;
    }
    let by_mean_of_others = (sse / n).sqrt();
    assert!(
        (4.4..4.8).contains(&by_mean_of_others),
        "{by_mean_of_others}"
    );
    let floor = r["verdict"]["repeatability_floor"].as_f64().unwrap();
    assert!((floor / (by_mean_of_others * (2.0f64 / 3.0).sqrt()) - 1.0).abs() < 1e-3);
    // Friction helps, but what remains is above the floor: not only the motor's spread.
    let h = &r["repeatability"]["holdout"];
    assert_eq!(h["remainder_rad_s"], r["verdict"]["holdout_rmse_after"]);
    assert_eq!(h["within_floor"], false, "{h}");
    assert!(text.contains("is above the repeatability floor"), "{text}");
}

#[test]
fn lab_motor_training_with_a_sine_covers_reversals_and_detects_its_repeat() {
    let Some((r, _)) = lab_diagnose(
        &["step_2.csv", "stair_2.csv", "sine_2.csv"],
        &["chirp_3.csv", "sine_3.csv"],
        &[],
    ) else {
        return;
    };
    let found = gaps(&r);
    assert!(!found.contains(&"reversal"), "{found:?}");
    assert!(!found.contains(&"negative_voltage"), "{found:?}");
    // sine_2 (training) and sine_3 (held out) share their input: detected as repeats.
    let groups = r["repeatability"]["groups"].as_array().unwrap();
    assert_eq!(groups.len(), 1, "{groups:?}");
    let g = &groups[0];
    assert_eq!(g["found"], "detected");
    let names: Vec<&str> = g["records"]
        .as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_str().unwrap())
        .collect();
    assert!(
        names[0].ends_with("sine_2.csv") && names[1].ends_with("sine_3.csv"),
        "{names:?}"
    );
    let floor = r["verdict"]["repeatability_floor"].as_f64().unwrap();
    assert!((2.0..6.0).contains(&floor), "{floor}");
}
