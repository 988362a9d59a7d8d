//! `motor-id diagnose` on records of the independent reference plant (its own integrator and
//! effect formulas, `tests/src/reference_plant/`): real drives' friction named from the
//! catalogue, the same friction with its entry left out owned up to as an unexplained
//! remainder where it lives, and an encoder's records without an effect left alone.

use motor_id_tests::blind;
use motor_id_tests::reference_plant::{
    csv, experiment, run, Effects, Motor, Sensors, Shape, SpeedSensor,
};
use serde_json::Value;
use std::path::Path;

/// The paper's motor at 10 V (stall torque 0.47 N m, top speed 43 rad/s), 200 Hz, 40 s per
/// record (five slowest time constants per step).
const VOLTS: f64 = 10.0;
const RATE: f64 = 200.0;
const DURATION: f64 = 40.0;

/// Records of the paper's motor with `effects`, read by `speed`: trained on a ramp (the shaft
/// breaks away part-way), voltage steps and a reversal, held out on another reversal and
/// ramp; then `diagnose` with `extra` arguments. Returns the JSON report.
fn diagnose(dir: &Path, effects: Effects, speed: SpeedSensor, extra: &[&str]) -> Value {
    diagnose_with_noise(dir, effects, speed, (0.2, 0.05), VOLTS, extra)
}

/// [`diagnose`] with white noise of `noise` (speed [rad/s], current [A]) on the readings,
/// the held-out records at `held_out_volts` (noise-free records of the same experiment
/// would be the same record, which `diagnose` refuses to hold out).
fn diagnose_with_noise(
    dir: &Path,
    effects: Effects,
    speed: SpeedSensor,
    (noise_omega, noise_current): (f64, f64),
    held_out_volts: f64,
    extra: &[&str],
) -> Value {
    let records = [
        ("ramp", Shape::Ramp, 1, VOLTS),
        ("steps", Shape::Steps, 2, VOLTS),
        ("reversal", Shape::Reversal, 3, VOLTS),
        ("reversal_held_out", Shape::Reversal, 4, held_out_volts),
        ("ramp_held_out", Shape::Ramp, 5, held_out_volts),
    ];
    let mut paths = Vec::new();
    for (name, shape, seed, volts) in records {
        let sensors = Sensors {
            speed,
            noise_omega,
            noise_current,
            seed,
        };
        let r = run(
            Motor::PAPER,
            effects,
            sensors,
            experiment(shape, volts, RATE, DURATION),
        );
        let path = dir.join(format!("{name}.csv"));
        csv::write(&r, &path, true);
        paths.push(path);
    }
    motor_id_tests::diagnose(&paths[..3], &paths[3..], extra, &dir.join("diag.json")).0
}

/// Break-away 0.08 N m falling to a Coulomb torque of 0.03 N m over 8 rad/s (6-17 % of the
/// stall torque at 10 V, and a fifth of the top speed).
fn sticky() -> Effects {
    Effects {
        tc: 0.03,
        ts: 0.05,
        ws: 8.0,
        ..Effects::default()
    }
}

/// `o` named exactly `names` (in catalogue-name order).
fn assert_named(o: &blind::Outcome, names: &[&str]) {
    let named: Vec<&str> = o.named.iter().map(String::as_str).collect();
    assert_eq!(named, names, "{}", o.verdict);
}

/// Case `names` of the blind harness at `rate` and `seed`, read by the quiet tacho that shows
/// a tacho's own effects ([`blind::QUIET_TACHO`]), diagnosed in `dir`.
fn on_a_quiet_tacho(dir: &Path, names: &[&str], rate: f64, seed: u64) -> blind::Outcome {
    blind::check_without(dir, names, rate, seed, &[], Some(blind::QUIET_TACHO))
}

#[test]
fn static_friction_is_named_and_without_its_entry_the_rest_is_unexplained_near_standstill() {
    let dir = tempfile::tempdir().unwrap();
    let full = diagnose(dir.path(), sticky(), SpeedSensor::Tacho, &[]);
    let v = &full["verdict"];
    let named = motor_id_tests::named_effects(v);
    assert!(named.iter().any(|n| n == "static_friction"), "{v}");
    assert_eq!(v["unexplained"], false, "{v}");

    let dir = tempfile::tempdir().unwrap();
    let without = diagnose(
        dir.path(),
        sticky(),
        SpeedSensor::Tacho,
        &["--without", "static_friction"],
    );
    let v = &without["verdict"];
    assert_eq!(v["unexplained"], true, "{v}");
    let remainder = &v["remainder"];
    let top = remainder["regimes"][0]["name"].as_str().unwrap();
    assert!(
        ["near standstill", "low speed (< 30 % of max)", "transients"].contains(&top),
        "the remainder lies in {top}: {remainder}"
    );
    // Never a catalogue name forced onto it.
    for line in remainder["summary"].as_array().unwrap() {
        assert!(!line.as_str().unwrap().contains("signature"), "{line}");
    }
}

#[test]
fn an_encoders_records_without_an_effect_are_left_alone() {
    let dir = tempfile::tempdir().unwrap();
    let encoder = SpeedSensor::Encoder { lines: 1024 };
    let r = diagnose(dir.path(), Effects::default(), encoder, &[]);
    let v = &r["verdict"];
    assert!(v["effect"].is_null(), "{v}");
    assert_eq!(v["unexplained"], false, "{v}");
}

#[test]
fn noise_free_records_without_an_effect_are_left_alone() {
    // A noise-free tacho and current: what is left after the baseline is the two
    // integrators' difference (the plant's RK4 on 32 substeps against the product's exact
    // step), numerics, not an effect; nothing is named and nothing called unexplained.
    let dir = tempfile::tempdir().unwrap();
    let r = diagnose_with_noise(
        dir.path(),
        Effects::default(),
        SpeedSensor::Tacho,
        (0.0, 0.0),
        0.8 * VOLTS,
        &[],
    );
    let v = &r["verdict"];
    assert!(v["effect"].is_null(), "{v}");
    assert_eq!(v["unexplained"], false, "{v}");
}

#[test]
fn a_current_sensor_offset_is_named_on_the_current_channel() {
    // 2 % of the stall current (50 V / 3.412 ohm at full voltage; 10 V here: 2.9 A, so 0.06
    // A): the speed does not show it, the current residual does.
    let dir = tempfile::tempdir().unwrap();
    let offset = Effects {
        io: 0.06,
        ..Effects::default()
    };
    let r = diagnose(dir.path(), offset, SpeedSensor::Tacho, &[]);
    let v = &r["verdict"];
    assert_eq!(v["effect"], "current_offset", "{v}");
    let io = v["effect_params"]["io"].as_f64().unwrap();
    assert!((io / 0.06 - 1.0).abs() < 0.1, "io = {io}");
    assert_eq!(v["current"]["unexplained"], false, "{v}");
    assert_eq!(v["unexplained"], false, "{v}");
}

#[test]
fn a_pair_of_effects_is_named_exactly_and_nothing_rides_on_it() {
    // Asymmetric friction and a current offset (blind-check case 1 at 2 kHz, speed from an
    // encoder): the forward search once added static friction on top of a step whose fit
    // had not converged (ts 5 % of tc; the asymmetry 35 % off); backward elimination refits
    // the final model without each effect and drops the one that does not earn its place.
    let dir = tempfile::tempdir().unwrap();
    let o = motor_id_tests::blind::check(dir.path(), &["asymmetric", "offset"], 2000.0, 1);
    let expected: std::collections::BTreeSet<String> = ["asymmetric_friction", "current_offset"]
        .map(String::from)
        .into();
    assert_eq!(o.named, expected);
}

/// Effect `effect` alone in the reference plant at `rate` (seed `seed`), the catalogue
/// entry `left_out` left out of the search: nothing is named, the verdict says unexplained,
/// and `stand_in` is a partial stand-in whose reason contains `why` ("" for any). The
/// report's `verdict`.
fn a_stand_in_only_when_left_out(
    effect: &str,
    rate: f64,
    seed: u64,
    left_out: &str,
    stand_in: &str,
    why: &str,
) -> Value {
    let dir = tempfile::tempdir().unwrap();
    let o =
        motor_id_tests::blind::check_without(dir.path(), &[effect], rate, seed, &[left_out], None);
    assert!(o.named.is_empty(), "{:?}", o.named);
    assert!(o.unexplained);
    let partial = motor_id_tests::partial_stand_ins(&o.verdict);
    assert!(
        partial
            .iter()
            .any(|(name, reason)| name == stand_in && reason.contains(why)),
        "{partial:?}"
    );
    o.verdict
}

#[test]
fn coulomb_friction_left_out_is_not_named_as_an_extension_of_it() {
    // Coulomb friction alone, its entry left out (`--without coulomb_friction`): static
    // friction, which extends it, fitted its Coulomb part with ts 0.8 of its deviation from
    // 0 and was named (blind check `without`, 5 kHz, seed 1). Now it is judged against the
    // left-out entry's own fit: no better, it is a partial stand-in, and the verdict says
    // unexplained.
    let verdict = a_stand_in_only_when_left_out(
        "coulomb",
        5000.0,
        1,
        "coulomb_friction",
        "static_friction",
        "",
    );
    // Before it says so, the final model (its fit above the noise: the friction is
    // missing) is widened: the escalation's wider search over the stand-ins' own
    // parameters, on the records decimated, finds no fit better by 1 %: the misfit is the
    // model's, not the search's.
    let w = &verdict["widened"];
    assert!(w["evaluations"].as_u64().unwrap() > 4000, "{w}");
    assert!(w["decimation"].as_u64().unwrap() > 1, "{w}");
    let (before, widened) = (
        w["searched_before"].as_f64(),
        w["searched_widened"].as_f64(),
    );
    assert!(widened.unwrap() > 0.99 * before.unwrap(), "{w}");
    assert_eq!(w["taken"], false, "{w}");
}

#[test]
fn a_look_alike_whose_form_the_records_do_not_pin_is_not_named() {
    // A brush drop, its entry left out: a bridge dead time with a band narrower than the
    // current resolves fits as well, and was named (blind check `without`, 5 kHz, seed 1:
    // vdt 0.53 V pinned, ib 0.03 A not). It is a partial stand-in now, and the verdict
    // says unexplained.
    a_stand_in_only_when_left_out(
        "brush",
        5000.0,
        1,
        "brush_drop",
        "bridge_deadtime",
        "do not pin its ib",
    );
}

#[test]
fn a_look_alike_that_misfits_where_its_form_shows_is_not_named() {
    // A bridge dead time, its entry left out: a brush drop takes the speed to its noise and
    // most of the current's misfit, and was named (blind check `without`, every rate and
    // seed). Its form is not the dead time's: near standstill, where a brush drop holds the
    // current at zero and a bridge's band lets it flow, the held-out current's misfit stays
    // 2-5 times its noise (3.4 here). With the whole catalogue the same records name the
    // dead time (the rule does not take a true effect's name).
    a_stand_in_only_when_left_out(
        "deadtime",
        2000.0,
        2,
        "bridge_deadtime",
        "brush_drop",
        "near standstill",
    );
    let whole = tempfile::tempdir().unwrap();
    let o = motor_id_tests::blind::check(whole.path(), &["deadtime"], 2000.0, 2);
    let expected: std::collections::BTreeSet<String> = ["bridge_deadtime".to_string()].into();
    assert_eq!(o.named, expected);
}

#[test]
fn a_dead_time_fitted_without_a_band_gives_way_to_the_brush_drop_it_tends_to() {
    // A brush drop alone, beside armature reaction, Coulomb friction and a current offset
    // (blind checks): a bridge dead time was added with its band `ib` at the floor of its
    // search bounds (0.1 % of the largest current; a dead time with no band is a brush
    // drop), its band unpinned or a brush drop in its place predicting as well, so it was a
    // partial stand-in and the brush drop was never named. The search now takes the dead
    // time's limit in its place, at the step (the first three) or on the final model (the
    // offset's case, where the band reached its floor in the final refit): what the plant
    // holds is named, and the drop near the plant's.
    for (effects, rate, seed, expected) in [
        (&["brush"][..], 2000.0, 1, &["brush_drop"][..]),
        (
            &["reaction", "brush"],
            2000.0,
            2,
            &["armature_reaction", "brush_drop"],
        ),
        (
            &["coulomb", "brush"],
            5000.0,
            2,
            &["brush_drop", "coulomb_friction"],
        ),
        (
            &["brush", "offset"],
            5000.0,
            2,
            &["brush_drop", "current_offset"],
        ),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let o = motor_id_tests::blind::check(dir.path(), effects, rate, seed);
        let expected: std::collections::BTreeSet<String> =
            expected.iter().map(|e| e.to_string()).collect();
        assert_eq!(o.named, expected, "{effects:?}: {}", o.verdict);
        let vb = o.verdict["params"]["vb"].as_f64().expect("vb");
        eprintln!("{effects:?}: vb {vb} vs {}", o.truth.vb);
        assert!(
            (vb / o.truth.vb - 1.0).abs() < 0.03,
            "{effects:?}: vb {vb} vs {}",
            o.truth.vb
        );
    }
}

#[test]
fn a_brush_drop_left_out_is_not_named_for_the_dead_time_at_its_limit() {
    // The brush drop alone, its entry left out (`--without brush_drop`, 2 kHz, seed 1): the
    // dead time fitted for it puts its band at the floor, the brush drop's form, but the
    // entry the user left out is not put in its place; the dead time is a partial stand-in.
    a_stand_in_only_when_left_out("brush", 2000.0, 1, "brush_drop", "bridge_deadtime", "");
}

#[test]
fn a_coulomb_friction_beside_a_fan_load_is_not_taken_for_static_friction() {
    // Coulomb friction and a fan load of 3-6 % of the stall torque at the top speed (blind
    // check, 2 kHz, seeds 1 and 2): static friction whose break-away excess faded over the
    // speeds, with a larger viscous B, bent the friction's curve like the fan load and was
    // named alone; the fan load, tried on top of it, added nothing. The search now weighs
    // an extension chosen first against each entry beside the friction it extends, and
    // goes on from the Coulomb friction where one predicts as well: static friction is
    // never named. Seed 2 names both. On seed 1 static friction in the fan load's place,
    // refitted with its Coulomb torque free, predicts the held-out records within 1.2 %
    // (0.6503 against 0.6424 rad/s, under the encoder's noise): the records do not tell
    // the two forms apart, so the fan load is a labelled partial stand-in, not a cause.
    let names = |n: &[&str]| -> std::collections::BTreeSet<String> {
        n.iter().map(|x| x.to_string()).collect()
    };
    for (seed, named) in [
        (1, vec!["coulomb_friction"]),
        (2, vec!["coulomb_friction", "quadratic_load"]),
    ] {
        let dir = tempfile::tempdir().unwrap();
        let o = motor_id_tests::blind::check(dir.path(), &["coulomb", "quadratic"], 2000.0, seed);
        let v = &o.verdict;
        assert_eq!(o.named, names(&named), "seed {seed}: {v}");
        assert_eq!(o.unexplained, named.len() == 1, "seed {seed}: {v}");
        if named.len() == 1 {
            let stand_ins = motor_id_tests::partial_stand_ins(v);
            assert!(
                stand_ins.iter().any(|(name, why)| name == "quadratic_load"
                    && why.contains("with static_friction in its place")),
                "seed {seed}: {v}"
            );
        }
    }
}

#[test]
fn asymmetric_friction_and_a_bridge_dead_time_are_named_with_their_sizes() {
    // Blind-check case 1 of the pair at 2 kHz (encoder speed): both named, nothing more, and
    // their parameters near the reference plant's (its own formulas: Coulomb torque tc +- ta,
    // a dead-time error vdt clamp(i / ib, -1, 1)), within what the product's holding of an
    // effect over a sample and the plant's substeps allow.
    let dir = tempfile::tempdir().unwrap();
    let o = motor_id_tests::blind::check(dir.path(), &["asymmetric", "deadtime"], 2000.0, 1);
    let expected: std::collections::BTreeSet<String> = ["asymmetric_friction", "bridge_deadtime"]
        .map(String::from)
        .into();
    assert_eq!(o.named, expected, "{}", o.verdict);
    let p = &o.verdict["params"];
    let got = |k: &str| p[k].as_f64().unwrap_or_else(|| panic!("{k} in {p}"));
    let e = o.truth;
    for (name, value, truth, tolerance) in [
        ("tc", got("tc"), e.tc, 0.03),
        ("ka", got("ka"), e.ta / e.tc, 0.03),
        ("vdt", got("vdt"), e.vdt, 0.03),
    ] {
        eprintln!("{name}: {value} vs {truth}");
        assert!(
            (value / truth - 1.0).abs() < tolerance,
            "{name}: {value} vs {truth}"
        );
    }
}

#[test]
fn a_drive_current_limit_is_named_and_its_limit_measured() {
    // The independent plant's drive holds |i| at 35-40 % of the stall current by lowering
    // the applied voltage while the log keeps the commanded one (blind-check case `limit`,
    // seeds 1 and 2 at 5 kHz). Before `current_limit` joined the catalogue, the verdict
    // named nothing and listed `current_offset` and `armature_reaction` as partial stand-ins
    // with the misfit mostly kept; now the entry explains it: named alone, the held-out
    // misfit down to the noise, the limit within 3 % of the plant's.
    for seed in [1, 2] {
        let dir = tempfile::tempdir().unwrap();
        let o = motor_id_tests::blind::check(dir.path(), &["limit"], 5000.0, seed);
        let v = &o.verdict;
        let named: Vec<&str> = o.named.iter().map(String::as_str).collect();
        assert_eq!(named, ["current_limit"], "seed {seed}: {v}");
        assert_eq!(v["unexplained"], false, "seed {seed}: {v}");
        let after = v["holdout_rmse_after"].as_f64().unwrap();
        let noise = v["holdout_noise"].as_f64().unwrap();
        assert!(after < 1.2 * noise, "seed {seed}: {after} vs noise {noise}");
        let imax = v["params"]["imax"].as_f64().unwrap();
        let truth = o.truth.imax;
        assert!(
            (imax / truth - 1.0).abs() < 0.03,
            "seed {seed}: imax {imax} vs {truth}"
        );
    }
}

#[test]
fn a_tacho_ripple_does_not_inflate_the_noise_floor() {
    // 2.7 % ripple at 8 per revolution: at the top speed 55 Hz, 0.27 cycles per sample,
    // where the noise estimate cannot tell a ripple from noise. The floor is the white noise
    // (0.2 rad/s), which the held-out records' ripple, subtracted at the order the
    // residual shows, no longer hides.
    let dir = tempfile::tempdir().unwrap();
    let ripple = Effects {
        ripple_amp: 0.027,
        ripple_cycles: 8.0,
        ripple_phase: 0.3,
        ..Effects::default()
    };
    let r = diagnose(dir.path(), ripple, SpeedSensor::Tacho, &[]);
    let noise = r["verdict"]["holdout_noise"].as_f64().unwrap();
    eprintln!("held-out noise {noise} against 0.2");
    assert!(
        (noise / 0.2 - 1.0).abs() <= 0.1,
        "{noise}: {}",
        r["verdict"]
    );
}

#[test]
fn cogging_is_named_when_told_its_detents_per_revolution() {
    // A detent torque of 0.03 N m (6 % of the stall torque at 10 V) at 12 per revolution:
    // its speed ripple (0.03 / (J 12 w), 0.06 rad/s at 1 rad/s) lies under the tacho's
    // noise of 0.2 rad/s, and static friction, which mimics the detents' hold at a start,
    // fits nearly as well. Told the detents per revolution (a motor's datasheet has them),
    // the diagnosis names cogging and measures it; not told, it does not try it (the order
    // cannot be read from this residual: its largest share is a trend's, at order 1).
    let dir = tempfile::tempdir().unwrap();
    let cogging = Effects {
        cog_amp: 0.03,
        cog_cycles: 12.0,
        cog_phase: 0.7,
        ..Effects::default()
    };
    let r = diagnose(
        dir.path(),
        cogging,
        SpeedSensor::Tacho,
        &["--fix", "cog_cycles=12"],
    );
    let v = &r["verdict"];
    assert_eq!(v["effect"], "cogging", "{v}");
    assert_eq!(v["unexplained"], false, "{v}");
    let amp = v["effect_params"]["cog_amp"].as_f64().unwrap();
    assert!((amp / 0.03 - 1.0).abs() < 0.1, "{v}");
    let untold = diagnose(dir.path(), cogging, SpeedSensor::Tacho, &[]);
    let tried: Vec<&str> = untold["effects"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|e| e["name"].as_str())
        .collect();
    assert!(!tried.contains(&"cogging"), "{tried:?}");
}

/// A fast motor (La/Ra 20 ms, mechanical time scale 0.27 s) on two 40 s reversing cycles
/// at 24 V and 2 kHz, read by a tacho (0.2 rad/s of noise) and a current sensor (0.05 A):
/// trained on one reversing every second, held out on one reversing every 0.9 s. With
/// `heat` (rise per watt [K/W], thermal time constant [s]) the winding warms along each.
/// `extra`: more options of `diagnose`. Returns the report and the plant's runs.
fn diagnose_cycles(
    dir: &Path,
    heat: (f64, f64),
    extra: &[&str],
) -> (Value, Vec<motor_id_tests::reference_plant::Run>) {
    let motor = Motor {
        ra: 1.0,
        la: 0.02,
        j: 0.002,
        b: 0.001,
        kv: 0.08,
    };
    let effects = Effects {
        rth: heat.0,
        tau_th: heat.1,
        ..Effects::default()
    };
    let mut paths = Vec::new();
    let mut runs = Vec::new();
    for (name, period, seed) in [("cycle", 2.0, 1), ("cycle_held_out", 1.8, 2)] {
        let sensors = Sensors {
            speed: SpeedSensor::Tacho,
            noise_omega: 0.2,
            noise_current: 0.05,
            seed,
        };
        let input = experiment(Shape::Cycle { period }, 24.0, 2000.0, 40.0);
        let r = run(motor, effects, sensors, input);
        let path = dir.join(format!("{name}.csv"));
        csv::write(&r, &path, true);
        paths.push(path);
        runs.push(r);
    }
    let report =
        motor_id_tests::diagnose(&paths[..1], &paths[1..], extra, &dir.join("diag.json")).0;
    (report, runs)
}

#[test]
fn winding_heating_is_named_on_long_cycling_records_and_not_without_it() {
    // The plant's own heating (its resistance Ra (1 + 0.00393 dT) inside its RK4, its
    // temperature a fourth state driven by i^2 Ra(T)): 0.18 K/W with a thermal time
    // constant of 20 s warms the winding by 44 K over the training record and 49 K over the
    // held-out one, Ra up 17-19 %. The
    // diagnosis names `winding_heating` alone, measures the rise per watt within 2 % and
    // the time constant within 5 %, and leaves the held-out misfit at the noise.
    let dir = tempfile::tempdir().unwrap();
    let (rth, tau) = (0.18, 20.0);
    let (r, runs) = diagnose_cycles(dir.path(), (rth, tau), &[]);
    for run in &runs {
        let warmed = run.heat_true.last().copied().unwrap();
        assert!((40.0..50.0).contains(&warmed), "{warmed} K");
    }
    let v = &r["verdict"];
    assert_eq!(motor_id_tests::named_effects(v), ["winding_heating"], "{v}");
    assert_eq!(v["unexplained"], false, "{v}");
    let after = v["holdout_rmse_after"].as_f64().unwrap();
    let noise = v["holdout_noise"].as_f64().unwrap();
    assert!(after < 1.1 * noise, "{after} vs noise {noise}");
    let got = |k: &str| {
        v["params"][k]
            .as_f64()
            .unwrap_or_else(|| panic!("{k} in {v}"))
    };
    eprintln!(
        "rth {} (truth {rth}), tau_th {} (truth {tau})",
        got("rth"),
        got("tau_th")
    );
    assert!((got("rth") / rth - 1.0).abs() < 0.02, "{v}");
    assert!((got("tau_th") / tau - 1.0).abs() < 0.05, "{v}");
    assert!((got("ra") - 1.0).abs() < 0.02, "{v}");

    // The same records without heating: nothing is named (the heating's two parameters
    // do not stand in for noise on records this long).
    let dir = tempfile::tempdir().unwrap();
    let (r, _) = diagnose_cycles(dir.path(), (0.0, 0.0), &[]);
    let v = &r["verdict"];
    assert!(motor_id_tests::named_effects(v).is_empty(), "{v}");
    assert_eq!(v["unexplained"], false, "{v}");
}

#[test]
fn heating_left_out_of_the_catalogue_is_reported_as_a_drift_of_ra_and_named_nothing() {
    // The records of the test above, `winding_heating` withheld (`--without`): no catalogue
    // name stands in for it, the remainder is unexplained, and it says that Ra rises along
    // the records (windows of 10 s centred 5 s and 35 s into a cycle warming by 44-49 K:
    // 0.393 %/K of the temperature between them, some 10-15 %).
    let dir = tempfile::tempdir().unwrap();
    let (r, _) = diagnose_cycles(dir.path(), (0.18, 20.0), &["--without", "winding_heating"]);
    let v = &r["verdict"];
    assert!(motor_id_tests::named_effects(v).is_empty(), "{v}");
    assert_eq!(v["unexplained"], true, "{v}");
    let drift = v["remainder"]["drift"].as_array().expect("drift");
    let ra: Vec<&Value> = drift.iter().filter(|d| d["param"] == "ra").collect();
    assert!(!ra.is_empty(), "{drift:?}");
    for d in &ra {
        let change = d["change"].as_f64().unwrap();
        assert!((0.08..0.2).contains(&change), "{d}");
    }
    // The largest drift is Ra's, and the sentence says so.
    assert_eq!(drift[0]["param"], "ra", "{drift:?}");
    let said = v["remainder"]["summary"].to_string();
    eprintln!("{said}");
    assert!(
        said.contains("a parameter drifts along a record: ra +"),
        "{said}"
    );
}

#[test]
fn a_quiet_tachos_delay_of_half_a_sample_is_named_at_5_and_10_khz() {
    // A tacho of 0.05 rad/s white noise delayed by half a sample to one: the delay takes the
    // speed's held-out misfit from about 1.008 times the noise to the noise, a fall under
    // the 2 % the rule asks of others, and completes the model on the speed, the one
    // channel it acts on (three of the blind harness' cases, none of them named before).
    for (rate, seed) in [(5000.0, 1), (10000.0, 1), (10000.0, 2)] {
        let dir = tempfile::tempdir().unwrap();
        let o = on_a_quiet_tacho(dir.path(), &["delay"], rate, seed);
        let v = &o.verdict;
        assert_eq!(
            o.named.iter().collect::<Vec<_>>(),
            ["sensor_delay"],
            "{rate} Hz, seed {seed}: {v}"
        );
        assert!(!o.unexplained, "{v}");
        let td = v["effect_params"]["td"].as_f64().unwrap();
        assert!(
            (td / o.truth.td - 1.0).abs() < 0.1,
            "td {td} against {}",
            o.truth.td
        );
    }
}

#[test]
fn a_look_alike_weighed_inside_the_rest_of_the_model_is_refitted_with_it() {
    // Static friction beside a quiet tacho's ripple (the blind harness' case): Coulomb
    // friction passed the rule beside the ripple at the first step, so that it is weighed in
    // the ripple's place on the final model, where static friction holds its one parameter.
    // The model without the ripple must free the fitted Coulomb torque, not hold it as if the
    // user had fixed it: held, Coulomb friction had nothing to fit and `diagnose` stopped
    // ("every parameter is fixed: nothing to identify").
    let dir = tempfile::tempdir().unwrap();
    let o = on_a_quiet_tacho(dir.path(), &["static", "ripple"], 5000.0, 1);
    assert_named(&o, &["static_friction", "tacho_ripple"]);
}

#[test]
fn a_ripple_beside_a_current_limit_takes_its_order_from_the_limited_model_s_residual() {
    // A quiet tacho's ripple (14 per revolution) beside a drive's current limit (the blind
    // harness' case): the baseline's residual is the limit's misfit (24 rad/s), whose order
    // spectrum peaks at 17, and a ripple held there fits nothing. Its order is taken again
    // from the residual of the model with the limit.
    let dir = tempfile::tempdir().unwrap();
    let o = on_a_quiet_tacho(dir.path(), &["ripple", "limit"], 5000.0, 1);
    let v = &o.verdict;
    assert_named(&o, &["current_limit", "tacho_ripple"]);
    assert_eq!(
        v["params"]["ripple_cycles"].as_f64(),
        Some(o.truth.ripple_cycles),
        "{v}"
    );
}

#[test]
fn a_fan_load_beside_a_ripple_is_named_and_the_ripple_s_fit_reaches_the_noise() {
    // A quiet tacho's ripple beside a fan load (the blind harness' case, 5 kHz): the ripple's
    // angle, integrated from the measured speed, took the tacho's noise as a random walk;
    // the ripple's fit left 1.5 times the noise on the held-out speed, the fan load was a
    // partial stand-in and the verdict unexplained. Tracked on the readings, the angle
    // follows the rotor: both named, and the remainder within the noise.
    let dir = tempfile::tempdir().unwrap();
    let o = on_a_quiet_tacho(dir.path(), &["quadratic", "ripple"], 5000.0, 1);
    assert_named(&o, &["quadratic_load", "tacho_ripple"]);
    assert!(!o.unexplained, "{}", o.verdict);
}

#[test]
fn a_fix_at_zero_switches_an_effect_off() {
    // `--fix tc=0`: the user says the Coulomb torque is zero. The entry is not tried, and
    // no model holds a Coulomb torque (judged by value, a fix at the default was taken for
    // no fix, and Coulomb friction was fitted and named on the sticky plant).
    let dir = tempfile::tempdir().unwrap();
    let r = diagnose(dir.path(), sticky(), SpeedSensor::Tacho, &["--fix", "tc=0"]);
    let tried: Vec<&str> = r["effects"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|e| e["name"].as_str())
        .collect();
    assert!(!tried.contains(&"coulomb_friction"), "{tried:?}");
    assert!(tried.contains(&"static_friction"), "{tried:?}");
    let v = &r["verdict"];
    let named = motor_id_tests::named_effects(v);
    assert!(!named.iter().any(|n| n == "coulomb_friction"), "{v}");
    assert!(v["params"]["tc"].as_f64().is_none_or(|tc| tc == 0.0), "{v}");
}

#[test]
fn an_extension_s_refit_stalled_above_its_parent_is_fitted_again_from_it() {
    // Asymmetric friction and a current offset (the blind harness' case, 5 kHz): static
    // friction's first fit, started from no Coulomb torque, stopped at a training objective
    // 10 % above that of Coulomb friction, which it extends and holds, and was ranked on
    // that: a held-out speed misfit of 25 rad/s against Coulomb friction's 4.1. Fitted
    // again from Coulomb friction's fit, it predicts the held-out records as well as it.
    let dir = tempfile::tempdir().unwrap();
    let o = blind::check(dir.path(), &["asymmetric", "offset"], 5000.0, 1);
    assert_named(&o, &["asymmetric_friction", "current_offset"]);
    let text = std::fs::read_to_string(dir.path().join("diag.json")).unwrap();
    let report: Value = serde_json::from_str(&text).unwrap();
    let effect = |name: &str| {
        let all = report["effects"].as_array().unwrap();
        all.iter().find(|e| e["name"] == name).unwrap().clone()
    };
    let (stribeck, coulomb) = (effect("static_friction"), effect("coulomb_friction"));
    let joint = |e: &Value| e["holdout_joint"].as_f64().unwrap();
    assert!(
        joint(&stribeck) < 1.1 * joint(&coulomb),
        "{stribeck}\n{coulomb}"
    );
    assert_eq!(
        stribeck["restarted"]["from"], "coulomb_friction",
        "{stribeck}"
    );
    assert!(coulomb["restarted"].is_null(), "{coulomb}");
}
