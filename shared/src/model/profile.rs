//! Excitation profiles for simulation and for the board's commissioning experiment: the
//! operating conditions of paper's Section 6 (starting, load change, speed change) plus a
//! reversal. Each is a pure function of time, so no buffer is needed.

use crate::model::params::ModelParams;
use crate::param_id::ParamId;

/// The experiments of paper's Section 6, plus a reversal.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Profile {
    /// Voltage step from rest at t = 0 (paper's Fig. 9, 11).
    Start,
    /// Start at half voltage, step up to full at 1/3, down to a quarter at 2/3 (paper
    /// Fig. 13-14: positive and negative voltage change).
    Steps,
    /// Start at full voltage; known load torque step at half time (paper's Fig. 12).
    Load,
    /// Full voltage, reversed to minus full voltage at half time.
    Reversal,
}

impl Profile {
    /// All profiles.
    pub const ALL: [Profile; 4] = [
        Profile::Start,
        Profile::Steps,
        Profile::Load,
        Profile::Reversal,
    ];

    /// Name on the command line.
    pub const fn name(self) -> &'static str {
        match self {
            Profile::Start => "start",
            Profile::Steps => "steps",
            Profile::Load => "load",
            Profile::Reversal => "reversal",
        }
    }

    /// Parse a name.
    pub fn from_name(name: &str) -> Option<Profile> {
        Profile::ALL.iter().copied().find(|p| p.name() == name)
    }

    /// Number of segments in which the motor should settle.
    pub const fn segments(self) -> u32 {
        match self {
            Profile::Start => 1,
            Profile::Steps => 3,
            Profile::Load | Profile::Reversal => 2,
        }
    }
}

/// A profile with its amplitudes and length.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Experiment {
    /// Which profile.
    pub profile: Profile,
    /// Full armature voltage [V].
    pub voltage: f32,
    /// Length [s].
    pub duration: f32,
    /// Load torque of the load step [N m].
    pub load_torque: f32,
}

/// Input at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Input {
    /// Armature voltage [V].
    pub v: f32,
    /// Known load torque [N m].
    pub tl: f32,
}

impl Experiment {
    /// Input at time `t`.
    pub fn at(&self, t: f32) -> Input {
        let x = t / self.duration;
        let v = self.voltage;
        match self.profile {
            Profile::Start => Input { v, tl: 0.0 },
            Profile::Steps => {
                let v = if x < 1.0 / 3.0 {
                    0.5 * v
                } else if x < 2.0 / 3.0 {
                    v
                } else {
                    0.25 * v
                };
                Input { v, tl: 0.0 }
            }
            Profile::Load => Input {
                v,
                tl: if x < 0.5 { 0.0 } else { self.load_torque },
            },
            Profile::Reversal => Input {
                v: if x < 0.5 { v } else { -v },
                tl: 0.0,
            },
        }
    }

    /// True when the profile applies a known load torque (the record gets a `tl` column).
    pub fn has_load(&self) -> bool {
        self.profile == Profile::Load
    }
}

/// Slowest time constant of the linear motor [s]: `1 / |slow pole|` of paper Eq. 6.
pub fn slowest_time_constant(p: &ModelParams) -> f32 {
    let (ra, la, j, b, kv) = (
        p.get(ParamId::Ra) as f64,
        p.get(ParamId::La) as f64,
        p.get(ParamId::J) as f64,
        p.get(ParamId::B) as f64,
        p.get(ParamId::Kv) as f64,
    );
    // Denominator La J s^2 + (Ra J + La B) s + (Ra B + Kv^2).
    let a2 = la * j;
    let a1 = ra * j + la * b;
    let a0 = ra * b + kv * kv;
    let disc = a1 * a1 - 4.0 * a2 * a0;
    let slow = if disc >= 0.0 {
        // Smaller-magnitude real root, without cancellation: 2 a0 / (a1 + sqrt(disc)).
        2.0 * a0 / (a1 + libm::sqrt(disc))
    } else {
        a1 / (2.0 * a2)
    };
    (1.0 / slow) as f32
}

/// A duration that lets the motor settle in every segment: 5 slowest time constants each.
pub fn settling_duration(p: &ModelParams, profile: Profile) -> f32 {
    5.0 * slowest_time_constant(p) * profile.segments() as f32
}

/// A load step of 20 % of the stall torque `Kv V / Ra` (paper Eq. 1-4 at standstill).
pub fn default_load_torque(p: &ModelParams, voltage: f32) -> f32 {
    0.2 * p.get(ParamId::Kv) * voltage.abs() / p.get(ParamId::Ra)
}
