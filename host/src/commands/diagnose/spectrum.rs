//! The order spectrum of the baseline's residual against rotor angle: a peak at a fixed
//! number of cycles per revolution that scales with speed is the tacho ripple's signature;
//! one that falls as the speed rises is cogging's (a detent torque's speed ripple,
//! `cog_amp / (J cycles w)`).

use super::data::{peak, Trace};

/// How a ripple's size goes with the speed `w`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shape {
    /// `w amp sin(order theta + phase)`: the tacho ripple (a reading modulated with angle).
    Ripple,
    /// `amp sin(order theta + phase) / w`: cogging (a torque modulated with angle, filtered
    /// by the inertia: `amp` is `cog_amp / (J order)`).
    Cogging,
}

impl Shape {
    /// Share of the record's top speed below which samples are left out: the angle barely
    /// moves there. Cogging shows mostly at low speed (its ripple falls as 1 / w), so it
    /// keeps samples down to a hundredth of the top speed.
    fn slowest(self) -> f64 {
        match self {
            Shape::Ripple => 0.1,
            Shape::Cogging => 0.01,
        }
    }

    /// The ripple's size at speed `w` for a unit amplitude.
    fn at(self, w: f64) -> f64 {
        match self {
            Shape::Ripple => w,
            Shape::Cogging => 1.0 / w,
        }
    }
}

/// The strongest ripple of the residual against rotor angle.
#[derive(Clone, Copy, Debug)]
pub struct OrderPeak {
    /// Cycles per revolution.
    pub order: u32,
    /// Share of the residual's energy it explains.
    pub share: f64,
    /// Amplitude of `shape(w) amp sin(order theta + phase)`.
    pub amp: f64,
    /// Phase [rad], in [0, 2 pi).
    pub phase: f64,
}

impl OrderPeak {
    /// No ripple: order 1, nothing explained.
    pub const NONE: OrderPeak = OrderPeak {
        order: 1,
        share: 0.0,
        amp: 0.0,
        phase: 0.0,
    };
}

/// The tacho ripple's order spectrum of the residual against rotor angle (integrated
/// speed): for each order in 1..=64 cycles per revolution, the least-squares fit of
/// `r = w (a sin + b cos)(order theta)` ([`Shape::Ripple`]); the order that explains most
/// of the residual's energy.
pub fn order_peak(traces: &[Trace]) -> OrderPeak {
    let samples = Samples::of(traces, Shape::Ripple);
    (1..=64u32)
        .filter_map(|order| samples.fit(Shape::Ripple, order))
        .fold(None, |best: Option<OrderPeak>, p| match best {
            Some(b) if b.share >= p.share => Some(b),
            _ => Some(p),
        })
        .unwrap_or(OrderPeak::NONE)
}

/// The least-squares fit of `r = shape(w) (a sin + b cos)(order theta)` at one `order`
/// (cogging's, when the user gives it: on the reference plant's records its ripple lies
/// under the noise, and the largest share is a trend's, at order 1), `None` when the records
/// turn too little.
pub fn order_fit(traces: &[Trace], shape: Shape, order: u32) -> Option<OrderPeak> {
    Samples::of(traces, shape).fit(shape, order)
}

/// The samples an order spectrum fits: turning faster than [`Shape::slowest`] of the
/// record's top speed (the angle barely moves below, and cogging's `1 / w` grows without
/// bound), each as (angle, residual, speed), and the residual's energy over them.
struct Samples {
    points: Vec<(f64, f64, f64)>,
    total: f64,
}

impl Samples {
    fn of(traces: &[Trace], shape: Shape) -> Samples {
        let mut points = Vec::new();
        let mut total = 0.0f64;
        for t in traces {
            let wmax = peak(&t.omega);
            // Cogging lives where the baseline turns while the detents hold or jerk the
            // shaft: its angle and size follow the measured speed; the ripple's the
            // baseline's (a reading modulated at the model's own speed).
            let speed = |k: usize| match shape {
                Shape::Ripple => t.omega[k] as f64,
                Shape::Cogging => (t.omega[k] + t.residual[k]) as f64,
            };
            for (k, theta) in angles(t.omega.len(), t.dt, speed).enumerate() {
                let w = speed(k);
                if w.abs() > shape.slowest() * wmax as f64 {
                    points.push((theta, t.residual[k] as f64, w));
                    total += (t.residual[k] as f64).powi(2);
                }
            }
        }
        Samples { points, total }
    }

    fn fit(&self, shape: Shape, order: u32) -> Option<OrderPeak> {
        if self.points.len() < 16 || self.total <= 0.0 {
            return None;
        }
        let SinCos { a, b, explained } = fit_sin_cos(self.points.iter().map(|&(theta, r, w)| {
            let (s, c) = (order as f64 * theta).sin_cos();
            let size = shape.at(w);
            ((size * s, size * c), r)
        }))?;
        // a sin + b cos = amp sin(x + phase) with a = amp cos(phase), b = amp sin(phase).
        Some(OrderPeak {
            order,
            share: explained / self.total,
            amp: a.hypot(b),
            phase: b.atan2(a).rem_euclid(std::f64::consts::TAU),
        })
    }
}

/// The least-squares fit of `r = a s + b c` over pairs `((s, c), r)`, and the sum of
/// squares it explains.
struct SinCos {
    a: f64,
    b: f64,
    explained: f64,
}

/// [`SinCos`] of `points`; `None` when `s` and `c` do not span two directions.
fn fit_sin_cos(points: impl Iterator<Item = ((f64, f64), f64)>) -> Option<SinCos> {
    let (mut ss, mut cc, mut sc, mut rs, mut rc) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for ((s, c), r) in points {
        ss += s * s;
        cc += c * c;
        sc += s * c;
        rs += r * s;
        rc += r * c;
    }
    let det = ss * cc - sc * sc;
    if det <= 1e-12 * (ss * cc).max(f64::MIN_POSITIVE) {
        return None;
    }
    let a = (rs * cc - rc * sc) / det;
    let b = (rc * ss - rs * sc) / det;
    Some(SinCos {
        a,
        b,
        explained: a * rs + b * rc,
    })
}

/// The rotor angle at each of `n` sample instants `dt` apart from the first, the speed
/// `speed(k)` integrated by the trapezoid rule. (A left-rectangle sum lags by the speed's
/// change times dt / 2: at 2 kHz a ripple of 16 per revolution whose speed rose by 200 rad/s
/// drifted by 0.8 rad within the record, and the part of it a window's fit could not follow
/// read as noise.)
fn angles(n: usize, dt: f32, speed: impl Fn(usize) -> f64) -> impl Iterator<Item = f64> {
    let half_dt = 0.5 * dt as f64;
    (0..n).scan(0.0f64, move |theta, k| {
        if k > 0 {
            *theta += half_dt * (speed(k - 1) + speed(k));
        }
        Some(*theta)
    })
}

/// Samples per window of [`without_ripple`]'s fits: a ripple's phase, carried by an angle
/// integrated from a speed that is never exact, drifts over a long record; a window of 200
/// samples holds its phase, and its two fitted coefficients take 1 % of the noise's
/// variance with them.
const RIPPLE_WINDOW: usize = 200;

/// The measured speed of `trace` less its ripple at `order` cycles per revolution:
/// `w (a sin + b cos)(order theta)` (the tacho ripple's signature, `w` the baseline's
/// simulated speed) fitted to the residual by least squares window by window
/// ([`RIPPLE_WINDOW`] samples) on this record alone (a rotor's angle at the start differs
/// from record to record, and with it the ripple's phase), `theta` the rotor's angle.
///
/// The rotor turns at the true speed, not at the reading: the integral of a reading
/// `w (1 + a sin x + b cos x)`, `x = order theta`, is `theta - (a cos x - b sin x) / order`
/// plus a constant. Its wobble shifts the ripple's phase by up to the ripple's share, which
/// left 3 % of a 3 % ripple in place (at 2 kHz, where a ripple dwarfing the noise lies above
/// 0.15 cycles per sample, a noise floor read 1.7 times the truth). So the angle is the
/// measured speed's integral with that wobble, from a first fit, added back, and the ripple
/// fitted again (what is left: the square of the ripple's share).
pub fn without_ripple(trace: &Trace, order: u32) -> Vec<f32> {
    let n = order as f64;
    let measured = |k: usize| (trace.omega[k] + trace.residual[k]) as f64;
    let read: Vec<f64> = angles(trace.omega.len(), trace.dt, measured).collect();
    let read_sin_cos = sin_cos_of(n, &read);
    let first = window_fits(trace, &read_sin_cos);
    let rotor: Vec<f64> = (read.iter().zip(&read_sin_cos))
        .enumerate()
        .map(|(k, (&theta, &(s, c)))| {
            let (a, b) = first[k / RIPPLE_WINDOW];
            theta + (a * c - b * s) / n
        })
        .collect();
    let rotor_sin_cos = sin_cos_of(n, &rotor);
    let second = window_fits(trace, &rotor_sin_cos);
    (trace.residual.iter().zip(&trace.omega).zip(&rotor_sin_cos))
        .enumerate()
        .map(|(k, ((&r, &w), &(s, c)))| {
            let (a, b) = second[k / RIPPLE_WINDOW];
            (r as f64 - w as f64 * (a * s + b * c)) as f32 + w
        })
        .collect()
}

/// `(sin, cos)` of `order` times each angle of `theta`.
fn sin_cos_of(order: f64, theta: &[f64]) -> Vec<(f64, f64)> {
    theta.iter().map(|t| (order * t).sin_cos()).collect()
}

/// The ripple's coefficients `(a, b)` of [`without_ripple`] fitted to `trace`'s residual
/// in each window of [`RIPPLE_WINDOW`] samples, `sin_cos` those of the ripple's angle at
/// each sample ((0, 0) where the window does not turn).
fn window_fits(trace: &Trace, sin_cos: &[(f64, f64)]) -> Vec<(f64, f64)> {
    (sin_cos.chunks(RIPPLE_WINDOW))
        .zip(trace.omega.chunks(RIPPLE_WINDOW))
        .zip(trace.residual.chunks(RIPPLE_WINDOW))
        .map(|((sin_cos, omega), residual)| {
            let points = (sin_cos.iter().zip(omega).zip(residual))
                .map(|((&(s, c), &w), &r)| ((w as f64 * s, w as f64 * c), r as f64));
            fit_sin_cos(points).map_or((0.0, 0.0), |f| (f.a, f.b))
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_ripple_fitted_on_one_record_is_taken_out_of_its_speed() {
        // 3 % ripple at 8 per revolution on a ramp of speed, phase 1 rad: what is left is the
        // simulated speed itself.
        let dt = 1e-3f32;
        let omega: Vec<f32> = (0..4000).map(|k| 5.0 + 0.02 * k as f32).collect();
        let residual: Vec<f32> = omega
            .iter()
            .enumerate()
            .map(|(k, &w)| {
                // The rotor's angle, exact for the ramp 5 + 20 t rad/s.
                let t = k as f64 * dt as f64;
                let theta = 5.0 * t + 10.0 * t * t;
                (w as f64 * 0.03 * (8.0 * theta + 1.0).sin()) as f32
            })
            .collect();
        let trace = Trace {
            name: "ramp".into(),
            set: "holdout",
            dt,
            residual,
            omega: omega.clone(),
            current: vec![0.0; 4000],
            current_residual: None,
        };
        // The largest difference from the simulated speed after taking out `order`.
        let left_at = |order: u32| {
            without_ripple(&trace, order)
                .iter()
                .zip(&omega)
                .map(|(c, w)| (c - w).abs())
                .fold(0.0f32, f32::max)
        };
        // What is left is the square of the ripple's share (3 % of 3 %, on speeds up to
        // 85 rad/s: 0.08 before the angle's wobble was taken out).
        let worst = left_at(8);
        assert!(worst < 0.01, "{worst}");
        // At another order the ripple stays.
        let left = left_at(5);
        assert!(left > 1.0, "{left}");
    }
}
