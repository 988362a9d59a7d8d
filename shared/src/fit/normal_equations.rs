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
        match Simulator::any_averaged(self.records) {
            true => self.normal_equations_of::<true>(space, u, h, central, out, scores),
            false => self.normal_equations_of::<false>(space, u, h, central, out, scores),
        }
    }

    /// [`Objective::normal_equations_sums`], of averaged readings with `AVERAGED`
    /// ([`Simulator::sample`]).
    fn normal_equations_of<const AVERAGED: bool>(
        &self,
        space: &Space,
        u: &[f32],
        h: f32,
        central: bool,
        out: &mut NormalEquations,
        mut scores: Option<&mut ScoreBlocks>,
    ) -> Option<()> {
        let dim = space.dim();
        let nominal = space.params(u);
        // Perturbed points: +h (and -h) per coordinate, kept inside the cube, as (coordinate,
        // value; Kv's along the torque scale, by its displacement) (their parameters are
        // built per record: stack is scarce on a board). `pairs[d]` holds the indices of the
        // upper and lower point in `points`, NOMINAL for the nominal one.
        const NOMINAL: usize = usize::MAX;
        let mut steps = [0.0f32; MAX_FREE];
        let mut pairs = [(NOMINAL, NOMINAL); MAX_FREE];
        let mut points: heapless::Vec<(usize, f32), { 2 * MAX_FREE }> = heapless::Vec::new();
        // Kv's slot differentiated along the torque scale (see `torque_scale`) where a
        // current is read, for which the scale holds the speed: its points are stored by
        // their displacement along it.
        let scale = match self.current_weight > 0.0 {
            true => ScaleSlot::new(space, &u[..dim], h, central),
            false => None,
        };
        for d in 0..dim {
            // The upper and lower point's value (Kv's slot: its displacement, 0 at the
            // nominal point) and the nominal point's.
            let slot = scale.as_ref().filter(|s| s.kv == d);
            let (hi, lo, nominal) = match slot {
                Some(slot) => (slot.t.0, slot.t.1, 0.0),
                None if central => ((u[d] + h).min(1.0), (u[d] - h).max(0.0), u[d]),
                None if u[d] + h <= 1.0 => (u[d] + h, u[d], u[d]),
                None => (u[d], u[d] - h, u[d]),
            };
            steps[d] = slot.map_or(hi - lo, ScaleSlot::step);
            let mut index_of = |x: f32| -> Option<usize> {
                if x == nominal {
                    return Some(NOMINAL);
                }
                points.push((d, x)).ok()?;
                Some(points.len() - 1)
            };
            pairs[d] = (index_of(hi)?, index_of(lo)?);
        }
        let w = self.current_weight;
        let mut totals = Totals::default();
        // The Jacobian's sums go straight into `out` (no second matrix on this frame).
        out.jtj = [[0.0; MAX_FREE]; MAX_FREE];
        out.jtr = [0.0; MAX_FREE];
        for r in self.records {
            let (init, shifted) = self.initial_pair(r, &nominal);
            let mut sim0 = Simulator::for_record(&nominal, r, init).ok()?;
            let mut sim_s = match shifted {
                Some(s) => Some(Simulator::for_record(&nominal, r, s).ok()?),
                None => None,
            };
            let mut sims: heapless::Vec<Simulator, { 2 * MAX_FREE }> = heapless::Vec::new();
            for &(d, x) in &points {
                let moved = match scale.as_ref().filter(|s| s.kv == d) {
                    Some(slot) => slot.point(&u[..dim], x),
                    None => {
                        let mut moved = [0.0f32; MAX_FREE];
                        moved[..dim].copy_from_slice(&u[..dim]);
                        moved[d] = x;
                        moved
                    }
                };
                let p = space.params(&moved[..dim]);
                let (init_p, _) = self.initial_pair(r, &p);
                sims.push(Simulator::for_record(&p, r, init_p).ok()?).ok()?;
            }
            let tracks = sim0.tracks_angle() || sims.iter().any(Simulator::tracks_angle);
            let with_current = r.current.is_some() && w > 0.0;
            let mut sums = RecordSums::new(dim, with_current, sim_s.is_some());
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
                let y0 = sim0.sample::<AVERAGED>();
                let read = |i: usize| {
                    if i == NOMINAL {
                        y0
                    } else {
                        sims[i].sample::<AVERAGED>()
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
                if let Some(slot) = &scale {
                    slot.to_axis(&mut col_w[..dim]);
                    slot.to_axis(&mut col_i[..dim]);
                }
                let (col_w, col_i) = (&col_w[..dim], &col_i[..dim]);
                let (rw, ri) = sums.add_residuals(r, k, y0, w);
                sums.add_jacobian(rw, ri, col_w, col_i);
                if let Some(s) = scores.as_deref_mut() {
                    // The residuals' response to the initial speed (see ScoreBlocks).
                    let h = match sim_s.as_ref().map(Simulator::sample::<AVERAGED>) {
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
                if let Some(s) = sim_s.as_ref() {
                    sums.add_shift_response(r, k, y0, s.sample::<AVERAGED>(), w, col_w, col_i);
                }
                sums.end_sample();
                let input = r.step_input(k, tracks);
                sim0.apply_record::<AVERAGED>(&input);
                if let Some(s) = sim_s.as_mut() {
                    s.apply_record::<AVERAGED>(&input);
                }
                for s in sims.iter_mut() {
                    s.apply_record::<AVERAGED>(&input);
                }
            }
            let shift = sums.finish_into(w, &mut totals, Some((dim, &mut out.jtj, &mut out.jtr)));
            if let Some(s) = scores.as_deref_mut() {
                s.end_record(shift);
            }
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
        out.simulations = 1 + points.len() as u32;
        Some(())
    }
}
