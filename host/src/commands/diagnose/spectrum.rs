//! The order spectrum of the baseline's residual against rotor angle: a peak at a fixed
//! number of cycles per revolution scales with speed, the tacho ripple's signature.

use super::data::{peak, Trace};

/// The strongest ripple of the residual against rotor angle.
#[derive(Clone, Copy, Debug)]
pub struct OrderPeak {
    /// Cycles per revolution.
    pub order: u32,
    /// Share of the residual's energy it explains.
    pub share: f64,
    /// Relative amplitude of `w * amp * sin(order * theta + phase)`.
    pub amp: f64,
    /// Phase [rad], in [0, 2 pi).
    pub phase: f64,
}

/// Order spectrum of the residual against rotor angle (integrated baseline speed): for each
/// order in 1..=64 cycles per revolution, the least-squares fit of
/// `r = w (a sin + b cos)(order theta)` (the tacho ripple's signature); the order that
/// explains most of the residual's energy.
pub fn order_peak(traces: &[Trace]) -> OrderPeak {
    let mut best = OrderPeak {
        order: 1,
        share: 0.0,
        amp: 0.0,
        phase: 0.0,
    };
    let mut total = 0.0f64;
    let mut used = 0usize;
    // Samples turning faster than 10 % of the top speed, their angle and relative residual.
    let mut samples: Vec<(f64, f64, f64)> = Vec::new();
    for t in traces {
        let wmax = peak(&t.omega);
        let mut theta = 0.0f64;
        for k in 0..t.omega.len() {
            let w = t.omega[k] as f64;
            if w.abs() > 0.1 * wmax as f64 {
                samples.push((theta, t.residual[k] as f64, w));
                total += (t.residual[k] as f64).powi(2);
                used += 1;
            }
            theta += w * t.dt as f64;
        }
    }
    if used < 16 || total <= 0.0 {
        return best;
    }
    for order in 1..=64u32 {
        // Least-squares fit of r = w (a sin + b cos)(order theta): the ripple model.
        let (mut ss, mut cc, mut sc, mut rs, mut rc) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for &(theta, r, w) in &samples {
            let (s, c) = (order as f64 * theta).sin_cos();
            let (s, c) = (w * s, w * c);
            ss += s * s;
            cc += c * c;
            sc += s * c;
            rs += r * s;
            rc += r * c;
        }
        let det = ss * cc - sc * sc;
        if det <= 0.0 {
            continue;
        }
        let a = (rs * cc - rc * sc) / det;
        let b = (rc * ss - rs * sc) / det;
        let explained = a * rs + b * rc;
        let share = explained / total;
        if share > best.share {
            // a sin + b cos = amp sin(x + phase) with a = amp cos(phase), b = amp sin(phase).
            let phase = b.atan2(a).rem_euclid(std::f64::consts::TAU);
            best = OrderPeak {
                order,
                share,
                amp: a.hypot(b),
                phase,
            };
        }
    }
    best
}
