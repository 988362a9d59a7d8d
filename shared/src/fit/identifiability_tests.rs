//! The numerical floor of [`interpret`]: a direction of small columns is informed, a
//! cancellation of large ones is flat.

use super::*;
use crate::fit::space::ProblemSpec;

/// The analysis of a Fisher information `fisher` (natural coordinates, unit residual
/// variance) over Ra and La, the rest fixed at the paper's motor.
fn analysed(fisher: [[f64; 2]; 2]) -> Identifiability {
    let mut spec = ProblemSpec::default();
    for id in [ParamId::J, ParamId::B, ParamId::Kv] {
        spec.fix(id, ModelParams::PAPER_MOTOR.get(id)).unwrap();
    }
    let space = Space::new(&spec, true).unwrap();
    assert_eq!(space.dim(), 2);
    let u = space.unit(&ModelParams::PAPER_MOTOR);
    let p = space.params(&u);
    let per_unit: [f64; 2] =
        core::array::from_fn(|i| space.free()[i].natural_per_unit(p.get(space.free()[i].id)));
    let mut ne = NormalEquations::EMPTY;
    for a in 0..2 {
        for b in 0..2 {
            ne.jtj[a][b] = fisher[a][b] * per_unit[a] * per_unit[b];
        }
    }
    // SSE over the degrees of freedom: a residual variance of 1.
    let cost = Cost {
        sse: 1000.0,
        residuals: 1002,
        rmse_omega: 1.0,
        rmse_current: None,
    };
    let mut scores = ScoreBlocks::EMPTY;
    scores.set_dim(2);
    let mut lines = [[0.0; MAX_FREE]; MAX_FREE];
    interpret(&ne, &scores, &space, &u[..2], &cost, &mut lines).unwrap()
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
