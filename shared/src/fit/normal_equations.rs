//! The Gauss-Newton normal equations of the objective ([`crate::fit::objective`]) at one
//! point of the unit cube, by finite differences of simulations run side by side over each
//! record, with the records' initial speeds projected out, and, for the identifiability
//! analysis, the block scores of the residuals ([`crate::fit::score_blocks`]).

use crate::capacity::MAX_FREE;
use crate::fit::linalg::{Mat, Vector};
use crate::fit::objective::{Cost, Objective};
use crate::fit::score_blocks::ScoreBlocks;
use crate::fit::space::Space;
use crate::fit::sums::{RecordSums, Totals, SHIFT};
use crate::fit::torque_scale::ScaleSlot;
use crate::fit::workspace::{with_sims, JacobianSims};
use crate::model::params::ModelParams;
use crate::model::record::Record;
use crate::model::rounding::Rounding;
use crate::model::sim::Simulator;

/// Gauss-Newton normal equations at one point of the unit cube.
#[derive(Clone, Debug)]
pub struct NormalEquations {
    /// `J^T J` (Jacobian of the weighted residuals w.r.t. unit coordinates).
    pub jtj: Mat,
    /// `J^T r` with `r = measured - simulated`.
    pub jtr: Vector,
    /// Cost at the point.
    pub cost: Cost,
    /// Model evaluations spent: parameter sets simulated, each over all records.
    pub simulations: u32,
}

impl NormalEquations {
    /// Not yet computed: zero sums, an infinite cost, no simulations. The value a caller
    /// starts from before [`Objective::normal_equations`] fills it in place.
    pub const EMPTY: NormalEquations = NormalEquations {
        jtj: [[0.0; MAX_FREE]; MAX_FREE],
        jtr: [0.0; MAX_FREE],
        cost: Cost {
            sse: f64::INFINITY,
            residuals: 0,
            rmse_omega: f32::INFINITY,
            rmse_current: None,
        },
        simulations: 0,
    };
}

impl Objective<'_, '_> {
    /// Normal equations at unit point `u` by finite differences of step `h` in unit
    /// coordinates: forward (dim + 1 evaluations) or central (2 dim + 1), with the initial
    /// speeds projected out (variable projection, see [`RecordSums`]). Written into `out`
    /// in place, so that no second copy of the equations sits on a refinement's stack (the
    /// board's stack budget, docs/measurements/footprint.md). False when the point cannot be simulated or a sum is
    /// not finite: `out.cost` and `out.simulations` are then as they were, its sums are not
    /// (a caller that goes on uses the cost only, as least squares does when it stops).
    pub fn normal_equations(
        &self,
        space: &Space,
        u: &[f32],
        h: f32,
        central: bool,
        out: &mut NormalEquations,
    ) -> bool {
        self.normal_equations_sums(space, u, h, central, out, None)
            .is_some()
    }

    /// [`Objective::normal_equations`], with the block scores of the residuals summed into
    /// `scores` as well when given (for the identifiability analysis; see [`ScoreBlocks`]);
    /// `None` where that returns false.
    pub(crate) fn normal_equations_sums(
        &self,
        space: &Space,
        u: &[f32],
        h: f32,
        central: bool,
        out: &mut NormalEquations,
        scores: Option<&mut ScoreBlocks>,
    ) -> Option<()> {
        // The simulators in the lent workspace (a board's static RAM), or on a frame of
        // their own.
        with_sims(self.workspace, |sims| {
            match Simulator::averaged_path(self.records) {
                true => self.normal_equations_of::<true>(sims, space, u, h, central, out, scores),
                false => self.normal_equations_of::<false>(sims, space, u, h, central, out, scores),
            }
        })
    }

    /// [`Objective::normal_equations_sums`], of averaged readings with `AVERAGED`
    /// ([`Simulator::sample`]). Per record, `sims` holds the nominal parameter set's
    /// simulator, then one per perturbed point, then the nominal set's from the shifted
    /// initial speed (if the record has one): built on a frame of their own
    /// ([`Objective::fill_sims`]) and run on another ([`Objective::record_jacobian`]), so that
    /// the deepest call on a board's stack holds one of the two (docs/measurements/footprint.md).
    #[allow(clippy::too_many_arguments)]
    fn normal_equations_of<const AVERAGED: bool>(
        &self,
        sims: &mut JacobianSims,
        space: &Space,
        u: &[f32],
        h: f32,
        central: bool,
        out: &mut NormalEquations,
        mut scores: Option<&mut ScoreBlocks>,
    ) -> Option<()> {
        let points = Points::new(space, &u[..space.dim()], h, central, self.current_weight)?;
        let dim = points.dim;
        let nominal = space.params(&u[..dim]);
        let mut totals = Totals::default();
        // The Jacobian's sums go straight into `out` (no second matrix on this frame).
        out.jtj = [[0.0; MAX_FREE]; MAX_FREE];
        out.jtr = [0.0; MAX_FREE];
        for r in self.records {
            let shifted_at = self.fill_sims(sims, space, &u[..dim], &nominal, &points, r)?;
            let to = (&mut *out, &mut totals);
            self.record_jacobian::<AVERAGED>(
                sims,
                r,
                &points,
                shifted_at,
                to,
                scores.as_deref_mut(),
            );
        }
        let cost = self.cost_of(&totals)?;
        let (jtj, jtr) = (&out.jtj, &out.jtr);
        let finite = jtr[..dim].iter().all(|x| x.is_finite())
            && jtj[..dim]
                .iter()
                .all(|row| row[..dim].iter().all(|x| x.is_finite()));
        if !finite {
            return None;
        }
        out.cost = cost;
        // One evaluation per distinct parameter set, over all records (as the FFO counts).
        out.simulations = 1 + points.list.len() as u32;
        Some(())
    }

    /// Fill `sims` with the simulations of record `r` (see [`Objective::normal_equations_of`]);
    /// the index of the shifted initial speed's, if any. `None` when a point cannot be
    /// simulated.
    #[inline(never)]
    fn fill_sims(
        &self,
        sims: &mut JacobianSims,
        space: &Space,
        u: &[f32],
        nominal: &ModelParams,
        points: &Points,
        r: &Record,
    ) -> Option<Option<usize>> {
        let dim = points.dim;
        let (init, shifted) = self.initial_pair(r, nominal);
        let count = 1 + points.list.len() + shifted.is_some() as usize;
        sims.clear();
        // One call site, so that one simulator at a time is built on this frame.
        for j in 0..count {
            let (p, start) = match points.list.get(j.wrapping_sub(1)) {
                Some(&(d, x)) => {
                    let moved = match points.scale.as_ref().filter(|s| s.kv == d) {
                        Some(slot) => slot.point(u, x),
                        None => {
                            let mut moved = [0.0f32; MAX_FREE];
                            moved[..dim].copy_from_slice(u);
                            moved[d] = x;
                            moved
                        }
                    };
                    let p = space.params(&moved[..dim]);
                    let (init_p, _) = self.initial_pair(r, &p);
                    (p, init_p)
                }
                // The nominal set first, its shifted initial speed's last.
                None => (*nominal, if j == 0 { init } else { shifted? }),
            };
            // The nominal set's coefficients serve every set with its motor.
            let like = sims.first().map(|s| (nominal, s));
            let sim = Simulator::for_record_like(&p, r, start, like).ok()?;
            sims.push(sim).ok()?;
        }
        Some(shifted.map(|_| count - 1))
    }

    /// Run the simulations in `sims` over record `r` and add its sums of the Jacobian to
    /// `to` (the normal equations and the cost's totals), and to `scores` when given.
    #[inline(never)]
    fn record_jacobian<const AVERAGED: bool>(
        &self,
        sims: &mut JacobianSims,
        r: &Record,
        points: &Points,
        shifted_at: Option<usize>,
        to: (&mut NormalEquations, &mut Totals),
        mut scores: Option<&mut ScoreBlocks>,
    ) {
        let (dim, steps, pairs) = (points.dim, &points.steps, &points.pairs);
        let w = self.current_weight;
        let tracks = sims.iter().any(Simulator::tracks_angle);
        let with_current = r.current.is_some() && w > 0.0;
        let mut sums = RecordSums::new(dim, with_current, shifted_at.is_some());
        if let Some(s) = scores.as_deref_mut() {
            let rounding = match s.adc_readings() {
                true => [
                    Rounding::of_means(r.omega, self.sigma_omega(), r.averaged),
                    match (r.current, self.sigma_current(), with_current) {
                        (Some(c), Some(sc), true) => {
                            let q = Rounding::of_means(c, sc, r.averaged);
                            Rounding {
                                error: w * q.error,
                                ..q
                            }
                        }
                        _ => Rounding::default(),
                    },
                ],
                false => [Rounding::default(); 2],
            };
            s.start_record(r.len(), rounding);
        }
        for k in 0..r.len() {
            let y0 = sims[0].sample::<AVERAGED>();
            let ys = shifted_at.map(|j| sims[j].sample::<AVERAGED>());
            let read = |i: usize| {
                if i == NOMINAL {
                    y0
                } else {
                    sims[1 + i].sample::<AVERAGED>()
                }
            };
            let mut col_w = [0.0f32; MAX_FREE];
            let mut col_i = [0.0f32; MAX_FREE];
            for d in 0..dim {
                let a = read(pairs[d].0);
                let b = read(pairs[d].1);
                // r = measured - sim, so dr/du = -(dy/du).
                col_w[d] = -(a.omega - b.omega) / steps[d];
                col_i[d] = -w * (a.current - b.current) / steps[d];
            }
            if let Some(slot) = &points.scale {
                slot.to_axis(&mut col_w[..dim]);
                slot.to_axis(&mut col_i[..dim]);
            }
            let (col_w, col_i) = (&col_w[..dim], &col_i[..dim]);
            let (rw, ri) = sums.add_residuals(r, k, y0, w);
            sums.add_jacobian(rw, ri, col_w, col_i);
            if let Some(s) = scores.as_deref_mut() {
                // The residuals' response to the initial speed (see ScoreBlocks).
                let h = match ys {
                    Some(ys) => (
                        (ys.omega - y0.omega) / SHIFT,
                        if with_current {
                            w * (ys.current - y0.current) / SHIFT
                        } else {
                            0.0
                        },
                    ),
                    None => (0.0, 0.0),
                };
                s.add(col_w, col_i, (rw, ri), h, (y0.omega, y0.current));
            }
            if let Some(ys) = ys {
                sums.add_shift_response(r, k, y0, ys, w, col_w, col_i);
            }
            sums.end_sample();
            let input = r.step_input(k, tracks);
            for s in sims.iter_mut() {
                s.apply_record::<AVERAGED>(&input);
            }
        }
        let (out, totals) = to;
        let shift = sums.finish_into(w, totals, Some((dim, &mut out.jtj, &mut out.jtr)));
        if let Some(s) = scores {
            s.end_record(shift);
        }
    }
}

/// A point list's index of the nominal point (see [`Points`]).
const NOMINAL: usize = usize::MAX;

/// The Jacobian's perturbed points at one point `u` of the unit cube: +h (and -h) per
/// coordinate, kept inside the cube, as (coordinate, value; Kv's along the torque scale, by
/// its displacement) (their parameters are built per record: stack is scarce on a board).
struct Points {
    dim: usize,
    /// Each coordinate's difference step (Kv's slot: along the scale, see `torque_scale`).
    steps: [f32; MAX_FREE],
    /// The indices in `list` of each coordinate's upper and lower point, [`NOMINAL`] for
    /// the nominal one.
    pairs: [(usize, usize); MAX_FREE],
    list: heapless::Vec<(usize, f32), { 2 * MAX_FREE }>,
    /// Kv's slot differentiated along the torque scale where a current is read (weight
    /// `current_weight` > 0), for which the scale holds the speed.
    scale: Option<ScaleSlot>,
}

impl Points {
    /// The points at `u` with difference step `h` (both sides with `central`).
    fn new(space: &Space, u: &[f32], h: f32, central: bool, current_weight: f32) -> Option<Points> {
        let dim = space.dim();
        let scale = match current_weight > 0.0 {
            true => ScaleSlot::new(space, u, h, central),
            false => None,
        };
        let mut points = Points {
            dim,
            steps: [0.0; MAX_FREE],
            pairs: [(NOMINAL, NOMINAL); MAX_FREE],
            list: heapless::Vec::new(),
            scale,
        };
        for d in 0..dim {
            // The upper and lower point's value (Kv's slot: its displacement, 0 at the
            // nominal point) and the nominal point's.
            let slot = points.scale.as_ref().filter(|s| s.kv == d);
            let (hi, lo, nominal) = match slot {
                Some(slot) => (slot.t.0, slot.t.1, 0.0),
                None if central => ((u[d] + h).min(1.0), (u[d] - h).max(0.0), u[d]),
                None if u[d] + h <= 1.0 => (u[d] + h, u[d], u[d]),
                None => (u[d], u[d] - h, u[d]),
            };
            points.steps[d] = slot.map_or(hi - lo, ScaleSlot::step);
            let list = &mut points.list;
            let mut index_of = |x: f32| -> Option<usize> {
                if x == nominal {
                    return Some(NOMINAL);
                }
                list.push((d, x)).ok()?;
                Some(list.len() - 1)
            };
            points.pairs[d] = (index_of(hi)?, index_of(lo)?);
        }
        Some(points)
    }
}
