//! Cosine and sine of the discretisation's oscillatory modes ([`crate::model::discretise`])
//! without libm's argument reduction on a board's deepest call.

/// `(cos x, sin x)` for `x >= 0`: `x` brought within π/4 by the nearest multiple `n` of
/// π/2 (π/2 in two parts, its first 33 bits and the rest, so that `n` times the first is exact
/// for `n < 2^20`), where libm evaluates its polynomials directly, then turned by `n`
/// quarter turns. libm's own reduction for larger arguments (`rem_pio2`) holds its
/// large-argument tables on its frame: 832 bytes of a board's stack at the bottom of its
/// deepest call (docs/measurements/footprint.md). Within π/4 the result is libm's to the
/// bit.
pub(crate) fn cos_sin(x: f64) -> (f64, f64) {
    // π/2's first 33 bits (1.5707963267341256), and π/2 less those (6.0771005065061922e-11).
    const PIO2_HI: f64 = f64::from_bits(0x3FF9_21FB_5440_0000);
    const PIO2_LO: f64 = f64::from_bits(0x3DD0_B461_1A62_6331);
    if x.is_nan() || x >= 1.5e6 {
        // Beyond the exact products (a mode a million radians a step: no fit lands there).
        return (libm::cos(x), libm::sin(x));
    }
    let n = libm::round(x * core::f64::consts::FRAC_2_PI);
    let r = (x - n * PIO2_HI) - n * PIO2_LO;
    let (c, s) = (libm::cos(r), libm::sin(r));
    match n as u32 % 4 {
        0 => (c, s),
        1 => (-s, c),
        2 => (-c, -s),
        _ => (s, -c),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

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
