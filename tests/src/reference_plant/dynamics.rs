//! The reference plant's physics: paper Eq. 1-4 written out again, with every effect's own
//! formula, integrated by classical RK4 on a fine substep with its own stick-slip logic.
//! Nothing here comes from `motor_id_shared` (its exact-ZOH step, its held effect terms,
//! its dead zones): this is the independent side of the agreement tests.
//!
//! - paper Eq. 1 (armature): `La di/dt = v_applied - Ra i - Kv_eff w - vb sign(i)`, with
//!   `v_applied = v - vdt clamp(i / ib, -1, 1)` (bridge dead time);
//! - paper Eq. 4 (shaft): `J dw/dt = Kv_eff i - B w - friction(w) - kq w |w| - tl`, with
//!   `friction(w) = sign(w) (tc ± ta + ts exp(-(w/ws)^2))`;
//! - paper Eq. 2-3 with armature reaction: `Kv_eff = Kv max(1 - kar |i|, 0.1)`;
//! - `dtheta/dt = w` (the rotor angle, for the tacho ripple, the encoder and cogging);
//! - a current-limiting drive: `v_applied` clamped to `Kv_eff w + vb sign(i) ± Ra imax`, the
//!   voltages that hold `|i|` at `imax` (below it the current rises towards it with La/Ra);
//! - cogging: a detent torque `cog_amp sin(cog_cycles theta + cog_phase)` against the
//!   shaft, in the torque balance and in the break-away test at rest;
//! - winding heating: the resistance `Ra (1 + 0.00393 dT)` in paper Eq. 1 and in the current
//!   limit (copper's temperature coefficient at 20 °C), with the winding's temperature rise
//!   a fourth state of the RK4, `tau_th d(dT)/dt = rth i^2 Ra (1 + 0.00393 dT) - dT`, from
//!   0 at the start of a run.

use super::{Effects, Motor};

/// Copper's temperature coefficient of resistance at 20 °C [1/K] (annealed copper, IEC
/// 60028).
const COPPER_PER_KELVIN: f64 = 0.00393;

/// The plant's state: armature current [A], shaft speed [rad/s], rotor angle [rad], the
/// winding's temperature rise [K].
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct State {
    /// Armature current [A].
    pub i: f64,
    /// Shaft speed [rad/s].
    pub w: f64,
    /// Rotor angle [rad].
    pub theta: f64,
    /// The winding's temperature rise since the run's start [K] (0 without heating).
    pub heat: f64,
}

/// What is held over one substep: the inputs and the modes the stick-slip logic chose at
/// its start.
#[derive(Clone, Copy, Debug, Default)]
struct Hold {
    v: f64,
    tl: f64,
    /// No current flows: the bridge is open, or the brushes block it.
    current_blocked: bool,
    /// The shaft is held by static friction.
    shaft_stuck: bool,
    /// Direction of the current for the brush drop (+1, -1).
    current_dir: f64,
    /// Direction of motion for the friction (+1, -1).
    motion_dir: f64,
}

/// Sign with 0 for 0.
fn sign(x: f64) -> f64 {
    if x > 0.0 {
        1.0
    } else if x < 0.0 {
        -1.0
    } else {
        0.0
    }
}

/// A motor with its effects, integrating one substep at a time.
#[derive(Clone, Debug)]
pub struct Dynamics {
    m: Motor,
    e: Effects,
    /// The state.
    pub s: State,
}

impl Dynamics {
    /// At rest, no current, angle 0.
    pub fn new(m: Motor, e: Effects) -> Dynamics {
        assert!(m.ra > 0.0 && m.la > 0.0 && m.j > 0.0 && m.b >= 0.0 && m.kv > 0.0);
        assert!(
            e.ta.abs() <= e.tc,
            "asymmetric friction beyond the Coulomb torque"
        );
        assert!(
            e.ts == 0.0 || e.ws > 0.0,
            "static friction needs a Stribeck speed"
        );
        assert!(e.vdt == 0.0 || e.ib > 0.0, "dead time needs a current band");
        assert!(
            e.rth == 0.0 || e.tau_th > 0.0,
            "heating needs a thermal time constant"
        );
        Dynamics {
            m,
            e,
            s: State::default(),
        }
    }

    /// Back-EMF and torque constant with armature reaction (flux `1 - kar |i|`, floored at
    /// a tenth).
    fn kv_eff(&self, i: f64) -> f64 {
        self.m.kv * (1.0 - self.e.kar * i.abs()).max(0.1)
    }

    /// Kinetic Coulomb torque for motion in `dir`: `tc + ta` forward, `tc - ta` backward.
    fn coulomb(&self, dir: f64) -> f64 {
        self.e.tc + self.e.ta * dir
    }

    /// Torque that holds a shaft at rest against a drive in `dir`.
    fn break_away(&self, dir: f64) -> f64 {
        self.coulomb(dir) + self.e.ts
    }

    /// Sliding friction at speed `w` moving in `dir` (Stribeck: the static excess decays
    /// as `exp(-(w/ws)^2)`).
    fn friction(&self, w: f64, dir: f64) -> f64 {
        let stribeck = if self.e.ts > 0.0 {
            self.e.ts * (-(w / self.e.ws).powi(2)).exp()
        } else {
            0.0
        };
        dir * (self.coulomb(dir) + stribeck)
    }

    /// Armature voltage with the bridge's dead-time error (the sign of the current,
    /// smoothed over `ib` by the ripple).
    fn applied(&self, v: f64, i: f64) -> f64 {
        if self.e.vdt == 0.0 {
            v
        } else {
            v - self.e.vdt * (i / self.e.ib).clamp(-1.0, 1.0)
        }
    }

    /// The winding's resistance at its temperature rise `heat` [ohm].
    fn resistance(&self, heat: f64) -> f64 {
        self.m.ra * (1.0 + COPPER_PER_KELVIN * heat)
    }

    /// The bridge's voltage `v` after the drive's current limit, at state `s`.
    fn limited(&self, v: f64, s: State) -> f64 {
        if self.e.imax <= 0.0 {
            return v;
        }
        let emf = self.kv_eff(s.i) * s.w + self.e.vb * sign(s.i);
        let reach = self.resistance(s.heat) * self.e.imax;
        v.clamp(emf - reach, emf + reach)
    }

    /// The cogging torque at angle `theta` [N m].
    fn cogging(&self, theta: f64) -> f64 {
        self.e.cog_amp * (self.e.cog_cycles * theta + self.e.cog_phase).sin()
    }

    fn has_friction(&self) -> bool {
        self.e.tc > 0.0 || self.e.ts > 0.0
    }

    /// Time derivative of the state (paper Eq. 1 and 4 with the effects).
    fn derivative(&self, s: State, h: &Hold) -> State {
        let (m, e) = (&self.m, &self.e);
        let kv = self.kv_eff(s.i);
        let ra = self.resistance(s.heat);
        let di = if h.current_blocked {
            0.0
        } else {
            (self.applied(self.limited(h.v, s), s.i) - ra * s.i - kv * s.w - e.vb * h.current_dir)
                / m.la
        };
        let heat = if e.rth > 0.0 {
            (e.rth * s.i * s.i * ra - s.heat) / e.tau_th
        } else {
            0.0
        };
        let dw = if h.shaft_stuck {
            0.0
        } else {
            (kv * s.i
                - m.b * s.w
                - self.friction(s.w, h.motion_dir)
                - e.kq * s.w * s.w.abs()
                - self.cogging(s.theta)
                - h.tl)
                / m.j
        };
        State {
            i: di,
            w: dw,
            theta: s.w,
            heat,
        }
    }

    /// The modes over the next substep, from the state at its start (stick-slip logic).
    fn hold(&self, v: f64, tl: f64, open: bool) -> Hold {
        let s = self.s;
        let mut h = Hold {
            v,
            tl,
            current_dir: sign(s.i),
            motion_dir: sign(s.w),
            ..Hold::default()
        };
        if open {
            h.current_blocked = true;
        } else if self.e.vb > 0.0 && s.i == 0.0 {
            // No current flows until the driving voltage exceeds the brush drop.
            let drive = self.applied(v, 0.0) - self.kv_eff(0.0) * s.w;
            h.current_blocked = drive.abs() <= self.e.vb;
            h.current_dir = sign(drive);
        }
        if self.has_friction() && s.w == 0.0 {
            // At rest: break away only when the drive torque exceeds tc (+-ta) + ts.
            let current = if h.current_blocked { 0.0 } else { s.i };
            let drive = self.kv_eff(current) * current - tl - self.cogging(s.theta);
            let dir = sign(drive);
            h.shaft_stuck = dir == 0.0 || drive.abs() <= self.break_away(dir);
            h.motion_dir = dir;
        }
        h
    }

    /// Advance by `h` seconds with voltage `v` and load `tl` held (the bridge `open` or
    /// not): one classical RK4 step; a speed (current) that would cross zero against
    /// friction (the brush drop) stops at zero.
    pub fn substep(&mut self, v: f64, tl: f64, open: bool, dt: f64) {
        let hold = self.hold(v, tl, open);
        if open {
            self.s.i = 0.0;
        }
        let s0 = self.s;
        let at = |k: State, f: f64| State {
            i: s0.i + f * k.i,
            w: s0.w + f * k.w,
            theta: s0.theta + f * k.theta,
            heat: s0.heat + f * k.heat,
        };
        let k1 = self.derivative(s0, &hold);
        let k2 = self.derivative(at(k1, dt / 2.0), &hold);
        let k3 = self.derivative(at(k2, dt / 2.0), &hold);
        let k4 = self.derivative(at(k3, dt), &hold);
        let mut s1 = State {
            i: s0.i + dt / 6.0 * (k1.i + 2.0 * k2.i + 2.0 * k3.i + k4.i),
            w: s0.w + dt / 6.0 * (k1.w + 2.0 * k2.w + 2.0 * k3.w + k4.w),
            theta: s0.theta + dt / 6.0 * (k1.theta + 2.0 * k2.theta + 2.0 * k3.theta + k4.theta),
            heat: s0.heat + dt / 6.0 * (k1.heat + 2.0 * k2.heat + 2.0 * k3.heat + k4.heat),
        };
        if self.e.vb > 0.0 && !hold.current_blocked && sign(s1.i) != hold.current_dir {
            s1.i = 0.0;
        }
        if self.has_friction() && !hold.shaft_stuck && sign(s1.w) != hold.motion_dir {
            s1.w = 0.0;
        }
        self.s = s1;
    }
}
