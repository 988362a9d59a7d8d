//! Cosine and sine of the discretisation's oscillatory modes ([`crate::model::discretise`])
//! without libm's argument reduction on a board: neither on its deepest call's stack nor in
//! its flash.

/// `(cos x, sin x)` for `x >= 0`: `x` brought within π/4 ([`reduce`]), where the
/// polynomials of [`kernel_cos`] and [`kernel_sin`] hold, then turned by `n` quarter turns.
/// Below `1.5e6` rad (every argument the benchmarks, the blind checks and the lab reach) the
/// result is the one libm's `cos` and `sin` of the same remainder gave, to the bit (libm
/// evaluates the same polynomials there); above, the phase is off by up to `x 2^-53` rad
/// (1e-7 rad at 1e9 rad a step, a mode that has long decayed within the step of any
/// record). libm's own exact reduction (`rem_pio2`, with its large-argument tables), which
/// backed the arguments beyond `1.5e6`, held 832 bytes of a board's stack at the bottom of
/// its deepest call; without it and libm's `cos` and `sin`, the board's flash is 4.9 KB
/// smaller in all (docs/measurements/footprint.md). NaN from `2^40` (1.1e12 rad a step) on,
/// where the phase would be off by more than 1e-4 rad: no motor's mode (the seed paper's
/// box reaches some 600 rad/s), and a simulation with such a mode fails
/// ([`crate::model::discretise`] refuses coefficients that are not finite), where libm's
/// exact phase had given it one.
pub(crate) fn cos_sin(x: f64) -> (f64, f64) {
    debug_assert!(x >= 0.0 || x.is_nan(), "cos_sin takes x >= 0, not {x}");
    const NO_PHASE: f64 = 1_099_511_627_776.0; // 2^40
    if x.is_nan() || x >= NO_PHASE {
        return (f64::NAN, f64::NAN);
    }
    let (n, r) = reduce(x);
    let (c, s) = (kernel_cos(r), kernel_sin(r));
    match n % 4 {
        0 => (c, s),
        1 => (-s, c),
        2 => (-c, -s),
        _ => (s, -c),
    }
}

/// `x >= 0` as `n π/2 + r` with `n` the nearest multiple and `|r|` within π/4 (and its
/// rounding): π/2 in two parts, its first 33 bits and the rest, so that `n` times the first
/// is exact for `n < 2^20` (Cody and Waite); beyond, that product is rounded.
fn reduce(x: f64) -> (u64, f64) {
    // π/2's first 33 bits (1.5707963267341256), and π/2 less those (6.0771005065061922e-11).
    const PIO2_HI: f64 = f64::from_bits(0x3FF9_21FB_5440_0000);
    const PIO2_LO: f64 = f64::from_bits(0x3DD0_B461_1A62_6331);
    let n = libm::round(x * core::f64::consts::FRAC_2_PI);
    (n as u64, (x - n * PIO2_HI) - n * PIO2_LO)
}

/// A kernel's polynomial coefficients from their bits, as fdlibm gives them (exact).
const fn coefficients(bits: [u64; 6]) -> [f64; 6] {
    let mut c = [0.0; 6];
    let mut k = 0;
    while k < 6 {
        c[k] = f64::from_bits(bits[k]);
        k += 1;
    }
    c
}

/// The high word of `|x|`'s bits: what the kernels' small-argument thresholds compare.
fn high_word(x: f64) -> u32 {
    ((x.to_bits() >> 32) as u32) & 0x7fff_ffff
}

/// `cos x` for `|x| <= π/4`: the minimax polynomial of fdlibm's `__kernel_cos` (Sun
/// Microsystems, 1993; its coefficients and its evaluation order, as libm's `cos` uses it
/// there), `1 - x^2/2 + x^4 (C1 + x^2 C2 + ... + x^10 C6)` with `1 - x^2/2` summed so that
/// its rounding error is kept; exactly 1 below `2^-27 sqrt 2`, as libm.
fn kernel_cos(x: f64) -> f64 {
    // 4.1667e-2, -1.3889e-3, 2.4802e-5, -2.7557e-7, 2.0876e-9, -1.1360e-11 (fdlibm's bits).
    const C: [f64; 6] = coefficients([
        0x3FA5_5555_5555_554C,
        0xBF56_C16C_16C1_5177,
        0x3EFA_01A0_19CB_1590,
        0xBE92_7E4F_809C_52AD,
        0x3E21_EE9E_BDB4_B1C4,
        0xBDA8_FAE9_BE88_38D4,
    ]);
    if high_word(x) < 0x3e46_a09e {
        return 1.0;
    }
    let z = x * x;
    let w = z * z;
    let r = z * (C[0] + z * (C[1] + z * C[2])) + w * w * (C[3] + z * (C[4] + z * C[5]));
    let hz = 0.5 * z;
    let one_less = 1.0 - hz;
    one_less + (((1.0 - one_less) - hz) + z * r)
}

/// `sin x` for `|x| <= π/4`: the minimax polynomial of fdlibm's `__kernel_sin` (as
/// [`kernel_cos`]), `x + x^3 (S1 + x^2 S2 + ... + x^10 S6)`; `x` itself below `2^-26`, as libm.
fn kernel_sin(x: f64) -> f64 {
    // -1.6667e-1, 8.3333e-3, -1.9841e-4, 2.7557e-6, -2.5051e-8, 1.5897e-10 (fdlibm's bits).
    const S: [f64; 6] = coefficients([
        0xBFC5_5555_5555_5549,
        0x3F81_1111_1110_F8A6,
        0xBF2A_01A0_19C1_61D5,
        0x3EC7_1DE3_57B1_FE7D,
        0xBE5A_E5E6_8A2B_9CEB,
        0x3DE5_D93A_5ACF_D57C,
    ]);
    if high_word(x) < 0x3e50_0000 {
        return x;
    }
    let z = x * x;
    let w = z * z;
    let r = S[1] + z * (S[2] + z * S[3]) + z * w * (S[4] + z * S[5]);
    x + z * x * (S[0] + z * r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A deterministic sweep of `[-π/4, π/4]`: every sign and exponent the reduction's
    /// remainders take, and the arguments around the kernels' small-argument thresholds
    /// (where `sin`'s matters; `cos`'s gives the polynomial's own value).
    fn eighth_turn() -> impl Iterator<Item = f64> {
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut draw = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f64 / (1u64 << 53) as f64
        };
        // A mantissa uniform in [1/2, 1) times a power of two down to 2^-70: every exponent
        // as often as the next.
        let random = (0..200_000).map(move |k| {
            let scale = libm::exp2(-70.0 * draw());
            let x = core::f64::consts::FRAC_PI_4 * scale * (0.5 + 0.5 * draw());
            if k % 2 == 0 {
                x
            } else {
                -x
            }
        });
        let thresholds = [0x3e46_a09e_0000_0000u64, 0x3e50_0000_0000_0000]
            .into_iter()
            .flat_map(|b| [b - 1, b, b + 1].map(f64::from_bits));
        let edges = [0.0, core::f64::consts::FRAC_PI_4, f64::MIN_POSITIVE, 1e-300];
        random.chain(thresholds).chain(edges).flat_map(|x| [x, -x])
    }

    #[test]
    fn on_the_remainders_of_the_reduction_the_kernels_are_libms_to_the_bit() {
        // What `cos_sin` evaluated before: libm's `cos` and `sin` of the remainder, which
        // may lie just beyond π/4; arguments near odd multiples of π/4 among them.
        for k in 0..200_000u32 {
            let spread = 1.5e6 * (f64::from(k) / 200_000.0);
            let odd_eighth = (2.0 * f64::from(k % 1000) + 1.0) * core::f64::consts::FRAC_PI_4;
            for x in [spread, odd_eighth, f64::from_bits(odd_eighth.to_bits() + 1)] {
                let (_, r) = reduce(x);
                assert_eq!(kernel_cos(r).to_bits(), libm::cos(r).to_bits(), "cos {x}");
                assert_eq!(kernel_sin(r).to_bits(), libm::sin(r).to_bits(), "sin {x}");
            }
        }
    }

    #[test]
    fn the_kernels_are_libms_to_the_bit_within_an_eighth_turn() {
        for x in eighth_turn() {
            assert_eq!(kernel_cos(x).to_bits(), libm::cos(x).to_bits(), "cos {x:e}");
            assert_eq!(kernel_sin(x).to_bits(), libm::sin(x).to_bits(), "sin {x:e}");
        }
    }

    #[test]
    fn beyond_the_exact_reduction_the_phase_is_off_by_at_most_the_arguments_spacing() {
        for k in 0..=2000 {
            // From 1.5e6 to just under 2^40.
            let x = 1.5e6 * 7.3e5f64.powf(k as f64 / 2000.0) + 0.3;
            let (c, s) = cos_sin(x);
            let (cr, sr) = (libm::cos(x), libm::sin(x));
            // The phase is off by up to x 2^-53 rad, the polynomials by a few ulp.
            let bound = x * f64::EPSILON / 2.0 + 4.0 * f64::EPSILON;
            assert!((c - cr).abs() <= bound && (s - sr).abs() <= bound, "{x}");
        }
        for x in [1_099_511_627_776.0, 1e300, f64::INFINITY, f64::NAN] {
            let (c, s) = cos_sin(x);
            assert!(c.is_nan() && s.is_nan(), "{x}");
        }
    }

    #[test]
    fn cos_sin_is_libm_within_an_eighth_turn_and_close_beyond() {
        for k in 0..=2000 {
            // Up to π/4: libm's own values, to the bit.
            let x = k as f64 / 2000.0 * core::f64::consts::FRAC_PI_4;
            assert_eq!(cos_sin(x), (libm::cos(x), libm::sin(x)), "{x}");
            // Beyond, up to 1e5 rad: within 1e-15 of 1 and 4 ulp of the value (the rest of
            // the first reduction term is 8e-28 rad a quarter turn).
            let x = 1e5f64.powf(k as f64 / 2000.0) + 0.7;
            let (c, s) = cos_sin(x);
            let (cr, sr) = (libm::cos(x), libm::sin(x));
            for (got, want) in [(c, cr), (s, sr)] {
                let err = (got - want).abs();
                assert!(
                    err <= 1e-15_f64.max(4.0 * f64::EPSILON * want.abs()),
                    "{x}: {got} {want}"
                );
            }
        }
    }
}
