//! `tacho_ripple`: the tacho reading is modulated with rotor angle (commutator slots, an
//! eccentric or unevenly spaced encoder disc):
//! `w (1 + ripple_amp sin(ripple_cycles theta + ripple_phase))`. The angle follows the
//! measured speed when a fit gives it, corrected by the readings (see
//! [`crate::model::sim::Simulator::apply`]).

use super::entry::{ids, EffectBounds, EffectSpec, Role};
use crate::param_id::{ParamId, ParamSpec};

/// Its parameters.
const PARAMS: [ParamSpec; 3] = [
    ParamSpec {
        id: ParamId::RippleAmp,
        name: "ripple_amp",
        key: "amp",
        unit: "",
        default_bounds: (0.0, 0.2),
        physical_range: (0.0, 0.9),
    },
    ParamSpec {
        id: ParamId::RippleCycles,
        name: "ripple_cycles",
        key: "cycles",
        unit: "",
        default_bounds: (1.0, 64.0),
        physical_range: (0.0, 1000.0),
    },
    ParamSpec {
        id: ParamId::RipplePhase,
        name: "ripple_phase",
        key: "phase",
        unit: "rad",
        default_bounds: (0.0, core::f32::consts::TAU),
        physical_range: (-1000.0, 1000.0),
    },
];

/// The entry.
pub const SPEC: EffectSpec = EffectSpec {
    name: "tacho_ripple",
    physics: "tacho reading modulated with rotor angle: w (1 + amp sin(cycles theta + phase))",
    needs_current: false,
    extends: None,
    params: &PARAMS,
    ids: &ids(&PARAMS),
    // Up to 20 % at 1 to 64 cycles per revolution.
    search_bounds: |_, _| {
        let mut out = EffectBounds::new();
        for b in [
            (ParamId::RippleAmp, 0.0, 0.2),
            (ParamId::RippleCycles, 1.0, 64.0),
            (ParamId::RipplePhase, 0.0, core::f32::consts::TAU),
        ] {
            let _ = out.push(b);
        }
        out
    },
    // Found by the order spectrum of the residual against rotor angle, not a correlation.
    signature: None,
    shows_in: None,
    limit: None,
    role: Role::Reading,
};

/// The tacho reading of shaft speed `w` at ripple angle `psi` (`ripple_cycles theta`).
#[inline(always)]
pub fn reading(amp: f32, phase: f32, w: f32, psi: f32) -> f32 {
    if amp == 0.0 {
        w
    } else {
        w * (1.0 + amp * libm::sinf(psi + phase))
    }
}

/// The ripple angle `cycles theta` of the rotor when `read` is the integral of the tacho's
/// own readings (from 0 at the record's start, where the rotor's is 0 too). The rotor turns
/// at the true speed `w`; the reading `w (1 + amp sin(psi + phase))` integrates to
/// `psi - amp cos(psi + phase) + amp cos(phase)`, which this inverts to first order (what
/// is left: `amp^2`). Without it the angle wobbled by the ripple's share and a fit of the
/// ripple left that share of it in the residual: on the blind checks' 2 kHz records, where a
/// 2-5 % ripple dwarfs the tacho's noise, the fit stayed above the noise floor.
#[inline(always)]
pub fn rotor_angle(amp: f32, phase: f32, read: f32) -> f32 {
    read + amp * (libm::cosf(read + phase) - libm::cosf(phase))
}

/// The [`reading`] at the [`rotor_angle`] of `read`, and the reading's slope in the angle
/// (`w amp cos(angle + phase)`: what a shift of the angle moves the reading by), by one
/// sine and cosine (given
/// `cos_phase`, the cosine of `phase`, a constant of a simulation): the rotor's angle lies
/// `d = amp (cos(read + phase) - cos(phase))` past `read`, and the sine and cosine there are
/// taken to second order in `d` from those at `read` (the error, `d^3 / 6`, is under the
/// inversion's own `amp^2`).
#[inline(always)]
pub fn reading_and_slope_at_read(
    amp: f32,
    (phase, cos_phase): (f32, f32),
    w: f32,
    read: f32,
) -> (f32, f32) {
    let (s, c) = libm::sincosf(read + phase);
    let d = amp * (c - cos_phase);
    let half = 0.5 * d * d;
    let (sin, cos) = (s + d * c - half * s, c - d * s - half * c);
    (w * (1.0 + amp * sin), w * amp * cos)
}

/// The ripple angle after a step of `dt` at mean speed `rate`, wrapped to [-pi, pi] so
/// that f32 sin stays accurate on long records.
#[inline(always)]
pub fn advance(psi: f32, cycles: f32, rate: f32, dt: f32) -> f32 {
    libm::remainderf(psi + cycles * rate * dt, core::f32::consts::TAU)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reading_at_the_rotor_angle_of_a_read_angle_is_the_composition_s() {
        // Against the reading at the angle `rotor_angle` gives, by its own sine and cosine,
        // over a turn of read angles, for ripples of 5 and 20 %: within the third-order
        // term's bound, `w amp (2 amp)^3 / 6` (0.08 % and 21 % of the ripple's size).
        for amp in [0.05f32, 0.2] {
            let bound = 100.0 * amp * (2.0 * amp).powi(3) / 6.0 + 1e-4;
            for (k, phase) in [0.3f32, 2.5, -1.0].into_iter().enumerate() {
                for j in 0..64 {
                    let read = -3.1 + 0.1 * j as f32 + 0.01 * k as f32;
                    // The composition written out, in f64.
                    let x = (rotor_angle(amp, phase, read) + phase) as f64;
                    let (a, w) = (amp as f64, 100.0f64);
                    let exact = ((w * (1.0 + a * x.sin())) as f32, (w * a * x.cos()) as f32);
                    let given = (phase, libm::cosf(phase));
                    let (r, s) = reading_and_slope_at_read(amp, given, 100.0, read);
                    assert!((r - exact.0).abs() < bound, "{amp} {phase} {read}: {r} {exact:?}");
                    assert!((s - exact.1).abs() < bound, "{amp} {phase} {read}: {s} {exact:?}");
                }
            }
        }
    }

    #[test]
    fn the_rotor_angle_is_recovered_from_the_integral_of_a_rippled_reading() {
        // A shaft speeding up as 5 + 20 t rad/s for 4 s, read with a 5 % ripple at 16 per
        // revolution (phase 1 rad): the integral of the readings (trapezoid, 10 kHz) wobbles
        // about the rotor's ripple angle 16 (5 t + 10 t^2) by up to the ripple's share.
        let (amp, cycles, phase, dt) = (0.05f64, 16.0f64, 1.0f64, 1e-4f64);
        let truth = |t: f64| cycles * (5.0 * t + 10.0 * t * t);
        let read = |t: f64| (5.0 + 20.0 * t) * (1.0 + amp * (truth(t) + phase).sin());
        let (mut integral, mut worst_read, mut worst_rotor) = (0.0f64, 0.0f64, 0.0f64);
        for k in 1..40_000 {
            let (t0, t1) = ((k - 1) as f64 * dt, k as f64 * dt);
            integral += cycles * 0.5 * (read(t0) + read(t1)) * dt;
            let psi = truth(t1);
            // The distance of angle `x` from the rotor's, in [0, pi].
            let off = |x: f64| {
                let d = (x - psi).rem_euclid(core::f64::consts::TAU);
                d.min(core::f64::consts::TAU - d)
            };
            worst_read = worst_read.max(off(integral));
            let read = integral.rem_euclid(core::f64::consts::TAU) as f32;
            let rotor = rotor_angle(amp as f32, phase as f32, read) as f64;
            worst_rotor = worst_rotor.max(off(rotor));
        }
        assert!(worst_read > 0.05, "{worst_read}");
        assert!(worst_rotor < 0.01, "{worst_rotor}");
    }
}
