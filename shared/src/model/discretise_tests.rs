//! Tests of the exact discretisation (`model::discretise`).

use super::*;

#[test]
fn the_scalar_taylor_series_is_the_matrix_series_to_its_last_digits() {
    // Motors of the Table 1 box at steps from a drive's share of a record step to where
    // the series hands over (|lambda| t up to 0.5): the scalar sums of Cayley-Hamilton
    // give the matrix series' entries to a few f64 units in the last place, and the same
    // f32 coefficients, so no simulation moves.
    let (mut cases, mut worst) = (0, 0.0f64);
    for seed in 1..=400u64 {
        let a = Motor::of(&crate::model::synth::table_one_motor(seed)).a;
        let mu = 0.5 * (a[0][0] + a[1][1]);
        let half_diff = 0.5 * (a[0][0] - a[1][1]);
        let disc = half_diff * half_diff + a[0][1] * a[1][0];
        let radius = mu.abs() + libm::sqrt(disc.abs());
        for reach in [1e-4, 1e-3, 0.01, 0.05, 0.1, 0.2, 0.3, 0.45, 0.499] {
            let t = reach / radius;
            let (g, f) = taylor(&a, t);
            let (g_full, f_full) = taylor_sums(&a, t);
            for r in 0..2 {
                for c in 0..2 {
                    for (x, y) in [(g[r][c], g_full[r][c]), (f[r][c], f_full[r][c])] {
                        assert!(y != 0.0, "{seed} {t}: a zero entry");
                        worst = worst.max(((x - y) / y).abs());
                        assert_eq!(x as f32, y as f32, "{seed} {t} ({r}, {c})");
                    }
                }
            }
            cases += 1;
        }
    }
    assert_eq!(cases, 3600);
    assert!(worst < 1e-14, "relative difference {worst:e}");
}

/// Reference: classical RK4 in f64 with many substeps, from x0 under inputs (v, tl).
fn reference_step(p: &ModelParams, dt: f64, x0: [f64; 2], v: f64, tl: f64) -> [f64; 2] {
    let ra = p.get(ParamId::Ra) as f64;
    let la = p.get(ParamId::La) as f64;
    let j = p.get(ParamId::J) as f64;
    let b = p.get(ParamId::B) as f64;
    let kv = p.get(ParamId::Kv) as f64;
    let deriv = |x: [f64; 2]| {
        [
            (v - ra * x[0] - kv * x[1]) / la,
            (kv * x[0] - b * x[1] - tl) / j,
        ]
    };
    let fastest = ra / la + b / j + kv / (la * j).sqrt();
    let n = ((dt * fastest * 50.0).ceil() as usize).clamp(200, 2_000_000);
    let h = dt / n as f64;
    let mut x = x0;
    for _ in 0..n {
        let k1 = deriv(x);
        let k2 = deriv([x[0] + 0.5 * h * k1[0], x[1] + 0.5 * h * k1[1]]);
        let k3 = deriv([x[0] + 0.5 * h * k2[0], x[1] + 0.5 * h * k2[1]]);
        let k4 = deriv([x[0] + h * k3[0], x[1] + h * k3[1]]);
        for s in 0..2 {
            x[s] += h / 6.0 * (k1[s] + 2.0 * k2[s] + 2.0 * k3[s] + k4[s]);
        }
    }
    x
}

fn check(p: ModelParams, dt: f32) {
    check_step(&p, &Discrete::new(&p, dt).unwrap(), dt, 2e-5);
}

/// `d`, coefficients of `p` over `t` seconds, takes a state to where the fine RK4 does,
/// within `tolerance` of its scale.
fn check_step(p: &ModelParams, d: &Discrete, t: f32, tolerance: f64) {
    let x0 = [1.5f64, 40.0];
    let (v, tl) = (24.0, 0.3);
    let r = reference_step(p, t as f64, x0, v, tl);
    for s in 0..2 {
        let got = x0[s]
            + d.d[s][0] as f64 * x0[0]
            + d.d[s][1] as f64 * x0[1]
            + d.gv[s] as f64 * v
            + d.gt[s] as f64 * tl;
        let scale = r[s].abs().max(x0[s].abs()).max(1e-3);
        assert!(
            (got - r[s]).abs() <= tolerance * scale,
            "state {s}: zoh {got} vs reference {} over {t} s for {p:?}",
            r[s]
        );
    }
}

#[test]
fn matches_fine_rk4_in_every_branch() {
    // Paper's motor (complex poles at 1 kHz): trigonometric branch.
    check(ModelParams::PAPER_MOTOR, 1e-3);
    // The corner of the Table 1 box where Euler/RK4 diverge (`docs/ARCHITECTURE.md`): complex poles near -25 +- 632j.
    check(ModelParams::motor(0.5, 0.01, 0.001, 0.0005, 2.0), 1e-3);
    // Small step: Taylor branch.
    check(ModelParams::PAPER_MOTOR, 2e-5);
    // Stiff, well separated real poles at 100 Hz: divided differences.
    check(ModelParams::motor(10.0, 0.01, 1.0, 0.0005, 0.01), 1e-2);
    // Fast small motor (La/Ra = 0.5 ms) at 10 kHz.
    check(ModelParams::motor(2.0, 0.001, 2e-5, 1e-5, 0.02), 1e-4);
}

#[test]
fn a_share_of_a_step_matches_the_fine_reference() {
    // The motor recovered from a step's own coefficients, over part of that step: the
    // paper's motor at 1 kHz, a slow shaft at 50 kHz (am about -1e-6), a shaft without
    // viscous friction (am = 0), and a step as long as La/Ra.
    let cases = [
        (ModelParams::PAPER_MOTOR, 1e-3),
        (ModelParams::PAPER_MOTOR, 2e-5),
        (ModelParams::motor(1.0, 0.02, 0.5, 0.0, 0.08), 1e-3),
        (
            ModelParams::motor(8.45, 0.0247, 0.0831, 0.00607, 1.83),
            2.55e-3,
        ),
    ];
    for (p, dt) in cases {
        let kv = p.get(ParamId::Kv);
        let whole = Discrete::new(&p, dt).unwrap();
        for share in [0.01f32, 0.37, 0.9] {
            let part = whole.over_share(dt, kv, share).unwrap();
            check_step(&p, &part, share * dt, 1e-4);
        }
    }
}

#[test]
fn slow_mode_kept_exact_at_high_rate() {
    // Mechanical pole around -0.24 /s at 50 kHz: D[1][1] is about -5e-6.
    let d = Discrete::new(&ModelParams::PAPER_MOTOR, 2e-5).unwrap();
    // Steady-state speed from the discrete map must equal the analytic Kv V / (Ra B + Kv^2).
    let p = ModelParams::PAPER_MOTOR;
    let (ra, b, kv) = (p.get(ParamId::Ra), p.get(ParamId::B), p.get(ParamId::Kv));
    let expected = kv as f64 * 100.0 / (ra as f64 * b as f64 + kv as f64 * kv as f64);
    // Solve D x + gv v = 0 in f64 from the f32 coefficients.
    let m = [
        [d.d[0][0] as f64, d.d[0][1] as f64],
        [d.d[1][0] as f64, d.d[1][1] as f64],
    ];
    let rhs = [-(d.gv[0] as f64) * 100.0, -(d.gv[1] as f64) * 100.0];
    let det = m[0][0] * m[1][1] - m[0][1] * m[1][0];
    let w = (m[0][0] * rhs[1] - m[1][0] * rhs[0]) / det;
    assert!((w - expected).abs() < 1e-4 * expected, "{w} vs {expected}");
}

#[test]
fn refuses_bad_parameters() {
    assert_eq!(
        Discrete::new(&ModelParams::PAPER_MOTOR.with(ParamId::La, 0.0), 1e-3),
        Err(Error::NonPositiveParameter(ParamId::La))
    );
    assert_eq!(
        Discrete::new(&ModelParams::PAPER_MOTOR, f32::NAN),
        Err(Error::InvalidStep)
    );
}

#[test]
fn the_inverse_factorials_are_the_fractions() {
    // Each entry against k! built exactly in integers (u128 holds 25!), and against the
    // recurrence 1/k! = (1/(k-1)!) / k: within an f64 unit in the last place of both.
    let mut factorial = 1u128;
    for (k, &inv) in INV_FACTORIAL.iter().enumerate() {
        if k > 0 {
            factorial *= k as u128;
        }
        let exact = 1.0 / factorial as f64;
        assert!(
            ((inv - exact) / exact).abs() < 3e-16,
            "{k}: {inv:e} {exact:e}"
        );
        if k > 0 {
            let by_recurrence = INV_FACTORIAL[k - 1] / k as f64;
            assert!(((inv - by_recurrence) / inv).abs() < 3e-16, "{k}");
        }
    }
    assert_eq!(INV_FACTORIAL.len(), TAYLOR_TERMS as usize + 2);
}
