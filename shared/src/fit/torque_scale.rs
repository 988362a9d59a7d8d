//! The torque scale: J, B, Kv and every torque parameter scaled by one factor leave the
//! speed unchanged for a given current, and as a direction of the unit cube, the one the
//! finite-difference Jacobian ([`crate::fit::normal_equations`]) differentiates along
//! instead of Kv's own axis.
//!
//! Divided by Kv, paper Eq. 4 gives the speed from the current through J/Kv, B/Kv and the
//! load torques over Kv alone; only the back-EMF current Kv ω / Ra of paper Eq. 1 moves
//! along the scale. Where the back-EMF is small against Ra i (a viscous motor), that
//! direction is a narrow valley of the cost. Along any one coordinate the speed moves, and
//! with Coulomb friction its stops, stick and break-away move with it: the residuals kink
//! there, and a finite difference along each axis is off by far more than the valley's own
//! curvature. Their combination along the scale, which holds the speed and so every kink,
//! came out 4 to 3,000 times the curvature measured along the line itself (commissioning
//! benchmark, motor 960: the refinement stalled 12 % off the truth, at 120 of its
//! deviations; docs/measurements/commissioning.md). Differentiated along the scale
//! itself, that column is smooth; the axis Jacobian follows by linear algebra. Only for
//! records with current: without it the simulated current moves along the scale, and the
//! speed with it.

use crate::capacity::MAX_FREE;
use crate::fit::space::{Scale, Space};
use crate::param_id::{ParamId, PARAM_COUNT};

/// True for the parameters that scale with the torque: J, B, Kv and every parameter
/// measured in a torque (N m, N m s^2/rad^2, ...: Coulomb and static friction, a quadratic
/// load, cogging).
pub fn scales(id: ParamId) -> bool {
    SCALES[id.index()]
}

/// [`scales`] per parameter, read from the catalogue's units when compiled (a board links
/// no unit string for it).
const SCALES: [bool; PARAM_COUNT] = {
    let mut scales = [false; PARAM_COUNT];
    let mut k = 0;
    while k < PARAM_COUNT {
        let id = ParamId::ALL[k];
        let unit = id.spec().unit.as_bytes();
        let torque = unit.len() >= 3 && unit[0] == b'N' && unit[1] == b' ' && unit[2] == b'm';
        scales[k] = torque || matches!(id, ParamId::J | ParamId::B | ParamId::Kv);
        k += 1;
    }
    scales
};

/// The scale's direction at unit point `u`: the coordinate of Kv and the displacement of
/// every coordinate per unit displacement of Kv's (1 at Kv's, 0 for a parameter that does
/// not scale), the free torque parameters scaled with J, B and Kv. `None` unless J, B and Kv
/// are all free.
fn direction(space: &Space, u: &[f32]) -> Option<(usize, [f32; MAX_FREE])> {
    let free = space.free();
    let slot = |id: ParamId| space.position(id);
    let (_, _, kv) = (slot(ParamId::J)?, slot(ParamId::B)?, slot(ParamId::Kv)?);
    // d u / d ln(scale) per coordinate: 1 / ln(hi/lo) on a log scale, p / (hi - lo) on a
    // linear one.
    let per_log = |k: usize| {
        let f = &free[k];
        match f.scale {
            Scale::Log => 1.0 / libm::logf(f.hi / f.lo),
            Scale::Linear => f.value(u[k]) / (f.hi - f.lo),
        }
    };
    let along_kv = per_log(kv);
    let mut w = [0.0f32; MAX_FREE];
    for (k, f) in free.iter().enumerate() {
        if scales(f.id) {
            w[k] = per_log(k) / along_kv;
        }
    }
    w.iter().all(|x| x.is_finite()).then_some((kv, w))
}

/// The Jacobian's differentiation along the scale at one point: Kv's slot of the finite
/// differences displaced along [`direction`] instead of Kv's axis.
#[derive(Clone, Copy, Debug)]
pub struct ScaleSlot {
    /// Kv's coordinate.
    pub kv: usize,
    /// The displacements of Kv's coordinate at the upper and the lower point (one of them 0
    /// for forward differences).
    pub t: (f32, f32),
    /// The direction, per unit displacement of Kv's coordinate.
    w: [f32; MAX_FREE],
    /// The other coordinates' realised displacement between the two points, per unit of
    /// Kv's (each kept within the cube and rounded in f32): what the column holds besides
    /// Kv's own derivative.
    realised: [f32; MAX_FREE],
    /// Kv's realised displacement between the lower and the upper point.
    step: f32,
}

impl ScaleSlot {
    /// The slot at `u` for finite differences of step `h`, central or forward (backward, or
    /// a shorter forward step, where the forward point would leave the cube); `None` when J, B or Kv is not free or
    /// the point sits in a corner the scale cannot move in (then Kv's axis serves).
    pub fn new(space: &Space, u: &[f32], h: f32, central: bool) -> Option<ScaleSlot> {
        let (kv, w) = direction(space, u)?;
        let (up, down) = (room(u, &w, h, 1.0), room(u, &w, h, -1.0));
        let t = match central {
            true => (up, -down),
            false if up >= h => (h, 0.0),
            false if down >= h || down > up => (0.0, -down),
            false => (up, 0.0),
        };
        let (hi, lo) = (along(u, &w, t.0), along(u, &w, t.1));
        let step = hi[kv] - lo[kv];
        if step <= 0.0 {
            return None;
        }
        let mut realised = [0.0f32; MAX_FREE];
        for (k, r) in realised.iter_mut().enumerate().take(u.len()) {
            if k != kv {
                *r = (hi[k] - lo[k]) / step;
            }
        }
        Some(ScaleSlot {
            kv,
            t,
            w,
            realised,
            step,
        })
    }

    /// Kv's displacement between the lower and the upper point.
    pub fn step(&self) -> f32 {
        self.step
    }

    /// The perturbed point at displacement `t` of Kv's coordinate.
    pub fn point(&self, u: &[f32], t: f32) -> [f32; MAX_FREE] {
        along(u, &self.w, t)
    }

    /// Kv's column on its own axis from the column along the scale (in place): the
    /// difference along the scale is Kv's derivative plus the others' times their realised
    /// displacement.
    pub fn to_axis(&self, columns: &mut [f32]) {
        let mut kv = columns[self.kv];
        for (c, r) in columns.iter().zip(&self.realised) {
            kv -= r * c;
        }
        columns[self.kv] = kv;
    }
}

/// The point `t` along `w` from `u`, each coordinate kept within the cube.
fn along(u: &[f32], w: &[f32; MAX_FREE], t: f32) -> [f32; MAX_FREE] {
    let mut moved = [0.0f32; MAX_FREE];
    for ((m, &x), &dx) in moved.iter_mut().zip(u).zip(w) {
        *m = (x + t * dx).clamp(0.0, 1.0);
    }
    moved
}

/// The largest displacement up to `h` along `sign * w` from `u` that keeps every coordinate
/// within the cube (0 at a face the direction leaves by).
fn room(u: &[f32], w: &[f32; MAX_FREE], h: f32, sign: f32) -> f32 {
    u.iter().zip(w).fold(h, |t, (&x, &dx)| {
        let d = sign * dx;
        match d {
            d if d > 0.0 => t.min((1.0 - x) / d),
            d if d < 0.0 => t.min(x / -d),
            _ => t,
        }
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::normal_equations::NormalEquations;
    use crate::fit::objective::Objective;
    use crate::fit::space::ProblemSpec;
    use crate::model::params::ModelParams;
    use crate::testkit::Owned;

    extern crate std;
    use std::vec::Vec;

    #[test]
    fn the_torque_parameters_scale_and_the_electrical_ones_do_not() {
        for id in [
            ParamId::J,
            ParamId::B,
            ParamId::Kv,
            ParamId::Tc,
            ParamId::Ts,
        ] {
            assert!(scales(id), "{id:?}");
        }
        for id in [
            ParamId::Ra,
            ParamId::La,
            ParamId::Td,
            ParamId::Ws,
            ParamId::Io,
        ] {
            assert!(!scales(id), "{id:?}");
        }
    }

    #[test]
    fn the_jacobian_holds_the_curvature_along_the_scale_of_a_viscous_motor_with_coulomb_friction() {
        // Motor 960 of the commissioning benchmark: Kv^2 is 0.6 % of Ra B, Coulomb friction 5 %
        // of the drive's torque; its slow record (steps, then a coast-down to a stop), noise
        // free so that at the truth the Gauss-Newton curvature is the cost's own. Along each
        // axis the Jacobian put the curvature along the scale 1,377 (forward) and 365
        // (central) times too high here; along the scale, 0.95 and 1.17 times.
        let p = ModelParams::motor(
            8.604882,
            0.078124955,
            0.0035782813,
            0.003720269,
            0.014117234,
        )
        .with(ParamId::Tc, 0.05 * 0.014117234 * 40.0);
        let slow = Owned::commissioning(&p, 1600, 5e-3, 50.0);
        let records = [slow.record(true, false)];
        let objective = Objective::new(&records).unwrap();
        let mut spec = ProblemSpec::default();
        spec.free(ParamId::Tc);
        let space = Space::new(&spec, true).unwrap();
        let dim = space.dim();
        // The curvature along the line itself: the second difference of the cost over the
        // scale moved by ±0.1 %.
        let scaled = |f: f32| {
            [ParamId::J, ParamId::B, ParamId::Kv, ParamId::Tc]
                .iter()
                .fold(p, |q, &id| q.with(id, p.get(id) * f))
        };
        let sse = |f: f32| objective.cost(&scaled(f)).unwrap().sse;
        let along_line = sse(1.001) + sse(0.999) - 2.0 * sse(1.0);
        assert!(along_line > 0.0, "{along_line}");
        let u = space.unit(&p);
        let up = space.unit(&scaled(1.001));
        let d: Vec<f64> = (0..dim).map(|k| f64::from(up[k] - u[k])).collect();
        for central in [false, true] {
            let mut ne = NormalEquations::EMPTY;
            assert!(objective.normal_equations(&space, &u[..dim], 1e-4, central, &mut ne));
            let quadratic: f64 = (0..dim)
                .map(|i| (0..dim).map(|k| d[i] * ne.jtj[i][k] * d[k]).sum::<f64>())
                .sum();
            let ratio = 2.0 * quadratic / along_line;
            assert!(
                (0.7..1.4).contains(&ratio),
                "central {central}: Jacobian {} against the line's {along_line}",
                2.0 * quadratic
            );
        }
    }
}
