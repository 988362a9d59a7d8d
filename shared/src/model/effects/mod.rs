//! The catalogue of unmodelled effects: one entry ([`EffectSpec`]) per effect, in a file of
//! its own, holding the effect's stable name (`docs/CONTRACTS.md`), its physics, its
//! parameters with units and ranges, the search bounds a fit gives them, its term in the
//! model step, and the signature its absence leaves in a residual (for the diagnosis).
//!
//! Adding an effect: a file here with its entry, its row in the table of parameters and
//! effects ([`crate::catalogue`]: the entry's variant, its module and its parameters, which
//! generate [`ParamId`], [`Effect`] and [`CATALOGUE`]), and its tests. The entry's
//! [`Role`] tells the simulator where it acts: an effect that adds held inputs (a voltage,
//! a load torque) needs nothing more; one that acts in a way the simulator does not know
//! yet (a new dead zone, a reading's shape, a state of its own) is a new role, written once
//! in [`crate::model::sim`]. The compile-time checks below catch an entry whose spec and
//! row differ.

pub mod entry;
pub mod friction;
pub mod regime;

pub use entry::{
    EffectBounds, EffectSpec, Held, HeldInputs, Limit, Role, Scales, Signature, SignatureSample,
    StepState,
};

use crate::capacity::MODEL_PARAMS;
use crate::model::params::{ModelParams, MOTOR_SPECS};
use crate::param_id::{ParamId, ParamSpec, PARAM_COUNT};

/// The entries' modules, [`Effect`], [`CATALOGUE`] and the parameters each row lists, from
/// the table's rows.
macro_rules! effect_list {
    (
        motor [$($(#[$motor_doc:meta])* $motor:ident),*]
        entries [$(
            $(#[$entry_doc:meta])* $entry:ident $module:ident [$($(#[$doc:meta])* $param:ident),*]
        )*]
    ) => {
        $(pub mod $module;)*

        /// One effect that the linear model of paper Eq. 5 lacks.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        #[cfg_attr(feature = "defmt", derive(defmt::Format))]
        pub enum Effect {
            $($(#[$entry_doc])* $entry,)*
        }

        /// The catalogue, in the order of [`Effect`].
        pub const CATALOGUE: [&EffectSpec; EFFECT_COUNT] = [$(&$module::SPEC,)*];

        /// Every effect, in the table's order.
        const LISTED: &[Effect] = &[$(Effect::$entry,)*];

        /// The parameters each row of the table lists.
        const ROW_PARAMS: &[&[ParamId]] = &[$(&[$(ParamId::$param),*],)*];
    };
}

crate::catalogue::catalogue_table!(effect_list);

/// Number of entries in the catalogue.
pub const EFFECT_COUNT: usize = LISTED.len();

// Each entry's spec adds exactly the parameters its row of the table lists, in order.
const _: () = {
    let mut e = 0;
    while e < EFFECT_COUNT {
        let (spec, row) = (CATALOGUE[e].ids, ROW_PARAMS[e]);
        assert!(
            spec.len() == row.len(),
            "an entry's spec and its row differ"
        );
        let mut k = 0;
        while k < row.len() {
            assert!(
                spec[k] as usize == row[k] as usize,
                "an entry's spec and its row differ"
            );
            k += 1;
        }
        e += 1;
    }
};

impl Effect {
    /// The whole catalogue.
    pub const ALL: [Effect; EFFECT_COUNT] = crate::catalogue::listed(LISTED);

    /// Its entry.
    pub const fn spec(self) -> &'static EffectSpec {
        CATALOGUE[self as usize]
    }

    /// Stable name (`docs/CONTRACTS.md`).
    pub const fn name(self) -> &'static str {
        self.spec().name
    }

    /// Parse a stable name.
    pub fn from_name(name: &str) -> Option<Effect> {
        Effect::ALL.iter().copied().find(|e| e.name() == name)
    }

    /// The effect this one extends (its parameters are part of this one's model).
    pub fn parent(self) -> Option<Effect> {
        self.spec().extends.and_then(Effect::from_name)
    }

    /// The entry whose form this one's becomes as its [`Limit`] parameter falls to its
    /// search floor, with that parameter.
    pub fn limit(self) -> Option<(Effect, ParamId)> {
        let l = self.spec().limit?;
        Effect::from_name(l.entry).map(|e| (e, l.param))
    }

    /// It acts on the current channel only (records without current cannot show it).
    pub const fn needs_current(self) -> bool {
        self.spec().needs_current
    }

    /// The parameters this effect adds. The first one switches the effect on (non-zero).
    pub const fn params(self) -> &'static [ParamId] {
        self.spec().ids
    }

    /// Search bounds of this effect's parameters for motor `p` in an experiment of `s`
    /// (each entry says why its range), never empty (`hi > lo`).
    pub fn bounds(self, p: &ModelParams, s: &Scales) -> EffectBounds {
        let mut out = (self.spec().search_bounds)(p, s);
        for b in out.iter_mut() {
            b.2 = b.2.max(b.1 + f32::EPSILON);
        }
        out
    }
}

/// Every parameter's spec, at its [`ParamId::index`]: the motor's, then each entry's.
const SPECS: [ParamSpec; PARAM_COUNT] = {
    let mut out = [MOTOR_SPECS[0]; PARAM_COUNT];
    let mut filled = [false; PARAM_COUNT];
    let mut k = 0;
    while k < MOTOR_SPECS.len() {
        out[MOTOR_SPECS[k].id as usize] = MOTOR_SPECS[k];
        filled[MOTOR_SPECS[k].id as usize] = true;
        k += 1;
    }
    let mut e = 0;
    while e < CATALOGUE.len() {
        let params = CATALOGUE[e].params;
        let mut j = 0;
        while j < params.len() {
            let id = params[j].id as usize;
            assert!(!filled[id], "a parameter belongs to two entries");
            out[id] = params[j];
            filled[id] = true;
            j += 1;
        }
        e += 1;
    }
    let mut i = 0;
    while i < PARAM_COUNT {
        assert!(filled[i], "a parameter of ParamId has no spec");
        i += 1;
    }
    out
};

/// One field of every parameter's spec, at its [`ParamId::index`]: a table of its own, so
/// that a build links only the fields it reads (a board validates ranges; it prints no name).
macro_rules! spec_field {
    ($field:ident: $t:ty) => {{
        let mut out: [$t; PARAM_COUNT] = [SPECS[0].$field; PARAM_COUNT];
        let mut k = 0;
        while k < PARAM_COUNT {
            out[k] = SPECS[k].$field;
            k += 1;
        }
        out
    }};
}

const NAMES: [&str; PARAM_COUNT] = spec_field!(name: &str);
const KEYS: [&str; PARAM_COUNT] = spec_field!(key: &str);
const UNITS: [&str; PARAM_COUNT] = spec_field!(unit: &str);

/// One field of the spec of each parameter a build holds ([`MODEL_PARAMS`]: every one on
/// the host, a board's first six), so that a board's tables do not grow with the catalogue.
macro_rules! held_field {
    ($field:ident: $t:ty) => {{
        let mut out: [$t; MODEL_PARAMS] = [SPECS[0].$field; MODEL_PARAMS];
        let mut k = 0;
        while k < MODEL_PARAMS {
            out[k] = SPECS[k].$field;
            k += 1;
        }
        out
    }};
}

const DEFAULT_BOUNDS: [(f32, f32); MODEL_PARAMS] = held_field!(default_bounds: (f32, f32));
const PHYSICAL_RANGES: [(f32, f32); MODEL_PARAMS] = held_field!(physical_range: (f32, f32));

// A parameter a build does not hold reads its default, which its range must hold (every
// build holds the motor's five).
const _: () = {
    let mut k = MOTOR_SPECS.len();
    while k < PARAM_COUNT {
        let (lo, hi) = SPECS[k].physical_range;
        let value = ModelParams::default_of(ParamId::ALL[k]);
        assert!(lo <= value && value <= hi, "a default outside its range");
        k += 1;
    }
};

/// Each entry's role in the model step, in catalogue order (a table of its own, so that a
/// build links only what the simulator reads).
pub const ROLES: [Role; EFFECT_COUNT] = {
    let mut out = [Role::Reading; EFFECT_COUNT];
    let mut e = 0;
    while e < EFFECT_COUNT {
        out[e] = CATALOGUE[e].role;
        e += 1;
    }
    out
};

/// The entries whose role satisfies `acts`, as a bit per entry in catalogue order.
macro_rules! role_mask {
    ($acts:expr) => {{
        let mut mask = 0u32;
        let mut e = 0;
        while e < EFFECT_COUNT {
            if $acts(&ROLES[e]) {
                mask |= 1 << e;
            }
            e += 1;
        }
        mask
    }};
}

/// Entries that act on the shaft's friction (the simulator's flags read these masks
/// against the entries that are on).
pub const SHAFT_FRICTION: u32 = role_mask!(Role::shaft_friction);
/// Entries beyond what the Coulomb friction path takes.
pub const BEYOND_COULOMB: u32 = role_mask!(Role::beyond_coulomb);
/// The shaft's dead zone of Coulomb friction.
pub const SHAFT_DEAD_ZONE: u32 = role_mask!(Role::shaft_dead_zone);
const _: () = assert!(EFFECT_COUNT <= 32, "one bit per entry");

/// The parameter that switches each effect on (its first; non-zero: on), in catalogue order.
pub const SWITCHES: [ParamId; EFFECT_COUNT] = {
    let mut out = [ParamId::Tc; EFFECT_COUNT];
    let mut e = 0;
    while e < CATALOGUE.len() {
        out[e] = CATALOGUE[e].params[0].id;
        e += 1;
    }
    out
};

impl ParamId {
    /// What the model knows of this parameter.
    pub const fn spec(self) -> &'static ParamSpec {
        &SPECS[self as usize]
    }

    /// Name on the command line and in JSON.
    pub const fn name(self) -> &'static str {
        NAMES[self as usize]
    }

    /// Parse a name as printed by [`ParamId::name`].
    pub fn from_name(name: &str) -> Option<ParamId> {
        ParamId::ALL.iter().copied().find(|p| p.name() == name)
    }

    /// Unit, as printed (empty for a ratio).
    pub const fn unit(self) -> &'static str {
        UNITS[self as usize]
    }

    /// Paper's Table 1 bounds for the motor parameters; for effect parameters a default search
    /// range that a caller usually narrows to the motor at hand. (A parameter this build does
    /// not hold, [`MODEL_PARAMS`], can only read its default: its bounds are that value.)
    pub const fn default_bounds(self) -> (f32, f32) {
        match self as usize {
            k if k < MODEL_PARAMS => DEFAULT_BOUNDS[k],
            _ => self.only_default(),
        }
    }

    /// Smallest and largest physically meaningful value (inclusive). (A parameter this build
    /// does not hold, [`MODEL_PARAMS`], can only read its default: its range is that value.)
    pub const fn physical_range(self) -> (f32, f32) {
        match self as usize {
            k if k < MODEL_PARAMS => PHYSICAL_RANGES[k],
            _ => self.only_default(),
        }
    }

    /// The range of a parameter this build does not hold: its default alone.
    const fn only_default(self) -> (f32, f32) {
        let value = ModelParams::default_of(self);
        (value, value)
    }

    /// The key of this parameter after `NAME:` on the command line
    /// (`tacho_ripple:amp=0.02,cycles=8,phase=0`); the full name is accepted too.
    pub const fn short_key(self) -> &'static str {
        KEYS[self as usize]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_parameter_is_named_once_and_found_by_its_name() {
        for id in ParamId::ALL {
            assert_eq!(ParamId::from_name(id.name()), Some(id));
            assert_eq!(id.spec().id, id);
        }
        for e in Effect::ALL {
            assert_eq!(Effect::from_name(e.name()), Some(e));
            // A parent is itself in the catalogue and extends nothing.
            assert_eq!(
                e.spec().extends.is_some(),
                e.parent().is_some(),
                "{}",
                e.name()
            );
            assert!(e.parent().is_none_or(|p| p.parent().is_none()));
            // A limit is another entry, reached through one of this entry's own parameters.
            assert_eq!(
                e.spec().limit.is_some(),
                e.limit().is_some(),
                "{}",
                e.name()
            );
            if let Some((limit, param)) = e.limit() {
                assert_ne!(limit, e);
                assert!(e.params().contains(&param), "{}", e.name());
            }
        }
    }

    #[test]
    fn search_bounds_name_the_effects_own_parameters_in_its_physical_range() {
        let p = ModelParams::PAPER_MOTOR;
        let s = Scales {
            v_max: 50.0,
            omega_max: 300.0,
            current_max: 10.0,
            dt: 1e-3,
        };
        for e in Effect::ALL {
            let b = e.bounds(&p, &s);
            let ids: std::vec::Vec<ParamId> = b.iter().map(|x| x.0).collect();
            let own = e.params().to_vec();
            assert_eq!(ids, own, "{}", e.name());
            for (id, lo, hi) in b {
                let (plo, phi) = id.physical_range();
                assert!(
                    plo <= lo && lo < hi && hi <= phi,
                    "{}: {lo}..{hi}",
                    id.name()
                );
            }
        }
    }
}
