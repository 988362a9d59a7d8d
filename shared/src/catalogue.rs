//! The one table of the model's parameters and of the catalogue of effects: the five motor
//! parameters of paper Eq. 1-5, then each effect's entry (its [`crate::model::effects::Effect`]
//! variant, the module that holds its [`crate::model::effects::EffectSpec`], and the
//! parameters it adds, the first of which switches it on).
//!
//! Everything that lists parameters or effects is generated from this table:
//! [`crate::ParamId`] and its order (each parameter's code on the wire and in the store,
//! `docs/CONTRACTS.md`: rows are appended, never inserted), the effects' modules,
//! [`crate::model::effects::Effect`] and [`crate::model::effects::CATALOGUE`]. A
//! compile-time check holds each entry's spec to the parameters its row lists.
//!
//! The table is a macro that hands its rows to another (`catalogue_table!(callback)`), so
//! that the vocabulary ([`crate::param_id`]) and the model ([`crate::model::effects`]) each
//! take what they need without depending on each other.

/// Call `$callback!` with the table: `motor [params] entries [Variant module [params] ...]`.
macro_rules! catalogue_table {
    ($callback:ident) => {
        $callback! {
            motor [
                /// Armature resistance Ra [ohm] (paper Eq. 1).
                Ra,
                /// Armature inductance La [H] (paper Eq. 1).
                La,
                /// Rotor inertia J [kg m^2] (paper Eq. 4).
                J,
                /// Viscous friction B [N m s/rad] (paper Eq. 4).
                B,
                /// Back-EMF / torque constant Kv [V s/rad] (paper Eq. 3).
                Kv
            ]
            entries [
                /// [`coulomb_friction`].
                CoulombFriction coulomb_friction [
                    /// Coulomb friction torque [N m] (`coulomb_friction`).
                    Tc
                ]
                /// [`quadratic_load`].
                QuadraticLoad quadratic_load [
                    /// Fan/pump load coefficient [N m s^2/rad^2], torque `kq * w * |w|`
                    /// (`quadratic_load`).
                    Kq
                ]
                /// [`armature_reaction`].
                ArmatureReaction armature_reaction [
                    /// Flux weakening per ampere [1/A], flux factor `1 - kar * |i|`
                    /// (`armature_reaction`).
                    Kar
                ]
                /// [`brush_drop`].
                BrushDrop brush_drop [
                    /// Brush voltage drop [V] with the sign of the current (`brush_drop`).
                    Vb
                ]
                /// [`sensor_delay`].
                SensorDelay sensor_delay [
                    /// Tacho delay [s] (`sensor_delay`).
                    Td
                ]
                /// [`tacho_ripple`].
                TachoRipple tacho_ripple [
                    /// Relative tacho ripple amplitude [-] (`tacho_ripple`).
                    RippleAmp,
                    /// Ripple cycles per mechanical revolution [-] (`tacho_ripple`).
                    RippleCycles,
                    /// Ripple phase [rad] (`tacho_ripple`).
                    RipplePhase
                ]
                /// [`static_friction`] (extends [`coulomb_friction`]).
                StaticFriction static_friction [
                    /// Break-away excess over the Coulomb torque [N m] (`static_friction`).
                    Ts,
                    /// Stribeck speed over which the break-away excess fades [rad/s]
                    /// (`static_friction`).
                    Ws
                ]
                /// [`asymmetric_friction`] (extends [`coulomb_friction`]).
                AsymmetricFriction asymmetric_friction [
                    /// Direction asymmetry of the Coulomb torque, a fraction of it [-]:
                    /// `tc (1 + ka)` forward, `tc (1 - ka)` backward (`asymmetric_friction`).
                    Ka
                ]
                /// [`bridge_deadtime`].
                BridgeDeadtime bridge_deadtime [
                    /// Dead-time voltage error of the bridge [V] (`bridge_deadtime`).
                    Vdt,
                    /// Current band over which the dead-time error changes sign [A]
                    /// (`bridge_deadtime`).
                    Ib
                ]
                /// [`current_offset`].
                CurrentOffset current_offset [
                    /// Current sensor offset [A] (`current_offset`).
                    Io
                ]
                /// [`current_limit`].
                CurrentLimit current_limit [
                    /// Drive current limit [A] (`current_limit`).
                    Imax
                ]
                /// [`cogging`].
                Cogging cogging [
                    /// Cogging (detent) torque amplitude [N m] (`cogging`).
                    CogAmp,
                    /// Cogging cycles per mechanical revolution [-] (`cogging`).
                    CogCycles,
                    /// Cogging phase [rad] (`cogging`).
                    CogPhase
                ]
                /// [`winding_heating`].
                WindingHeating winding_heating [
                    /// Winding temperature rise per watt of copper loss, at the thermal
                    /// steady state [K/W] (`winding_heating`).
                    Rth,
                    /// Winding thermal time constant [s] (`winding_heating`).
                    TauTh
                ]
            ]
        }
    };
}

pub(crate) use catalogue_table;

/// A list the table generated, as an array of its length (`N` is the list's length: a
/// shorter array is a compile-time error).
pub(crate) const fn listed<T: Copy, const N: usize>(list: &[T]) -> [T; N] {
    assert!(list.len() == N, "an array of the list's length");
    let mut out = [list[0]; N];
    let mut k = 0;
    while k < N {
        out[k] = list[k];
        k += 1;
    }
    out
}
