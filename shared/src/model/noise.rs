//! The measurement noise of a record's reading, from the record alone: the scale of the
//! fit's residual when the model is right (the noise floor every verdict is judged against).

/// Standard deviation of the measurement noise of `x` (the RMS of the reading error, the
/// scale of the fit's residual when the model is right), from local-quadratic
/// (Savitzky-Golay) residuals.
///
/// **The model.** `x[k] = s[k] + e[k]`: a signal `s` sampled well above its bandwidth, and a
/// stationary noise `e` whose autocovariance `g(l)` vanishes beyond one sample, with
/// `g(1) <= 0`. That covers white noise (analogue noise, an ADC's rounding: `g(1) = 0`) and
/// an encoder's speed reading, the count difference over a sample divided by `dt`: the
/// difference of two independent rounding errors, `g(0) = q^2 / 6`, `g(1) = -q^2 / 12` (RMS
/// `q / sqrt 6`, a blue spectrum `(q^2/3) sin^2(pi f)`: most of its power near Nyquist).
///
/// **One residual filter.** `r[k] = x[k] - sum_j h_j x[k+j]`, where `h` is the centre row of
/// the least-squares quadratic fit over `2m + 1` samples, has taps `a` that annihilate
/// quadratics, white-noise gain `A0 = sum a_j^2 = 1 - h_0`, and lag-one correlation
/// `A1 = sum a_j a_{j+1} < 0`. So `E[r^2] / A0 = g(0) + 2 (A1 / A0) g(1) + L`, where `L >= 0`
/// is what the signal leaks through the filter (its curvature's change, a ripple). Both
/// extra terms are non-negative under the model: each filter's normalised mean square is an
/// upper bound of `g(0)`, exact for white noise on a smooth signal.
///
/// **Two windows, the smaller bound.** A short window (5 samples: the fourth difference
/// `(1, -4, 6, -4, 1)`) looks only near Nyquist, so it lets through least of a fast signal
/// (leakage `(2 sin(pi f))^8 / 70` of a component at `f` cycles per sample: 0.4 % at f = 0.14,
/// where a second difference lets 9 % through), but reads an encoder's blue noise `sqrt(1 -
/// A1/A0) = 1.34` times high. A long window (17 samples) passes everything from f = 0.08
/// to Nyquist (at 0.8 to 1.7 times its mean gain), so it weighs the noise's spectrum more
/// evenly and reads an encoder only 1.077 times high, but it lets through ripple and fast
/// transients above f = 0.08. As both are upper bounds, the smaller is the estimate. (The
/// estimator this replaces, second differences read as white noise, read an encoder
/// `sqrt(20/12 / 6) / (1/sqrt 6) = 1.29` times high, and more through its normal-tail
/// correction of a bounded error: 1.47 on the reference plant.)
///
/// **Steps and transients** give a few large residuals. Each filter's mean square is trimmed:
/// a scale from the mean absolute residual (`sqrt(pi/2)` times it for a normal variable,
/// which outliers move less than the RMS), the RMS of the residuals within 4 of it, then the
/// mean square of those within 3.5 of that RMS, divided by `1 - 7 phi(3.5) / (2 Phi(3.5) - 1)
/// = 0.99389` (the mean square of a normal variable truncated at 3.5 sigma; a lighter-tailed
/// error, such as an encoder's, loses nothing at 3.5 and is read within 0.6 %).
///
/// **Limits.** White noise reads about 1 % low (the smaller of two estimates of it). Noise
/// outside the model reads off: a low-passed noise (`g(1) > 0`) reads low; an encoder at a
/// constant speed repeats a pattern of rounding errors, whose share below f = 0.08 reads as
/// signal; a ripple above f = 0.15 reads as noise (nothing in the record alone tells them
/// apart).
///
/// Fixed memory, no sorting, three passes over the record (both windows in each); f32 filter
/// outputs (symmetric taps on the sums of the readings either side: 5 and 25 operations per
/// sample on the board's FPU), f32 sums over blocks of 64 added into f64, a fixed order of
/// operations: the same bits on the host and the board.
pub fn noise_sigma(x: &[f32]) -> f32 {
    // Both windows in one loop (the short one at the long one's centre); a record shorter
    // than the long window gets the short one alone.
    let both = x.len() > 2 * SG_17.sides.len();
    if x.len() <= 2 * SG_5.sides.len() {
        return 0.0;
    }
    let pass = |limits: [f32; 2]| residual_sums(x, both, limits);
    let first = pass([f32::INFINITY; 2]);
    let scale = |k: usize| libm::sqrt(core::f64::consts::FRAC_PI_2) * first[k].abs_mean();
    let second = pass([(4.0 * scale(0)) as f32, (4.0 * scale(1)) as f32]);
    let rms = |k: usize| libm::sqrt(second[k].mean_square());
    let third = pass([(3.5 * rms(0)) as f32, (3.5 * rms(1)) as f32]);
    let var = |k: usize, f: &SgResidual| third[k].mean_square() / 0.99389 / f.gain;
    let short = var(0, &SG_5);
    let var = if both {
        short.min(var(1, &SG_17))
    } else {
        short
    };
    libm::sqrt(var) as f32
}

/// The local-quadratic residual over 5 samples (the fourth difference times 3 / 35).
const SG_5: SgResidual = SgResidual::of(SG_5_TAPS.0, &SG_5_TAPS.1);
const SG_5_TAPS: (f32, [f32; 2]) = sg_taps();
/// The local-quadratic residual over 17 samples.
const SG_17: SgResidual = SgResidual::of(SG_17_TAPS.0, &SG_17_TAPS.1);
const SG_17_TAPS: (f32, [f32; 8]) = sg_taps();

/// Taps of the residual of a least-squares quadratic fit over `2M + 1` samples at its
/// centre, `a_0 = 1 - h_0` and `a_{+-j} = -h_j` for `j = 1..=M`, where the fit's centre row is
/// `h_j = (S4 - S2 j^2) / (n S4 - S2^2)` (`S2`, `S4` the sums of `j^2`, `j^4` over
/// `j = -M..=M`, `n = 2M + 1`).
const fn sg_taps<const M: usize>() -> (f32, [f32; M]) {
    let m = M as f64;
    let s2 = m * (m + 1.0) * (2.0 * m + 1.0) / 3.0;
    let s4 = m * (m + 1.0) * (2.0 * m + 1.0) * (3.0 * m * m + 3.0 * m - 1.0) / 15.0;
    let den = (2.0 * m + 1.0) * s4 - s2 * s2;
    let mut sides = [0.0f32; M];
    let mut j = 0;
    while j < M {
        let k = (j + 1) as f64;
        sides[j] = (-(s4 - s2 * k * k) / den) as f32;
        j += 1;
    }
    ((1.0 - s4 / den) as f32, sides)
}

/// The residual of a local quadratic fit at the centre of a window of `2 sides.len() + 1`
/// samples.
struct SgResidual {
    /// The centre's tap.
    centre: f32,
    /// Taps `a_{+-j}`, `j = 1..=m` (f32, as applied).
    sides: &'static [f32],
    /// White-noise gain `sum a_j^2` of the taps as applied.
    gain: f64,
}

impl SgResidual {
    const fn of(centre: f32, sides: &'static [f32]) -> Self {
        let mut gain = (centre as f64) * (centre as f64);
        let mut j = 0;
        while j < sides.len() {
            gain += 2.0 * (sides[j] as f64) * (sides[j] as f64);
            j += 1;
        }
        SgResidual {
            centre,
            sides,
            gain,
        }
    }

    /// Residual of the window `w` (its length `2 sides.len() + 1`): the centre's tap, then the
    /// symmetric taps applied to the sums of the readings either side.
    #[inline(always)]
    fn at(&self, w: &[f32]) -> f32 {
        let (before, rest) = w.split_at(self.sides.len());
        let (c, after) = (rest[0], &rest[1..]);
        let mut r = self.centre * c;
        for ((t, a), b) in self.sides.iter().zip(after).zip(before.iter().rev()) {
            r += t * (a + b);
        }
        r
    }
}

/// Residuals summed in f32 over blocks of this many, then added into f64.
const NOISE_BLOCK: usize = 64;

/// Sums over the residuals `r` of one filter: of `|r|`, and of `r^2` over those within a
/// limit, with their count.
#[derive(Clone, Copy, Default)]
struct ResidualSums {
    block_abs: f32,
    abs: f64,
    block_sq: f32,
    sq: f64,
    n: usize,
    within: usize,
}

impl ResidualSums {
    #[inline(always)]
    fn add(&mut self, r: f32, limit: f32) {
        self.block_abs += r.abs();
        self.n += 1;
        if r.abs() <= limit {
            self.block_sq += r * r;
            self.within += 1;
        }
    }

    fn flush(&mut self) {
        self.abs += self.block_abs as f64;
        self.sq += self.block_sq as f64;
        self.block_abs = 0.0;
        self.block_sq = 0.0;
    }

    fn abs_mean(&self) -> f64 {
        self.abs / self.n.max(1) as f64
    }

    fn mean_square(&self) -> f64 {
        self.sq / self.within.max(1) as f64
    }
}

/// One pass over `x`: the sums of the short window's residuals and (with `both`) the long
/// one's, each trimmed at its limit. Not inlined: one copy serves the three passes.
#[inline(never)]
fn residual_sums(x: &[f32], both: bool, limits: [f32; 2]) -> [ResidualSums; 2] {
    let short = SG_5.sides.len();
    let half = if both { SG_17.sides.len() } else { short };
    let mut sums = [ResidualSums::default(); 2];
    for (i, w) in x.windows(2 * half + 1).enumerate() {
        sums[0].add(SG_5.at(&w[half - short..=half + short]), limits[0]);
        if both {
            sums[1].add(SG_17.at(w), limits[1]);
        }
        if i % NOISE_BLOCK == NOISE_BLOCK - 1 {
            sums[0].flush();
            sums[1].flush();
        }
    }
    sums[0].flush();
    sums[1].flush();
    sums
}

#[cfg(test)]
mod tests {
    use super::*;

    extern crate std;
    use std::vec::Vec;

    const DT: f64 = 5e-4;

    /// `n` samples of `signal(t)` plus white noise of `sigma`: the record and the realised
    /// noise's RMS.
    fn white(n: usize, sigma: f32, seed: u64, signal: impl Fn(f64) -> f64) -> (Vec<f32>, f64) {
        let mut rng = crate::rng::seeded(seed);
        let e: Vec<f32> = (0..n)
            .map(|_| sigma * crate::rng::normal(&mut rng))
            .collect();
        let x = (0..n)
            .map(|k| (signal(k as f64 * DT) + e[k] as f64) as f32)
            .collect();
        (x, rms(e.iter().map(|v| *v as f64)))
    }

    fn rms(v: impl Iterator<Item = f64>) -> f64 {
        let (s, n) = v.fold((0.0, 0usize), |(s, n), x| (s + x * x, n + 1));
        libm::sqrt(s / n as f64)
    }

    /// A smooth rise to 300 rad/s (time constant 50 ms).
    fn rise(t: f64) -> f64 {
        300.0 * (1.0 - libm::exp(-t / 0.05))
    }

    /// Steps every 250 samples (a current's jumps at voltage steps), each settling in 5 ms.
    fn steps(t: f64) -> f64 {
        let levels = [0.0, 12.0, -4.0, 8.0, 30.0, 2.0, -20.0, 5.0];
        let k = (t / DT).round() as usize;
        let (i, within) = (k / 250, (k % 250) as f64 * DT);
        let (from, to) = (levels[i % 8], levels[(i + 1) % 8]);
        to + (from - to) * libm::exp(-within / 0.005) * 0.3
    }

    /// An encoder of `lines` lines read at 2 kHz on a shaft at angle `theta(t)`: the count
    /// difference over each sample over `dt`, and the RMS of the reading minus the mean
    /// speed over the sample (the reading error).
    fn encoder(n: usize, lines: u32, offset: f64, theta: impl Fn(f64) -> f64) -> (Vec<f32>, f64) {
        let c = core::f64::consts::TAU / (4 * lines) as f64;
        let count = |k: usize| libm::floor(theta(k as f64 * DT) / c + offset);
        let x: Vec<f32> = (1..n)
            .map(|k| ((count(k) - count(k - 1)) * c / DT) as f32)
            .collect();
        let err = (1..n).map(|k| {
            let mean = (theta(k as f64 * DT) - theta((k - 1) as f64 * DT)) / DT;
            x[k - 1] as f64 - mean
        });
        let truth = rms(err);
        (x, truth)
    }

    fn check(name: &str, est: f32, truth: f64, tol: f64) {
        let ratio = est as f64 / truth;
        std::eprintln!("{name}: estimate {est:.4} truth {truth:.4} ratio {ratio:.3}");
        assert!((ratio - 1.0).abs() < tol, "{name}: {est} vs {truth}");
    }

    #[test]
    fn noise_sigma_recovers_white_noise_on_a_smooth_signal() {
        let (x, truth) = white(20_000, 0.5, 7, |t| 100.0 * (1.0 - libm::exp(-t * 2.0)));
        check("white, long exponential", noise_sigma(&x), truth, 0.02);
        for seed in 1..=5 {
            let (x, truth) = white(2000, 0.5, seed, rise);
            check("white, rise", noise_sigma(&x), truth, 0.1);
            let (x, truth) = white(2000, 0.5, seed, |t| {
                200.0 * libm::sin(core::f64::consts::TAU * 10.0 * t)
            });
            check("white, 10 Hz sine", noise_sigma(&x), truth, 0.1);
        }
    }

    #[test]
    fn noise_sigma_on_records_shorter_than_the_long_window_uses_the_short_one() {
        let (x, _) = white(16, 0.5, 2, rise);
        let short = noise_sigma(&x);
        assert!(short > 0.1 && short < 2.0, "{short}");
        let five = noise_sigma(&x[..5]);
        assert!(five > 0.0 && five.is_finite(), "{five}");
        assert_eq!(noise_sigma(&x[..4]), 0.0);
    }

    #[test]
    fn noise_sigma_recovers_white_noise_on_steps() {
        for seed in 1..=5 {
            let (x, truth) = white(2000, 0.05, seed, steps);
            check("white, steps", noise_sigma(&x), truth, 0.1);
        }
    }

    #[test]
    fn noise_sigma_reads_an_encoders_quantisation() {
        // 1024 lines at 2 kHz: q = 3.07 rad/s, reading error RMS about q / sqrt(6) = 1.25.
        for (i, offset) in [0.1, 0.5, 0.83].into_iter().enumerate() {
            // A ramp from 20 to 400 rad/s over a second, and a 5 Hz sine of 200 rad/s
            // around 50 rad/s.
            let (x, truth) = encoder(2000, 1024, offset, |t| 20.0 * t + 190.0 * t * t);
            check("encoder, ramp", noise_sigma(&x), truth, 0.2);
            let w = core::f64::consts::TAU * (5.0 + i as f64);
            let (x, truth) = encoder(2000, 1024, offset, |t| {
                50.0 * t + 200.0 * (1.0 - libm::cos(w * t)) / w
            });
            check("encoder, sine", noise_sigma(&x), truth, 0.2);
        }
    }

    /// Leakage of a sinusoid of amplitude `amp` at `f` cycles per sample through the fourth
    /// difference, normalised by its white-noise gain: `amp^2 / 2 (2 sin(pi f))^8 / 70`.
    fn fourth_difference_leak(amp: f64, f: f64) -> f64 {
        amp * amp / 2.0 * libm::pow(2.0 * libm::sin(core::f64::consts::PI * f), 8.0) / 70.0
    }

    #[test]
    fn noise_sigma_on_a_tacho_ripple_reads_the_noise_while_the_ripple_is_slow() {
        // A tacho reading w (1 + 2 % sin(cycles theta)) plus white noise of 0.5 rad/s, on a
        // rise to 300 rad/s in 20 ms (then a plateau): the ripple is 6 rad/s, twelve times
        // the noise, at f = cycles 300 dt / 2 pi = 0.024 cycles per sample per cycle per
        // revolution. A ripple is signal to a difference filter only while it is slow: up to
        // f = 0.15 (6 cycles here), the fourth difference lets through less than a tenth of
        // the noise's variance and the estimate is within 20 % of the noise; above, no
        // filter of the record alone tells a ripple near Nyquist from noise (the fit's
        // tacho_ripple effect models it), and the estimate follows the fourth difference's
        // predicted leakage.
        let tau = 0.02;
        let speed = |t: f64| 300.0 * (1.0 - libm::exp(-t / tau));
        let angle = |t: f64| 300.0 * (t - tau * (1.0 - libm::exp(-t / tau)));
        for cycles in [1.0, 2.0, 4.0, 6.0, 8.0, 12.0] {
            let (x, truth) = white(2000, 0.5, 3, |t| {
                speed(t) * (1.0 + 0.02 * libm::sin(cycles * angle(t)))
            });
            let est = noise_sigma(&x);
            let f = cycles * 300.0 * DT / core::f64::consts::TAU;
            if f <= 0.15 {
                check(&std::format!("ripple f = {f:.3}"), est, truth, 0.2);
            } else {
                let predicted = libm::sqrt(truth * truth + fourth_difference_leak(6.0, f));
                check(
                    &std::format!("ripple f = {f:.3} (predicted)"),
                    est,
                    predicted,
                    0.15,
                );
            }
        }
    }
}
