//! Exact zero-order-hold discretisation of the linear part of paper Eq. 5.
//!
//! With state `x = [i, w]` and inputs held over one step `dt`,
//! `x(k+1) = x(k) + D x(k) + gv * v + gt * tl`, where `D = e^{A dt} - I` and
//! `[gv gt] = (integral_0^dt e^{A s} ds) Bu` (paper Eq. 5 gives `A` and `Bu`).
//! Storing `D = e^{A dt} - I` rather than `e^{A dt}` keeps slow mechanical modes exact in f32
//! (at 50 kHz a 15 s mechanical time constant gives `1 - e^{a dt}` of about 1e-6, which an
//! f32 `e^{A dt}` could not hold to better than 6 %).
//!
//! The matrix functions are evaluated in closed form from the eigenvalues of the 2x2 matrix,
//! once per candidate, in f64 (a few hundred soft-float operations on the M4F, against the
//! thousands of f32 steps of a simulation): a Taylor series when `|lambda| dt` is small, the
//! trigonometric/hyperbolic form for complex or nearly repeated eigenvalues, and divided
//! differences with `expm1` for well separated real ones (the stiff case: at 100 Hz with
//! `La/Ra = 10 us` one mode is `e^{-1000}`, which never meets an overflowing `cosh`).
//! Every parameter set with positive Ra, La, J, Kv and B >= 0 gives finite coefficients.

use crate::error::Error;
use crate::model::params::ModelParams;
use crate::model::trig;
use crate::param_id::ParamId;

/// 2x2 matrix, row major, f64.
pub(crate) type M2 = [[f64; 2]; 2];

/// Discrete-time coefficients of one parameter set at one step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Discrete {
    /// `e^{A dt} - I`.
    pub d: [[f32; 2]; 2],
    /// Response of `[i, w]` to one volt held over the step.
    pub gv: [f32; 2],
    /// Response of `[i, w]` to one newton-metre of load torque held over the step.
    pub gt: [f32; 2],
    /// Electrical-only step with the rotor held at rest: `i += ae * i + ge * v`.
    pub ae: f32,
    /// See [`Discrete::ae`].
    pub ge: f32,
    /// Mechanical-only step with no armature current: `w += am * w + gm * tl`.
    pub am: f32,
    /// See [`Discrete::am`].
    pub gm: f32,
}

/// The linear motor of paper Eq. 5 in f64: its parameters and its state matrix `A` (state
/// `[i, w]`; `Bu = [[1/La, 0], [0, -1/J]]`).
pub(crate) struct Motor {
    pub ra: f64,
    pub la: f64,
    pub j: f64,
    pub b: f64,
    pub a: M2,
}

impl Motor {
    /// The motor of `p` (its parameters checked by the caller).
    pub(crate) fn of(p: &ModelParams) -> Motor {
        let ra = p.get(ParamId::Ra) as f64;
        let la = p.get(ParamId::La) as f64;
        let j = p.get(ParamId::J) as f64;
        let b = p.get(ParamId::B) as f64;
        let kv = p.get(ParamId::Kv) as f64;
        let a = [[-ra / la, -kv / la], [kv / j, -b / j]];
        Motor { ra, la, j, b, a }
    }
}

impl Discrete {
    /// Discretise the linear motor of `p` (paper Eq. 5) at step `dt` seconds. (Not inlined:
    /// a simulator's start and its events within a step share one copy of the board's code.)
    #[inline(never)]
    pub fn new(p: &ModelParams, dt: f32) -> Result<Discrete, Error> {
        if !(dt.is_finite() && dt > 0.0) {
            return Err(Error::InvalidStep);
        }
        for id in ParamId::MOTOR {
            let v = p.get(id);
            let ok = v.is_finite() && if id == ParamId::B { v >= 0.0 } else { v > 0.0 };
            if !ok {
                return Err(Error::NonPositiveParameter(id));
            }
        }
        let Motor { ra, la, j, b, a } = Motor::of(p);
        let t = dt as f64;
        let (g, f) = exp_minus_identity_and_integral(&a, t);
        // Bu = [[1/La, 0], [0, -1/J]].
        let gv = [f[0][0] / la, f[1][0] / la];
        let gt = [-f[0][1] / j, -f[1][1] / j];
        let (ae, ge) = first_order(-ra / la, 1.0 / la, t);
        let (am, gm) = first_order(-b / j, -1.0 / j, t);
        let out = Discrete {
            d: [
                [g[0][0] as f32, g[0][1] as f32],
                [g[1][0] as f32, g[1][1] as f32],
            ],
            gv: [gv[0] as f32, gv[1] as f32],
            gt: [gt[0] as f32, gt[1] as f32],
            ae: ae as f32,
            ge: ge as f32,
            am: am as f32,
            gm: gm as f32,
        };
        let all = [
            out.d[0][0],
            out.d[0][1],
            out.d[1][0],
            out.d[1][1],
            out.gv[0],
            out.gv[1],
            out.gt[0],
            out.gt[1],
            out.ae,
            out.ge,
            out.am,
            out.gm,
        ];
        if all.iter().all(|x| x.is_finite()) {
            Ok(out)
        } else {
            Err(Error::NonPositiveParameter(ParamId::La))
        }
    }
}

impl Discrete {
    /// The increments of `[i, w]` over this step (paper Eq. 5, exact ZOH) from `(i0, w0)`
    /// with `volts` and `load` held.
    #[inline(always)]
    pub fn increments(&self, i0: f32, w0: f32, volts: f32, load: f32) -> (f32, f32) {
        let di = self.d[0][0] * i0 + self.d[0][1] * w0 + self.gv[0] * volts + self.gt[0] * load;
        let dw = self.d[1][0] * i0 + self.d[1][1] * w0 + self.gv[1] * volts + self.gt[1] * load;
        (di, dw)
    }

    /// Armature resistance Ra [ohm] behind these coefficients
    /// ([`held_rotor_resistance`] of `ae`, `ge`).
    pub fn resistance(&self) -> f32 {
        held_rotor_resistance(self.ae, self.ge)
    }

    /// The same motor's coefficients over `share` (0 to 1) of the step `dt` these were made
    /// for, `kv` its back-EMF constant: for an event within a step (a shaft that breaks
    /// away or reverses there moves for the rest of the step). The motor is recovered from
    /// the first-order coefficients ([`first_order`]): `ae = e^{-Ra dt/La} - 1` and
    /// `ge = -ae/Ra` give Ra and La; `am = e^{-B dt/J} - 1` and `gm = am/B` (`-dt/J` when
    /// B = 0) give B and J. Scaling a whole step's increments by the share instead is first
    /// order in it: on a commissioning record whose step was near La/Ra, the current just
    /// after a break-away missed by 0.13 A (3.9 mA RMS over the record, against 5 mA of
    /// noise), which biased B by several per cent once the record's noise was averaged down.
    #[inline(never)]
    pub fn over_share(&self, dt: f32, kv: f32, share: f32) -> Result<Discrete, Error> {
        let t = dt as f64;
        let (ae, ge, am, gm) = (
            self.ae as f64,
            self.ge as f64,
            self.am as f64,
            self.gm as f64,
        );
        // [`held_rotor_resistance`] in f64, as the rest of the recovery.
        let ra = -ae / ge;
        let la = -ra * t / log1p(ae);
        let (b, j) = if am == 0.0 {
            (0.0, -t / gm)
        } else {
            let b = am / gm;
            (b, -b * t / log1p(am))
        };
        let p = ModelParams::PAPER_MOTOR
            .with(ParamId::Ra, ra as f32)
            .with(ParamId::La, la as f32)
            .with(ParamId::J, j as f32)
            .with(ParamId::B, b as f32)
            .with(ParamId::Kv, kv);
        Discrete::new(&p, share * dt)
    }
}

/// Armature resistance Ra [ohm] from the held-rotor step `i += ae i + ge v` of paper Eq. 1
/// ([`Discrete::ae`], [`Discrete::ge`]): `ae = e^{-Ra dt/La} - 1` and `ge = -ae / Ra`.
pub fn held_rotor_resistance(ae: f32, ge: f32) -> f32 {
    -ae / ge
}

/// `ln(1 + x)` for `x > -1`: its series where `1 + x` would lose `x`'s digits, else `ln`
/// (libm's `log1p` would add a kilobyte of a board's flash for the rare events that ask).
fn log1p(x: f64) -> f64 {
    if x.abs() < 1e-4 {
        x * (1.0 - x * (0.5 - x / 3.0))
    } else {
        libm::log(1.0 + x)
    }
}

/// `x' = a x + b u`, exact ZOH: returns `(e^{a t} - 1, b * (e^{a t} - 1) / a)`.
pub(crate) fn first_order(a: f64, b: f64, t: f64) -> (f64, f64) {
    let em1 = libm::expm1(a * t);
    let integral = if (a * t).abs() < 1e-8 { t } else { em1 / a };
    (em1, b * integral)
}

pub(crate) fn mat_mul(x: &M2, y: &M2) -> M2 {
    [
        [
            x[0][0] * y[0][0] + x[0][1] * y[1][0],
            x[0][0] * y[0][1] + x[0][1] * y[1][1],
        ],
        [
            x[1][0] * y[0][0] + x[1][1] * y[1][0],
            x[1][0] * y[0][1] + x[1][1] * y[1][1],
        ],
    ]
}

/// `k x`.
pub(crate) fn mat_scaled(x: &M2, k: f64) -> M2 {
    [[x[0][0] * k, x[0][1] * k], [x[1][0] * k, x[1][1] * k]]
}

/// `p I + q (A - m I)`.
fn combine(p: f64, q: f64, a: &M2, m: f64) -> M2 {
    [
        [p + q * (a[0][0] - m), q * a[0][1]],
        [q * a[1][0], p + q * (a[1][1] - m)],
    ]
}

/// `(e^{At} - I, integral_0^t e^{As} ds)` of a 2x2 matrix with positive determinant.
pub(crate) fn exp_minus_identity_and_integral(a: &M2, t: f64) -> (M2, M2) {
    let mu = 0.5 * (a[0][0] + a[1][1]);
    let det = a[0][0] * a[1][1] - a[0][1] * a[1][0];
    // mu^2 - det written without the cancellation of its two large terms.
    let half_diff = 0.5 * (a[0][0] - a[1][1]);
    let disc = half_diff * half_diff + a[0][1] * a[1][0];
    let spread = libm::sqrt(disc.abs());
    let radius_t = (mu.abs() + spread) * t;
    if radius_t < 0.5 {
        return taylor(a, t);
    }
    if disc < 0.0 || spread * t < 1e-3 {
        // Complex or nearly repeated eigenvalues mu +- spread (i or 1).
        let (c, s) = if disc < 0.0 {
            let wt = spread * t;
            let (cos, sin) = trig::cos_sin(wt);
            (cos, t * sinc(wt, sin))
        } else {
            let dt_ = spread * t;
            (libm::cosh(dt_), t * sinhc(dt_))
        };
        let emt = libm::exp(mu * t);
        // e^{mu t} C - 1 without cancellation for small mu t.
        let p = libm::expm1(mu * t) * c + (c - 1.0);
        let g = combine(p, emt * s, a, mu);
        // Cayley-Hamilton: A^-1 = (tr I - A) / det.
        let tr = 2.0 * mu;
        let inv = [
            [(tr - a[0][0]) / det, -a[0][1] / det],
            [-a[1][0] / det, (tr - a[1][1]) / det],
        ];
        let f = mat_mul(&inv, &g);
        return (g, f);
    }
    // Well separated real eigenvalues: fast l2 = mu - spread, slow l1 = det / l2 (no
    // cancellation). f(A) = f(l2) I + f[l1, l2] (A - l2 I).
    let l2 = mu - spread;
    let l1 = det / l2;
    let g1 = libm::expm1(l1 * t);
    let g2 = libm::expm1(l2 * t);
    let f1 = if (l1 * t).abs() < 1e-12 { t } else { g1 / l1 };
    let f2 = g2 / l2;
    let dl = l1 - l2;
    let g = combine(g2, (g1 - g2) / dl, a, l2);
    let f = combine(f2, (f1 - f2) / dl, a, l2);
    (g, f)
}

/// Taylor series of `e^{At} - I` and its integral, for `|lambda| t < 0.5`, summed on
/// scalars. By Cayley-Hamilton every power of the 2x2 matrix `X = At` is `p_k X + q_k I`,
/// with `p_0 = 0`, `q_0 = 1` and `p_{k+1} = tr(X) p_k + q_k`, `q_{k+1} = -det(X) p_k`, so
/// `e^X - I = (sum_{k>=1} q_k / k!) I + (sum_{k>=1} p_k / k!) X` and
/// `integral_0^t e^{As} ds = t ((sum_{k>=0} q_k / (k+1)!) I + (sum_{k>=0} p_k / (k+1)!) X)`:
/// four scalar sums, a few soft-float operations a term on the M4F, where the matrix
/// series took a 2x2 product, four divisions and sixteen comparisons a term (the
/// discretisations at a stop or a break-away within a step were a fifth of a commissioning
/// fit's instructions: docs/measurements/commissioning.md). `det(X)` adds two products of
/// one sign (paper Eq. 5: `Ra B / (La J)` and `Kv^2 / (La J)`), and each coefficient is
/// its sums without cancellation (the slow mode's `g[1][1]` is `X_11 + X_10 X_01 phi_2`).
///
/// The sums stop once two terms in a row are under [`NEGLIGIBLE`] of every sum they add
/// to (each later term is smaller still, `|lambda| t < 0.5`): the result agrees with
/// [`taylor_sums`]' matrix series to a few f64 units in the last place, and the f32
/// coefficients made from it are the same (the test holds both over 3,600 motors and steps).
fn taylor(a: &M2, t: f64) -> (M2, M2) {
    let x = mat_scaled(a, t);
    let tr = x[0][0] + x[1][1];
    let det = x[0][0] * x[1][1] - x[0][1] * x[1][0];
    // The k = 0 and k = 1 terms: X^0 = I (only in the integral's sums), X^1 = X.
    let (mut p, mut q) = (1.0f64, 0.0f64);
    let (mut g_p, mut g_q) = (1.0f64, 0.0f64);
    let (mut f_p, mut f_q) = (0.5f64, 1.0f64);
    let mut negligible_before = false;
    for k in 2..=TAYLOR_TERMS as usize {
        (p, q) = (tr * p + q, -det * p);
        let (c, cf) = (INV_FACTORIAL[k], INV_FACTORIAL[k + 1]);
        let (tg_p, tg_q, tf_p, tf_q) = (p * c, q * c, p * cf, q * cf);
        g_p += tg_p;
        g_q += tg_q;
        f_p += tf_p;
        f_q += tf_q;
        let small = |term: f64, sum: f64| term.abs() <= NEGLIGIBLE * sum.abs();
        let negligible =
            small(tg_p, g_p) && small(tg_q, g_q) && small(tf_p, f_p) && small(tf_q, f_q);
        if negligible && negligible_before {
            break;
        }
        negligible_before = negligible;
    }
    // g_q I + g_p X and t (f_q I + f_p X), written out: [`combine`]'s `A - m I` would add
    // four soft-float subtractions of zero.
    let g = [
        [g_q + g_p * x[0][0], g_p * x[0][1]],
        [g_p * x[1][0], g_q + g_p * x[1][1]],
    ];
    let f = [
        [t * (f_q + f_p * x[0][0]), t * f_p * x[0][1]],
        [t * f_p * x[1][0], t * (f_q + f_p * x[1][1])],
    ];
    (g, f)
}

/// The matrix Taylor series of `e^{At} - I` and its integral over all [`TAYLOR_TERMS`]
/// (the reference [`taylor`] is held to).
#[cfg(test)]
fn taylor_sums(a: &M2, t: f64) -> (M2, M2) {
    let at = mat_scaled(a, t);
    // term_k = (At)^k / k!; g = sum_{k>=1} term_k; f = t * sum_{k>=0} term_k / (k+1).
    let mut term: M2 = [[1.0, 0.0], [0.0, 1.0]];
    let mut g: M2 = [[0.0; 2]; 2];
    let mut f: M2 = [[t, 0.0], [0.0, t]];
    for k in 1..=TAYLOR_TERMS {
        let next = mat_mul(&term, &at);
        let kf = k as f64;
        term = [
            [next[0][0] / kf, next[0][1] / kf],
            [next[1][0] / kf, next[1][1] / kf],
        ];
        let scale = t / (kf + 1.0);
        for r in 0..2 {
            for c in 0..2 {
                g[r][c] += term[r][c];
                f[r][c] += term[r][c] * scale;
            }
        }
    }
    (g, f)
}

/// Most terms of the Taylor series (`|lambda| t < 0.5`: the 24th is under 2^-100 of the
/// first).
const TAYLOR_TERMS: u32 = 24;
/// `1 / k!` for `k` = 0 to `TAYLOR_TERMS + 1`, each the f64 nearest the exact fraction (no
/// division in [`taylor`]'s terms: one costs about a hundred instructions in soft float).
#[allow(clippy::excessive_precision)]
const INV_FACTORIAL: [f64; TAYLOR_TERMS as usize + 2] = [
    1.0,
    1.0,
    0.5,
    0.16666666666666666,
    0.041666666666666664,
    0.008333333333333333,
    0.001388888888888889,
    0.0001984126984126984,
    2.48015873015873e-05,
    2.7557319223985893e-06,
    2.755731922398589e-07,
    2.505210838544172e-08,
    2.08767569878681e-09,
    1.6059043836821613e-10,
    1.1470745597729725e-11,
    7.647163731819816e-13,
    4.779477332387385e-14,
    2.8114572543455206e-15,
    1.5619206968586225e-16,
    8.22063524662433e-18,
    4.110317623312165e-19,
    1.9572941063391263e-20,
    8.896791392450574e-22,
    3.868170170630684e-23,
    1.6117375710961184e-24,
    6.446950284384474e-26,
];
/// A term of [`taylor`]'s series this small against its sum (2^-64, 2^11 under half an
/// f64 unit in the last place) changes the sum by nothing, and so does every later one,
/// each smaller still.
const NEGLIGIBLE: f64 = 5.421010862427522e-20;

/// `sin x / x` for `x >= 0`, given `sin x`.
fn sinc(x: f64, sin_x: f64) -> f64 {
    if x < 1e-4 {
        1.0 - x * x / 6.0
    } else {
        sin_x / x
    }
}

fn sinhc(x: f64) -> f64 {
    if x.abs() < 1e-4 {
        1.0 + x * x / 6.0
    } else {
        libm::sinh(x) / x
    }
}

#[cfg(test)]
#[path = "discretise_tests.rs"]
mod tests;
