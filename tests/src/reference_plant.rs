//! An independent reference plant: a brushed DC motor (paper Eq. 1-5: `La di/dt = v - Ra i -
//! Kv w`, `J dw/dt = Kv i - B w - TL`) with optional effects, integrated by its own RK4 on a
//! fine substep, read by its own sensors, and written as a record CSV (`docs/CONTRACTS.md`)
//! for `motor-id identify` and `diagnose`.
//!
//! It shares no code with `motor_id_shared` (neither its simulator, its discretisation nor
//! its effect catalogue): checks of the fit or the diagnosis against data made by the
//! product's own simulator prove little, checks against this plant do.
//!
//! - [`dynamics`]: the equations and the stick-slip logic;
//! - [`sensors`]: tacho (delay, ripple), encoder, current offset, noise;
//! - [`experiments`]: input sequences;
//! - [`csv`]: reading and writing record CSVs;
//! - [`drive`]: the plant behind the device code's drive trait (commissioning).

pub mod csv;
pub mod drive;
pub mod dynamics;
pub mod experiments;
pub mod sensors;

pub use experiments::{experiment, Input, Shape};
pub use sensors::{encoder_quantum, Gaussian, Sensors, SpeedSensor};

use dynamics::Dynamics;

/// Substeps of RK4 per output sample (the voltage is held over the sample). At 2 kHz and
/// 32 substeps the step is 16 us, under a hundredth of the fastest electrical time constant
/// the tests use, so RK4's error (fifth order in the step) is far below f32 rounding.
pub const SUBSTEPS: usize = 32;

/// Motor parameters of paper Eq. 1-4 [ohm, H, kg m^2, N m s/rad, V s/rad].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motor {
    /// Armature resistance.
    pub ra: f64,
    /// Armature inductance.
    pub la: f64,
    /// Rotor inertia.
    pub j: f64,
    /// Viscous friction.
    pub b: f64,
    /// Back-EMF / torque constant.
    pub kv: f64,
}

impl Motor {
    /// The paper's identified motor.
    pub const PAPER: Motor = Motor {
        ra: 3.412,
        la: 0.0573,
        j: 0.0424,
        b: 0.00267,
        kv: 0.1604,
    };

    /// The `--motor` argument of `motor-id simulate`.
    pub fn cli(&self) -> String {
        format!(
            "ra={},la={},j={},b={},kv={}",
            self.ra, self.la, self.j, self.b, self.kv
        )
    }

    /// `[ra, la, j, b, kv]`.
    pub fn values(&self) -> [f64; 5] {
        [self.ra, self.la, self.j, self.b, self.kv]
    }

    /// Steady speed at constant voltage `v` (paper Eq. 1-4 with the derivatives at zero):
    /// `Kv v / (Ra B + Kv^2)`.
    pub fn steady_speed(&self, v: f64) -> f64 {
        self.kv * v / (self.ra * self.b + self.kv * self.kv)
    }
}

/// The effects, each off at zero (see [`dynamics`] and [`sensors`] for the formulas).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Effects {
    /// Coulomb friction torque [N m]: `tc sign(w)`.
    pub tc: f64,
    /// Static friction excess over `tc` at break-away [N m].
    pub ts: f64,
    /// Stribeck speed [rad/s]: the excess decays as `exp(-(w/ws)^2)`.
    pub ws: f64,
    /// Asymmetric friction [N m]: Coulomb torque `tc + ta` forward, `tc - ta` backward.
    pub ta: f64,
    /// Fan load: torque `kq w |w|` [N m s^2/rad^2].
    pub kq: f64,
    /// Armature reaction: `Kv_eff = Kv (1 - kar |i|)`, floored at `0.1 Kv` [1/A].
    pub kar: f64,
    /// Brush drop `vb sign(i)` [V]; no current while `|v - Kv w| <= vb`.
    pub vb: f64,
    /// Bridge dead time: voltage error `-vdt clamp(i / ib, -1, 1)` [V].
    pub vdt: f64,
    /// The current band over which the dead-time error changes sign [A].
    pub ib: f64,
    /// Current sensor offset: the reading is `i + io` [A].
    pub io: f64,
    /// Speed sensor delay [s].
    pub td: f64,
    /// Tacho ripple: reading `w (1 + amp sin(cycles theta + phase))`.
    pub ripple_amp: f64,
    /// Ripple cycles per revolution.
    pub ripple_cycles: f64,
    /// Ripple phase [rad].
    pub ripple_phase: f64,
    /// The drive's current limit [A] (0: none): it lowers the applied voltage so that
    /// |i| stays at most `imax`, while the log keeps the commanded voltage.
    pub imax: f64,
    /// Cogging (detent) torque amplitude [N m]: `cog_amp sin(cog_cycles theta + cog_phase)`
    /// against the shaft.
    pub cog_amp: f64,
    /// Cogging cycles per revolution.
    pub cog_cycles: f64,
    /// Cogging phase [rad].
    pub cog_phase: f64,
    /// Winding heating: the temperature rise per watt of copper loss at the steady state
    /// [K/W] (0: none); the resistance is `Ra (1 + 0.00393 dT)`.
    pub rth: f64,
    /// The winding's thermal time constant [s].
    pub tau_th: f64,
}

/// A run of the plant: the readings (as a record CSV holds them) and the truth.
#[derive(Clone, Debug)]
pub struct Run {
    /// The input.
    pub input: Input,
    /// Speed reading at `t_k` [rad/s] (sensor effects and noise).
    pub omega: Vec<f64>,
    /// Current reading at `t_k` [A] (offset and noise).
    pub current: Vec<f64>,
    /// True shaft speed at `t_k` [rad/s].
    pub omega_true: Vec<f64>,
    /// True armature current at `t_k` [A].
    pub current_true: Vec<f64>,
    /// True rotor angle at `t_k` [rad].
    pub theta_true: Vec<f64>,
    /// True temperature rise of the winding at `t_k` [K] (0 without heating).
    pub heat_true: Vec<f64>,
}

impl Run {
    /// True mean speed over the sample ending at `t_k` (`k >= 1`): `(theta_k - theta_k-1) / dt`.
    pub fn mean_speed(&self, k: usize) -> f64 {
        (self.theta_true[k] - self.theta_true[k - 1]) / self.input.dt
    }

    /// RMS of the speed reading against the true mean speed over each sample (from the
    /// second sample): the reading's error, the noise an estimate should find.
    pub fn speed_reading_error_rms(&self) -> f64 {
        let n = self.omega.len();
        let sum: f64 = (1..n)
            .map(|k| (self.omega[k] - self.mean_speed(k)).powi(2))
            .sum();
        (sum / (n - 1) as f64).sqrt()
    }

    /// Largest true speed magnitude.
    pub fn peak_speed(&self) -> f64 {
        self.omega_true.iter().fold(0.0, |a, w| a.max(w.abs()))
    }
}

/// Run `input` on `motor` with `effects` from rest, read by `sensors`.
pub fn run(motor: Motor, effects: Effects, sensors: Sensors, input: Input) -> Run {
    let n = input.len();
    let dt = input.dt;
    let h = dt / SUBSTEPS as f64;
    let mut plant = Dynamics::new(motor, effects);
    let mut noise = Gaussian::new(sensors.seed);
    let encoder_offset = noise.uniform();
    let mut history = sensors::History::new(h, n * SUBSTEPS + 1);
    let see = |p: &Dynamics, history: &mut sensors::History| {
        let e = &effects;
        let (w, theta) = (p.s.w, p.s.theta);
        history.push(
            sensors::tacho(w, theta, e.ripple_amp, e.ripple_cycles, e.ripple_phase),
            theta,
        );
    };
    see(&plant, &mut history);
    let mut out = Run {
        omega: Vec::with_capacity(n),
        current: Vec::with_capacity(n),
        omega_true: Vec::with_capacity(n),
        current_true: Vec::with_capacity(n),
        theta_true: Vec::with_capacity(n),
        heat_true: Vec::with_capacity(n),
        input,
    };
    for k in 0..n {
        let t = k as f64 * dt;
        let open = out.input.open_from.is_some_and(|from| k >= from);
        let s = plant.s;
        let (tacho, theta_seen) = history.at(t - effects.td);
        let speed = match sensors.speed {
            SpeedSensor::Tacho => tacho,
            SpeedSensor::Encoder { lines } => {
                let (_, before) = history.at(t - dt - effects.td);
                let counts = sensors::encoder_count(theta_seen, lines, encoder_offset)
                    - sensors::encoder_count(before, lines, encoder_offset);
                counts as f64 * encoder_quantum(lines, dt)
            }
        };
        out.omega.push(speed + sensors.noise_omega * noise.normal());
        out.current
            .push(s.i + effects.io + sensors.noise_current * noise.normal());
        out.omega_true.push(s.w);
        out.current_true.push(s.i);
        out.theta_true.push(s.theta);
        out.heat_true.push(s.heat);
        let (v, tl) = (out.input.v[k], out.input.load(k));
        for _ in 0..SUBSTEPS {
            plant.substep(v, tl, open, h);
            see(&plant, &mut history);
        }
    }
    out
}
