//! Controller gains from identified parameters: a current-loop and a speed-loop PI in
//! cascade, each by a textbook rule, checked by simulating their step responses on the
//! identified model (with its effects).
//!
//! - Current loop, pole-zero cancellation (the *technical optimum* without its delay term,
//!   Schröder, *Elektrische Antriebe – Regelung von Antriebssystemen*, ch. 3): the PI zero
//!   cancels the armature pole, `Ti = La / Ra`, and `Kp = La wc`, so the open loop is `wc / s`
//!   (back-EMF a slow disturbance) and the closed loop a first-order lag of bandwidth `wc`:
//!   `Kp = La wc` [V/A], `Ki = Kp / Ti = Ra wc` [V/(A s)].
//! - Speed loop, symmetric optimum (Kessler 1958): the current loop as a lag
//!   `Tσ = 1 / wc`, the mechanics as the integrator `Kv / (J s)`; with `a > 1` the crossover is
//!   `w0 = 1 / (a Tσ)`, `Ti = a² Tσ`, `Kp = J / (a Kv Tσ)` [A s/rad], and the phase margin
//!   `asin((a² - 1) / (a² + 1))`: `a` follows from the asked phase margin.

use anyhow::{bail, Result};
use motor_id_shared::model::sim::{InitialState, Simulator};
use motor_id_shared::{ModelParams, ParamId};
use serde::Serialize;

/// A PI controller's gains and its design.
#[derive(Serialize, Debug, Clone, Copy, PartialEq)]
pub struct PiGains {
    /// Proportional gain (current loop: V/A; speed loop: A s/rad).
    pub kp: f64,
    /// Integral gain (current loop: V/(A s); speed loop: A/rad).
    pub ki: f64,
    /// The designed bandwidth (current loop: closed-loop -3 dB; speed loop: open-loop
    /// crossover) [Hz].
    pub bandwidth_hz: f64,
}

/// The design asked for.
#[derive(Debug, Clone, Copy)]
pub struct Design {
    /// Current-loop bandwidth [Hz].
    pub current_bandwidth_hz: f64,
    /// Speed-loop phase margin [deg].
    pub phase_margin_deg: f64,
    /// Control (sample and PWM) rate [Hz].
    pub rate_hz: f64,
    /// Voltage limit of the bridge [V].
    pub voltage: f64,
}

/// Both loops' gains.
#[derive(Serialize, Debug, Clone, Copy)]
pub struct Gains {
    /// The current loop (pole-zero cancellation).
    pub current_loop: PiGains,
    /// The speed loop (symmetric optimum).
    pub speed_loop: PiGains,
    /// The speed loop's phase margin by design [deg].
    pub phase_margin_deg: f64,
}

/// The gains of `design` for motor `p`.
pub fn gains(p: &ModelParams, design: &Design) -> Result<Gains> {
    let (ra, la, j, kv) = (
        p.get(ParamId::Ra) as f64,
        p.get(ParamId::La) as f64,
        p.get(ParamId::J) as f64,
        p.get(ParamId::Kv) as f64,
    );
    let fc = design.current_bandwidth_hz;
    if !(fc > 0.0 && fc <= design.rate_hz / 10.0) {
        bail!(
            "--current-bandwidth must be above 0 and at most a tenth of --rate ({} Hz): a digital loop sampled at {} Hz cannot hold more",
            design.rate_hz / 10.0,
            design.rate_hz
        );
    }
    let pm = design.phase_margin_deg;
    if !(pm > 0.0 && pm < 90.0) {
        bail!("--phase-margin must be between 0 and 90 degrees");
    }
    let wc = std::f64::consts::TAU * fc;
    let current_loop = PiGains {
        kp: la * wc,
        ki: ra * wc,
        bandwidth_hz: fc,
    };
    // sin(pm) = (a² - 1) / (a² + 1)  =>  a² = (1 + sin pm) / (1 - sin pm).
    let s = pm.to_radians().sin();
    let a = ((1.0 + s) / (1.0 - s)).sqrt();
    let t_sigma = 1.0 / wc;
    let kp = j / (a * kv * t_sigma);
    let speed_loop = PiGains {
        kp,
        ki: kp / (a * a * t_sigma),
        bandwidth_hz: 1.0 / (a * t_sigma) / std::f64::consts::TAU,
    };
    Ok(Gains {
        current_loop,
        speed_loop,
        phase_margin_deg: pm,
    })
}

/// A discrete PI with its integrator held while the output saturates (anti-windup).
struct Pi {
    gains: PiGains,
    integral: f64,
    limit: f64,
}

impl Pi {
    fn new(gains: PiGains, limit: f64) -> Pi {
        Pi {
            gains,
            integral: 0.0,
            limit,
        }
    }

    /// The output for error `e` over a step `dt`.
    fn output(&mut self, e: f64, dt: f64) -> f64 {
        let u = self.gains.kp * e + self.integral;
        let clamped = u.clamp(-self.limit, self.limit);
        if u == clamped {
            self.integral += self.gains.ki * e * dt;
        }
        clamped
    }
}

/// A closed-loop step response on the model.
#[derive(Serialize, Debug, Clone)]
pub struct StepResponse {
    /// The reference step (A for the current loop, rad/s for the speed loop).
    pub reference: f64,
    /// Time to 63.2 % of the reference [s].
    pub t63_s: f64,
    /// The bandwidth a first-order lag with that rise would have, `1 / (2 pi t63)` [Hz].
    pub bandwidth_hz: f64,
    /// Largest value over the reference, as a share of it.
    pub overshoot: f64,
    /// Time [s], response and the voltage applied, one sample each.
    #[serde(skip)]
    pub trace: (Vec<f64>, Vec<f32>, Vec<f32>),
}

/// Which loop a step is given to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Loop {
    /// A current step from rest (the speed loop open).
    Current,
    /// A speed step from rest through both loops.
    Speed,
}

/// Most samples of a step response (its horizon is ten or twenty loop time constants at
/// the control rate; a tiny bandwidth would otherwise ask for terabytes).
pub const MAX_STEP_SAMPLES: usize = 2_000_000;

/// The step response of `which` loop with `gains` on motor `p` (effects included), from
/// rest, for `duration` s: a small-signal step, at most a tenth of the current limit
/// `voltage / Ra` (current loop) or of the no-load speed `voltage / Kv` (speed loop), and
/// small enough that the proportional action stays within half of the voltage limit and of
/// the current step: the loops' linear response, which the design rules describe.
pub fn step(
    p: &ModelParams,
    gains: &Gains,
    design: &Design,
    which: Loop,
    duration: f64,
) -> Result<StepResponse> {
    let dt = 1.0 / design.rate_hz;
    let mut sim = Simulator::new(p, dt as f32, InitialState::REST)
        .map_err(|e| anyhow::anyhow!("the model cannot be simulated: {e}"))?;
    let (ra, kv) = (p.get(ParamId::Ra) as f64, p.get(ParamId::Kv) as f64);
    let i_max = design.voltage / ra;
    let mut current_pi = Pi::new(gains.current_loop, design.voltage);
    let mut speed_pi = Pi::new(gains.speed_loop, i_max);
    // Small enough that the proportional action alone stays within half of each limit.
    let current_ref = (0.1 * i_max).min(0.5 * design.voltage / gains.current_loop.kp);
    let reference = match which {
        Loop::Current => current_ref,
        Loop::Speed => (0.1 * design.voltage / kv).min(0.5 * current_ref / gains.speed_loop.kp),
    };
    let samples = (duration * design.rate_hz).round();
    if samples.is_nan() || samples > MAX_STEP_SAMPLES as f64 {
        bail!(
            "the {} loop's step response would take {samples:.3e} samples (at most {MAX_STEP_SAMPLES}): raise --current-bandwidth, or lower --rate or --phase-margin",
            match which {
                Loop::Current => "current",
                Loop::Speed => "speed",
            }
        );
    }
    let n = samples as usize;
    let (mut t, mut y, mut volts) = (Vec::with_capacity(n), Vec::with_capacity(n), Vec::new());
    for k in 0..n {
        let r = sim.reading();
        let (i, w) = (r.current as f64, r.omega as f64);
        let i_ref = match which {
            Loop::Current => reference,
            Loop::Speed => speed_pi.output(reference - w, dt),
        };
        let v = current_pi.output(i_ref - i, dt);
        t.push(k as f64 * dt);
        y.push(match which {
            Loop::Current => i as f32,
            Loop::Speed => w as f32,
        });
        volts.push(v as f32);
        sim.advance(v as f32, 0.0);
    }
    let t63 = y
        .iter()
        .position(|x| *x as f64 >= 0.632 * reference)
        .map_or(f64::INFINITY, |k| t[k]);
    let peak = y.iter().fold(f64::NEG_INFINITY, |m, x| m.max(*x as f64));
    Ok(StepResponse {
        reference,
        t63_s: t63,
        bandwidth_hz: 1.0 / (std::f64::consts::TAU * t63),
        overshoot: (peak / reference - 1.0).max(0.0),
        trace: (t, y, volts),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn design() -> Design {
        Design {
            current_bandwidth_hz: 200.0,
            phase_margin_deg: 60.0,
            rate_hz: 10_000.0,
            voltage: 50.0,
        }
    }

    #[test]
    fn the_rules_give_the_textbook_gains() {
        let p = ModelParams::PAPER_MOTOR;
        let g = gains(&p, &design()).unwrap();
        let wc = std::f64::consts::TAU * 200.0;
        // The parameters are f32: agreement to f32 precision.
        let close = |a: f64, b: f64| (a / b - 1.0).abs() < 1e-6;
        assert!(close(g.current_loop.kp, 0.0573 * wc));
        assert!(close(g.current_loop.ki, 3.412 * wc));
        // 60 degrees: a = tan(75 deg) = 3.732; crossover wc / a.
        let a = 75f64.to_radians().tan();
        assert!(close(g.speed_loop.bandwidth_hz, 200.0 / a));
        assert!(close(g.speed_loop.kp, 0.0424 * wc / (a * 0.1604)));
        assert!(close(g.speed_loop.ki, g.speed_loop.kp * wc / (a * a)));
    }

    #[test]
    fn a_bandwidth_beyond_the_sampling_is_refused() {
        let d = Design {
            current_bandwidth_hz: 2000.0,
            ..design()
        };
        assert!(gains(&ModelParams::PAPER_MOTOR, &d).is_err());
    }

    #[test]
    fn the_closed_loops_meet_the_asked_bandwidth_on_the_model() {
        // The paper's motor and a fast one, with Coulomb friction on the second.
        let fast = ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08).with(ParamId::Tc, 0.01);
        for (p, fc) in [(ModelParams::PAPER_MOTOR, 200.0), (fast, 400.0)] {
            let d = Design {
                current_bandwidth_hz: fc,
                ..design()
            };
            let g = gains(&p, &d).unwrap();
            let s = step(
                &p,
                &g,
                &d,
                Loop::Current,
                10.0 / (std::f64::consts::TAU * fc),
            )
            .unwrap();
            assert!(
                (s.bandwidth_hz / fc - 1.0).abs() < 0.1,
                "{fc} Hz: {}",
                s.bandwidth_hz
            );
            assert!(s.overshoot < 0.02, "{}", s.overshoot);
            // The speed loop settles on its reference (the integral removes the error).
            let tw = 1.0 / (std::f64::consts::TAU * g.speed_loop.bandwidth_hz);
            let w = step(&p, &g, &d, Loop::Speed, 60.0 * tw).unwrap();
            let last = *w.trace.1.last().unwrap() as f64;
            assert!(
                (last / w.reference - 1.0).abs() < 0.02,
                "{last} vs {}",
                w.reference
            );
            assert!(w.overshoot < 0.4, "{}", w.overshoot);
        }
    }
}
