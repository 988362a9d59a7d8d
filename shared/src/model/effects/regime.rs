//! Operating regimes: classes of samples by speed, acceleration and current, each a share
//! of the records' largest magnitudes. The diagnosis says where a misfit lies by them, and
//! each catalogue entry names the one where its form shows most distinctly
//! ([`super::EffectSpec::shows_in`]): there a model with the effect must fit the records as
//! well as anywhere for the effect to be named (a stand-in that shaves the misfit elsewhere
//! leaves it there).

use super::entry::SignatureSample;

/// A class of samples.
#[derive(Clone, Copy, Debug)]
pub struct Regime {
    /// Its name in sentences.
    pub name: &'static str,
    /// Its short name (plot labels).
    pub short: &'static str,
    /// Whether a sample belongs to it.
    pub member: fn(&SignatureSample) -> bool,
}

/// Speed changing by more than a tenth of the largest acceleration.
pub const TRANSIENTS: Regime = Regime {
    name: "transients (start-up and speed changes)",
    short: "transient",
    member: |s| s.accel.abs() > 0.1 * s.accel_max,
};

/// Gaining speed below 30 % of the largest.
pub const START_UP: Regime = Regime {
    name: "start-up (gaining speed below 30 % of max)",
    short: "start-up",
    member: |s| s.omega.abs() < 0.3 * s.omega_max && s.accel * s.omega.signum() > 0.1 * s.accel_max,
};

/// Speed changing by at most a tenth of the largest acceleration.
pub const STEADY: Regime = Regime {
    name: "steady state",
    short: "steady",
    member: |s| s.accel.abs() <= 0.1 * s.accel_max,
};

/// Speed growing in magnitude.
pub const ACCELERATION: Regime = Regime {
    name: "acceleration",
    short: "accel.",
    member: |s| s.accel * s.omega.signum() > 0.1 * s.accel_max,
};

/// Speed falling in magnitude.
pub const DECELERATION: Regime = Regime {
    name: "deceleration",
    short: "decel.",
    member: |s| s.accel * s.omega.signum() < -0.1 * s.accel_max,
};

/// Under 30 % of the largest speed.
pub const LOW_SPEED: Regime = Regime {
    name: "low speed (< 30 % of max)",
    short: "low speed",
    member: |s| s.omega.abs() < 0.3 * s.omega_max,
};

/// At least 30 % of the largest speed.
pub const HIGH_SPEED: Regime = Regime {
    name: "high speed (>= 30 % of max)",
    short: "high speed",
    member: |s| s.omega.abs() >= 0.3 * s.omega_max,
};

/// Turning forwards (above 5 % of the largest speed).
pub const FORWARD: Regime = Regime {
    name: "forward rotation",
    short: "forward",
    member: |s| s.omega > 0.05 * s.omega_max,
};

/// Turning backwards (above 5 % of the largest speed).
pub const REVERSE: Regime = Regime {
    name: "reverse rotation",
    short: "reverse",
    member: |s| s.omega < -0.05 * s.omega_max,
};

/// Within 5 % of the largest speed from rest: where friction sticks and breaks away, a
/// brush drop's or a bridge's dead zone holds the current, an offset shows on a current
/// that should read zero.
pub const STANDSTILL: Regime = Regime {
    name: "near standstill",
    short: "standstill",
    member: |s| s.omega.abs() <= 0.05 * s.omega_max,
};

/// Current above 5 % of the largest.
pub const POSITIVE_CURRENT: Regime = Regime {
    name: "positive current",
    short: "i > 0",
    member: |s| s.current > 0.05 * s.current_max,
};

/// Current below -5 % of the largest.
pub const NEGATIVE_CURRENT: Regime = Regime {
    name: "negative current",
    short: "i < 0",
    member: |s| s.current < -0.05 * s.current_max,
};

/// Within 10 % of the largest current either way: where a drive that limits its current
/// holds it (starts and reversals of a voltage-driven record) and a model that does not
/// know the limit drives more, where armature reaction weakens the flux most, and where a
/// warm winding's copper loss (i² Ra) and its higher Ra show most.
pub const HIGH_CURRENT: Regime = Regime {
    name: "high current (|i| >= 90 % of max: starts, reversals)",
    short: "high |i|",
    member: |s| s.current.abs() >= 0.9 * s.current_max && s.current_max > 0.0,
};

/// Every regime, in the order the diagnosis reports them.
pub const REGIMES: [Regime; 13] = [
    TRANSIENTS,
    START_UP,
    STEADY,
    ACCELERATION,
    DECELERATION,
    LOW_SPEED,
    HIGH_SPEED,
    FORWARD,
    REVERSE,
    STANDSTILL,
    POSITIVE_CURRENT,
    NEGATIVE_CURRENT,
    HIGH_CURRENT,
];
