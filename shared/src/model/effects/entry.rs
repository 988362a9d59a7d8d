//! The shape of a catalogue entry: what one effect tells the model, the fit and the
//! diagnosis about itself.

use super::regime::Regime;
use crate::model::params::ModelParams;
use crate::param_id::{ParamId, ParamSpec};

/// Search bounds of an effect's parameters: `(parameter, lo, hi)`.
pub type EffectBounds = heapless::Vec<(ParamId, f32, f32), 3>;

/// One entry of the catalogue.
#[derive(Clone, Copy, Debug)]
pub struct EffectSpec {
    /// Stable name (`docs/CONTRACTS.md`).
    pub name: &'static str,
    /// The physics, in one sentence.
    pub physics: &'static str,
    /// It acts on the current channel only: records without current cannot show it.
    pub needs_current: bool,
    /// The effect it extends, by name (its parameters are part of this one's model: a fit
    /// of this effect frees them too), if any.
    pub extends: Option<&'static str>,
    /// The parameters it adds; the first one switches the effect on (non-zero).
    pub params: &'static [ParamSpec],
    /// The same parameters' ids ([`ids`] of `params`).
    pub ids: &'static [ParamId],
    /// Search bounds of its parameters for motor `p` in an experiment of magnitudes `s`.
    pub search_bounds: fn(p: &ModelParams, s: &Scales) -> EffectBounds,
    /// The shape its absence leaves in the speed residual, if it has a simple one.
    pub signature: Option<Signature>,
    /// The operating regime where its form shows most distinctly ([`super::regime`]), if
    /// one does: to be named by the diagnosis, a model with it must leave the held-out
    /// misfit there near the floor on every channel, else it only stands in for a cause of
    /// another form (docs/ARCHITECTURE.md, the diagnosis's naming rules).
    pub shows_in: Option<Regime>,
    /// The entry whose form this one's becomes as one of its parameters falls to the floor
    /// of its search bounds, if any ([`Limit`]).
    pub limit: Option<Limit>,
    /// Where it acts in the model step: the simulator takes it from here.
    pub role: Role,
}

/// An entry's form tends to another entry's as its parameter `param` falls to the floor of
/// its search bounds: a bridge dead time whose band `ib` vanishes is a brush drop
/// (`-vdt clamp(i / ib, -1, 1)` tends to `-vdt sign(i)`). A fit that puts `param` there
/// shows only the limit's form, which the diagnosis then names where it fits as well
/// (docs/ARCHITECTURE.md, the diagnosis's naming rules).
#[derive(Clone, Copy, Debug)]
pub struct Limit {
    /// The limit's entry, by name.
    pub entry: &'static str,
    /// The parameter whose floor is the limit.
    pub param: ParamId,
}

/// Where an effect acts in the model step ([`crate::model::sim`]).
#[derive(Clone, Copy, Debug)]
pub enum Role {
    /// Voltage and load torque added to the step's inputs, held over the step (paper Eq. 5
    /// with the effect's terms as inputs): an entry of this role needs nothing in the
    /// simulator but its function, and the state it reads when it has one of its own
    /// ([`StepState::cogging_angle`], [`StepState::winding_rise`], kept by the host's
    /// simulator).
    HeldInputs(HeldFn),
    /// A load torque that grows with the speed, taken at the step's end and solved with the
    /// step (the fan load: held at the step's start, it swung a light rotor further each
    /// step at a coarse one until it overflowed).
    SpeedLoad,
    /// The shaft's dead zone of Coulomb friction, which the simulator's friction path takes
    /// alone.
    ShaftDeadZone,
    /// A part of the shaft's friction law beyond Coulomb's ([`super::friction`]).
    FrictionLaw,
    /// The current's dead zone (a drop that no current flows under).
    CurrentDeadZone,
    /// A lag of the tacho reading, nothing else: the fast paths push through the delay line.
    ReadingDelay,
    /// The shape of a reading (the tacho's, or the current's).
    Reading,
}

impl EffectSpec {
    /// It changes what the speed channel reads: the motor's dynamics (paper Eq. 1-4, every
    /// role but a reading's), or the speed's reading itself.
    pub const fn acts_on_speed(&self) -> bool {
        !matches!(self.role, Role::Reading) || !self.needs_current
    }

    /// It changes what the current channel reads: the motor's dynamics, or the current's
    /// reading itself (not a lag or a shape of the speed's reading).
    pub const fn acts_on_current(&self) -> bool {
        match self.role {
            Role::Reading => self.needs_current,
            Role::ReadingDelay => false,
            _ => true,
        }
    }
}

impl Role {
    /// It changes the dynamics or the readings' shape beyond what the simulator's Coulomb
    /// friction path takes (which handles a shaft's dead zone and a delayed reading alone).
    pub const fn beyond_coulomb(&self) -> bool {
        !matches!(self, Role::ShaftDeadZone | Role::ReadingDelay)
    }

    /// It is the shaft's dead zone of Coulomb friction.
    pub const fn shaft_dead_zone(&self) -> bool {
        matches!(self, Role::ShaftDeadZone)
    }

    /// It acts on the shaft's friction (its dead zone or its law).
    pub const fn shaft_friction(&self) -> bool {
        matches!(self, Role::ShaftDeadZone | Role::FrictionLaw)
    }
}

/// An effect's held inputs at the start of a step.
pub type HeldFn = fn(&Held, &StepState) -> HeldInputs;

/// The state at the start of a step that held inputs read.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepState {
    /// Armature voltage commanded over the step [V] (the record's).
    pub volts: f32,
    /// The step of paper Eq. 1 with the rotor held, `i += ae i + ge v`
    /// ([`crate::model::discretise::Discrete`]): `(ae, ge)`, whose ratio is Ra ([`StepState::ra`]).
    pub held_rotor: (f32, f32),
    /// Back-EMF / torque constant Kv [V s/rad].
    pub kv: f32,
    /// Armature current [A].
    pub current: f32,
    /// Shaft speed [rad/s].
    pub omega: f32,
    /// `cog_cycles theta`, wrapped to [-pi, pi] (the shaft angle `theta` from the record's
    /// start; 0 when cogging is off).
    pub cogging_angle: f32,
    /// The winding's temperature rise since the record's start [K] (0 when winding heating
    /// is off).
    pub winding_rise: f32,
}

impl StepState {
    /// Armature resistance Ra [ohm], from the held-rotor step
    /// ([`crate::model::discretise::held_rotor_resistance`]; computed when an entry asks,
    /// not on every step).
    pub fn ra(&self) -> f32 {
        crate::model::discretise::held_rotor_resistance(self.held_rotor.0, self.held_rotor.1)
    }
}

/// Voltage and load torque an effect adds to a step's inputs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeldInputs {
    /// Added to the armature voltage [V].
    pub volts: f32,
    /// Added to the load torque [N m].
    pub load: f32,
}

/// The effect parameters a simulator holds, from `tc` on in [`ParamId`] order.
#[derive(Clone, Copy, Debug)]
pub struct Held<'a>(pub &'a [f32]);

impl Held<'_> {
    /// Parameter `id` (0 for one not held: the effect is off).
    #[inline(always)]
    pub fn get(&self, id: ParamId) -> f32 {
        match self.0.get(id.index().wrapping_sub(ParamId::MOTOR.len())) {
            Some(v) => *v,
            None => 0.0,
        }
    }
}

/// The shape of the speed residual (measured minus model) that an effect leaves when the
/// model lacks it: the diagnosis correlates the residual with it.
#[derive(Clone, Copy, Debug)]
pub struct Signature {
    /// What it looks like, in words ("minus sign of speed").
    pub label: &'static str,
    /// Its value at one sample.
    pub at: fn(&SignatureSample) -> f64,
}

/// What a signature reads at one sample (f64: the diagnosis runs on the host).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SignatureSample {
    /// Speed [rad/s].
    pub omega: f64,
    /// Acceleration [rad/s^2].
    pub accel: f64,
    /// Armature current [A].
    pub current: f64,
    /// Largest |speed| over the records [rad/s].
    pub omega_max: f64,
    /// Largest |acceleration| over the records [rad/s^2].
    pub accel_max: f64,
    /// Largest |current| over the records [A].
    pub current_max: f64,
}

/// Magnitudes of an experiment that set the search range of effect parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scales {
    /// Largest |armature voltage| [V].
    pub v_max: f32,
    /// Largest |speed| [rad/s].
    pub omega_max: f32,
    /// Largest |current| [A] (measured, or estimated as `v_max / Ra`).
    pub current_max: f32,
    /// Sample step [s] (the smallest over the records).
    pub dt: f32,
}

impl Scales {
    /// Stall torque `Kv v_max / Ra` of motor `p` (paper Eq. 1-4 at standstill): the scale of
    /// the torque effects.
    pub fn stall_torque(&self, p: &ModelParams) -> f32 {
        p.get(ParamId::Kv) * self.v_max / p.get(ParamId::Ra)
    }
}

/// The ids of an entry's parameters, in order.
pub(crate) const fn ids<const N: usize>(specs: &[ParamSpec; N]) -> [ParamId; N] {
    let mut out = [ParamId::Ra; N];
    let mut k = 0;
    while k < N {
        out[k] = specs[k].id;
        k += 1;
    }
    out
}

/// Bounds of one parameter (for an entry's `search_bounds`).
pub(crate) fn one(id: ParamId, lo: f32, hi: f32) -> EffectBounds {
    let mut out = EffectBounds::new();
    let _ = out.push((id, lo, hi));
    out
}
