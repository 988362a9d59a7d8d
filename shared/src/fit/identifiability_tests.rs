//! The numerical floor of [`interpret`]: a direction of small columns is informed, a
//! cancellation of large ones is flat.

use super::*;
use crate::fit::space::ProblemSpec;

/// The analysis of a Fisher information `fisher` (natural coordinates, unit residual
/// variance) over the first `N` of Ra, La and J, the rest fixed at the paper's motor.
fn analysed<const N: usize>(fisher: [[f64; N]; N]) -> Identifiability {
    let mut spec = ProblemSpec::default();
    for id in [
        ParamId::Ra,
        ParamId::La,
        ParamId::J,
        ParamId::B,
        ParamId::Kv,
    ]
    .into_iter()
    .skip(N)
    {
        spec.fix(id, ModelParams::PAPER_MOTOR.get(id)).unwrap();
    }
    let space = Space::new(&spec, true).unwrap();
    assert_eq!(space.dim(), N);
    let u = space.unit(&ModelParams::PAPER_MOTOR);
    let p = space.params(&u);
    let per_unit: [f64; N] =
        core::array::from_fn(|i| space.free()[i].natural_per_unit(p.get(space.free()[i].id)));
    let mut ne = NormalEquations::EMPTY;
    for a in 0..N {
        for b in 0..N {
            ne.jtj[a][b] = fisher[a][b] * per_unit[a] * per_unit[b];
        }
    }
    // SSE over the degrees of freedom: a residual variance of 1.
    let cost = Cost {
        sse: 1000.0,
        residuals: 1000 + N,
        rmse_omega: 1.0,
        rmse_current: None,
    };
    let mut scores = ScoreBlocks::EMPTY;
    scores.set_dim(N);
    let mut lines = [[0.0; MAX_FREE]; MAX_FREE];
    interpret(&ne, &scores, &space, &u[..N], &cost, &mut lines).unwrap()
}

#[test]
fn a_direction_of_small_columns_is_informed_however_large_the_others() {
    // La alone, known to 3.2 % (information 1e3), beside an Ra with a billion times the
    // information: 1e-9 of the largest eigenvalue, under a floor of 1e-8 of it, and called flat
    // by it; its own column is resolved far better than that.
    let a = analysed([[1e12, 0.0], [0.0, 1e3]]);
    let la = a.params.iter().find(|q| q.id == ParamId::La).unwrap();
    let std = la.std.expect("La pinned") as f64 / la.value as f64;
    assert!((std / 1e3f64.powf(-0.5) - 1.0).abs() < 1e-3, "{std}");
    assert!(a.unpinned.is_empty());
}

#[test]
fn a_cancellation_of_large_columns_stays_numerically_flat() {
    // Ra and La, each known to 1e-6, in a combination that cancels to 1e-9 of their
    // information: the eigenvalue (1e3, a deviation of 3 %) lies under what finite
    // differences of an f32 simulation resolve, and the direction is flat.
    let eps = 1e-9;
    let a = analysed([[1e12, 1e12 * (1.0 - eps)], [1e12 * (1.0 - eps), 1e12]]);
    assert!(a.params.iter().all(|q| !q.pinned));
    assert_eq!(a.unpinned.len(), 1);
    assert!(a.unpinned[0].std.is_infinite());
}

#[test]
fn a_direction_is_judged_by_its_own_columns_not_by_a_parameter_s_row() {
    // J alone, known to 3.2 % (information 1e3), beside Ra and La mixed at 30 degrees in
    // directions of 1e13 and 1e11. The eigenvector matrix is not symmetric: J's direction
    // holds J's column only (its own information 1e3, a floor of 1e-2), where J's row of
    // the matrix reaches into La's large column (a floor of 1e5, over J's eigenvalue, that
    // would call it flat, as the floor set by the largest eigenvalue alone did).
    let (c, s) = (30f64.to_radians().cos(), 30f64.to_radians().sin());
    let (big, mid, small) = (1e13, 1e11, 1e3);
    let fisher = [
        [big * c * c + mid * s * s, (big - mid) * c * s, 0.0],
        [(big - mid) * c * s, big * s * s + mid * c * c, 0.0],
        [0.0, 0.0, small],
    ];
    let a = analysed(fisher);
    assert!(a.unpinned.is_empty(), "{:?}", a.unpinned);
    let j = a.params.iter().find(|q| q.id == ParamId::J).unwrap();
    let std = j.std.expect("J pinned") as f64 / j.value as f64;
    assert!((std / small.powf(-0.5) - 1.0).abs() < 1e-3, "{std}");
}
