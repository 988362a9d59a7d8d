//! Tests of the repeat runs and their floor ([`super`]).

use super::super::data::record;
use super::*;
use motor_id_shared::rng::{normal, seeded};

/// `n` runs of one response with independent white noise of `sigma`.
fn runs(n: usize, sigma: f64, seed: u64) -> Vec<Vec<f32>> {
    let mut rng = seeded(seed);
    (0..n)
        .map(|_| {
            (0..5000)
                .map(|t| (100.0 * (t as f64 * 0.01).sin() + sigma * normal(&mut rng) as f64) as f32)
                .collect()
        })
        .collect()
}

#[test]
fn white_noise_alone_gives_back_its_sigma() {
    for (n, seed) in [(2, 1), (3, 2), (5, 3)] {
        let r = runs(n, 0.7, seed);
        let views: Vec<&[f32]> = r.iter().map(|x| &x[..]).collect();
        let fl = floors(&views);
        let group = pooled(fl.iter().map(|&(_, f)| (f, 5000)));
        assert!((group / 0.7 - 1.0).abs() < 0.15, "{n} runs: {group}");
        for (d, f) in fl {
            assert!((f / 0.7 - 1.0).abs() < 0.15, "{n} runs: run floor {f}");
            // Against the mean of the others, uncorrected: sigma sqrt(n/(n-1)).
            let expected = 0.7 * (n as f64 / (n - 1) as f64).sqrt();
            assert!((d / expected - 1.0).abs() < 0.15, "{n} runs: {d}");
        }
    }
    // Two runs: their difference over sqrt(2).
    let r = runs(2, 0.7, 9);
    let diff = rms(r[0].iter().zip(&r[1]).map(|(a, b)| (a - b) as f64));
    let fl = floors(&[&r[0], &r[1]]);
    assert!((fl[0].1 - diff / 2f64.sqrt()).abs() < 1e-9);
}

#[test]
fn repeats_are_runs_whose_inputs_agree() {
    let v: Vec<f32> = (0..1000)
        .map(|k| if k > 100 { 12.0 } else { 0.0 })
        .collect();
    let w = vec![0.0f32; 1000];
    let a = record("a.csv", v.clone(), w.clone());
    // Three samples shorter and a little voltage noise: the same experiment.
    let b = record(
        "b.csv",
        v[..997].iter().map(|x| x + 0.01).collect(),
        w.clone(),
    );
    assert!(repeats(&a, &b));
    // Another voltage, another step time, another sample step, a load: not.
    let other = record("c.csv", v.iter().map(|x| x * 0.5).collect(), w.clone());
    assert!(!repeats(&a, &other));
    let mut later = v.clone();
    later.rotate_right(50);
    assert!(!repeats(&a, &record("d.csv", later, w.clone())));
    let mut slow = b.clone();
    slow.dt = 2e-3;
    assert!(!repeats(&a, &slow));
    let mut loaded = b.clone();
    loaded.load = Some(vec![0.1; 997]);
    assert!(!repeats(&a, &loaded));
    // Far too short.
    assert!(!repeats(
        &a,
        &record("e.csv", v[..900].to_vec(), w[..900].to_vec())
    ));
}

#[test]
fn the_summary_says_whether_the_remainder_is_the_runs_spread() {
    let mut r = Repeatability {
        groups: vec![],
        method: METHOD,
        holdout: Some(HoldoutFloor {
            records: vec!["c.csv".into()],
            floor_rad_s: Num(4.0),
            remainder_rad_s: Num(4.3),
            within_floor: true,
        }),
    };
    assert_eq!(r.holdout_floor(), Some(Num(4.0)));
    assert_eq!(
        r.summary(),
        [
            "the held-out remainder 4.300 rad/s is within the repeatability floor 4.000 rad/s \
          of c.csv: it is the motor not repeating itself, not an unexplained effect"
        ]
    );
    let h = r.holdout.as_mut().unwrap();
    (h.remainder_rad_s, h.within_floor) = (Num(5.0), false);
    assert!(r.summary()[0].contains(
        "above the repeatability floor 4.000 rad/s of c.csv: \
                                     3.000 rad/s"
    ));
}
