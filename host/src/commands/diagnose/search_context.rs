//! What every fit of the search ([`super::search`]) shares, and the sets of effects it
//! refits: which effects a model holds, and what is left when one is taken out.

use super::data::{Data, Scored};
use super::effect_fit::{fit_effect, with_effect, Peaks, UserFixes};
use crate::fit::{refit_from, FitOptions};
use anyhow::Result;
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::model::effects::{Effect, Scales};
use motor_id_shared::ModelParams;

/// What every fit of the search shares: the records, the quiet fit options, the user's
/// problem and fixes, the baseline's parameters and scales, and the order peaks of a ripple and of
/// cogging.
pub(super) struct Context<'a> {
    pub(super) data: &'a Data,
    pub(super) quiet: FitOptions,
    pub(super) spec: ProblemSpec,
    /// The parameters the user fixed, by name.
    pub(super) fixes: UserFixes,
    pub(super) base_params: ModelParams,
    pub(super) scales: Scales,
    pub(super) peaks: Peaks,
}

impl<'a> Context<'a> {
    /// This context for adding `effects` to the model fitted at `params`: where one of them
    /// reads the shaft angle (a tacho ripple, cogging), with the order peaks of that model's
    /// residual, which start its fit and set its order; the baseline's can be another
    /// effect's (a drive's current limit left 24 rad/s of misfit there, whose spectrum put a
    /// 14-cycle ripple's peak at 17).
    pub(super) fn for_adding(&self, effects: &[Effect], params: &ModelParams) -> Result<Self> {
        let reads_angle = |e: &Effect| matches!(e, Effect::TachoRipple | Effect::Cogging);
        let peaks = match effects.iter().any(reads_angle) {
            true => Peaks::of(&self.data.traces(params)?, &self.spec),
            false => self.peaks,
        };
        Ok(Context {
            quiet: self.quiet.clone(),
            peaks,
            ..*self
        })
    }

    /// The user's problem with every effect of `set` free (and what each extends), the
    /// fixed values taken from `start` (a ripple's or cogging's order among them: a refit
    /// keeps the order its fit holds). Whether the user fixed a parameter is judged by name
    /// ([`super::effect_fit::UserFixes`]), not on `start`'s values: an effect's fitted value there
    /// is no fix of the user's (taken for one, every effect of a refitted model was held at
    /// the final fit's values, and an entry whose parameters were all held had nothing to
    /// fit: `diagnose` stopped with "every parameter is fixed").
    pub(super) fn spec_of(&self, set: &[Effect], start: &ModelParams) -> Result<ProblemSpec> {
        let mut s = self.spec;
        for e in set {
            s.base = self.spec.base;
            s = with_effect(&s, *e, start, (&self.scales, &self.peaks), &self.fixes)?;
        }
        s.base = *start;
        Ok(s)
    }

    /// `p` with `effect`'s own parameters back at the baseline's values (the effect taken
    /// out; what it extends stays).
    pub(super) fn without(&self, p: &ModelParams, effect: Effect) -> ModelParams {
        let mut out = *p;
        for id in effect.params() {
            out.set(*id, self.base_params.get(*id));
        }
        out
    }

    /// `p` reduced to the model of `prefix`: the parameters of every effect not in it back
    /// at the baseline's values, those of an effect it extends too unless `prefix` holds
    /// that effect (itself, or another that extends it).
    pub(super) fn only(
        &self,
        p: &ModelParams,
        prefix: &[Effect],
        dropped: &[Effect],
    ) -> ModelParams {
        dropped.iter().fold(*p, |q, e| {
            let q = self.without(&q, *e);
            match e.parent() {
                Some(parent) if !holds(prefix, parent) => self.without(&q, parent),
                _ => q,
            }
        })
    }

    /// `effect` added to the model `model` fitted at `at` ([`fit_effect`]), and scored.
    pub(super) fn add(
        &self,
        model: &ProblemSpec,
        effect: Effect,
        at: &ModelParams,
    ) -> Result<Scored> {
        let s = with_effect(model, effect, at, (&self.scales, &self.peaks), &self.fixes)?;
        self.data
            .score(fit_effect(self.data, &self.quiet, &s, effect, &self.peaks)?)
    }

    /// The model of `set` fitted on the training records from `start`, and scored.
    pub(super) fn refit(&self, set: &[Effect], start: &ModelParams) -> Result<Scored> {
        let spec = self.spec_of(set, start)?;
        self.data
            .score(refit_from(&self.data.train, &self.quiet, &spec, start)?)
    }
}

/// Whether the model of `set` holds `effect`'s parameters: `effect` is in it, or an effect
/// that extends it.
fn holds(set: &[Effect], effect: Effect) -> bool {
    set.iter()
        .any(|e| *e == effect || e.parent() == Some(effect))
}

/// `set` less `effect`: what `effect` extends takes its place unless the rest of the set
/// holds it already (itself, or another effect that extends it) or the user left it out
/// (`without`: it never enters a model).
pub(super) fn reduced(set: &[Effect], effect: Effect, without: &[Effect]) -> Vec<Effect> {
    let rest: Vec<Effect> = set.iter().copied().filter(|e| *e != effect).collect();
    set.iter()
        .filter_map(|e| match (*e == effect, e.parent()) {
            (false, _) => Some(*e),
            (true, Some(parent)) if !holds(&rest, parent) && !without.contains(&parent) => {
                Some(parent)
            }
            (true, _) => None,
        })
        .collect()
}

/// A context on the records `data` of `motor` for the user's problem with the parameters
/// of `fix` fixed (`--fix`), no order peaks (for tests).
#[cfg(test)]
pub(super) fn test_context<'a>(
    data: &'a Data,
    fix: &[(motor_id_shared::ParamId, f32)],
    motor: ModelParams,
) -> Context<'a> {
    use super::spectrum::OrderPeak;
    let fix = [crate::spec::FixSpec(fix.to_vec())];
    Context {
        data,
        quiet: crate::fit::tests::quiet(),
        spec: crate::spec::problem(&[], &fix).unwrap(),
        fixes: UserFixes::of(&fix),
        base_params: motor,
        scales: data.scales(&motor),
        peaks: Peaks {
            ripple: OrderPeak::NONE,
            detents: None,
            cogging: OrderPeak::NONE,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands::diagnose::data::simulated;
    use motor_id_shared::ParamId;

    /// A motor and one record of it, held out too: what a context's problems are built on.
    fn one_record() -> (ModelParams, Data) {
        let motor = ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08);
        (motor, simulated(&motor, &motor, (1, 1)))
    }

    #[test]
    fn a_refitted_model_frees_its_effects_fitted_values_and_keeps_the_user_s_fixes() {
        let (motor, data) = one_record();
        // A start from a fit that holds static friction: its Coulomb part, break-away and
        // scale all away from their defaults.
        let start = motor
            .with(ParamId::Tc, 0.05)
            .with(ParamId::Ts, 0.03)
            .with(ParamId::Ws, 20.0);
        let cx = test_context(&data, &[], motor);
        let spec = cx.spec_of(&[Effect::StaticFriction], &start).unwrap();
        for id in [ParamId::Tc, ParamId::Ts, ParamId::Ws] {
            assert!(spec.free[id.index()], "{} held", id.name());
        }
        assert_eq!(spec.base, start);
        // The same effect when the user fixed its Coulomb torque: that value stays fixed.
        let cx = test_context(&data, &[(ParamId::Tc, 0.05)], motor);
        let spec = cx.spec_of(&[Effect::StaticFriction], &start).unwrap();
        assert!(!spec.free[ParamId::Tc.index()]);
        assert!(spec.free[ParamId::Ts.index()] && spec.free[ParamId::Ws.index()]);
    }

    #[test]
    fn a_refitted_ripple_keeps_the_order_its_fit_holds() {
        let (motor, data) = one_record();
        let mut cx = test_context(&data, &[], motor);
        // The baseline's residual peaked at 17 cycles; the ripple was fitted at 14.
        cx.peaks.ripple.order = 17;
        let start = motor
            .with(ParamId::RippleCycles, 14.0)
            .with(ParamId::RippleAmp, 0.03);
        for set in [
            vec![Effect::TachoRipple],
            vec![Effect::TachoRipple, Effect::StaticFriction],
        ] {
            let spec = cx.spec_of(&set, &start).unwrap();
            assert!(!spec.free[ParamId::RippleCycles.index()]);
            assert_eq!(spec.base.get(ParamId::RippleCycles), 14.0, "{set:?}");
            assert!(spec.free[ParamId::RippleAmp.index()]);
        }
    }

    #[test]
    fn a_user_s_fix_at_a_default_value_is_kept() {
        // `--fix ripple_cycles=1` (a once-per-revolution ripple) and `--fix tc=0` hold the
        // value they give, the defaults: judged by value, the residual's order (17) took
        // the ripple's place, and Coulomb friction was freed.
        let (motor, data) = one_record();
        let fix = [(ParamId::RippleCycles, 1.0), (ParamId::Tc, 0.0)];
        let mut cx = test_context(&data, &fix, motor);
        cx.peaks.ripple.order = 17;
        let spec = cx
            .spec_of(&[Effect::TachoRipple, Effect::StaticFriction], &motor)
            .unwrap();
        for id in [ParamId::RippleCycles, ParamId::Tc] {
            assert!(!spec.free[id.index()], "{} freed", id.name());
        }
        assert_eq!(spec.base.get(ParamId::RippleCycles), 1.0);
        assert!(spec.free[ParamId::RippleAmp.index()] && spec.free[ParamId::Ts.index()]);
        // Coulomb friction fixed at zero is switched off: not tried; static friction, its
        // extension, still is (its break-away on no Coulomb torque), and so is the ripple.
        let leaves = |e| cx.fixes.leave_to_fit(e, &cx.spec);
        assert!(!leaves(Effect::CoulombFriction));
        assert!(leaves(Effect::StaticFriction) && leaves(Effect::TachoRipple));
        // Coulomb friction fixed at a value: the baseline holds it, nothing left to fit.
        let cx = test_context(&data, &[(ParamId::Tc, 0.05)], motor);
        assert!(!cx.fixes.leave_to_fit(Effect::CoulombFriction, &cx.spec));
        assert!(cx.fixes.leave_to_fit(Effect::StaticFriction, &cx.spec));
    }

    #[test]
    fn a_phase_s_box_is_a_turn_centred_on_the_spectrum_s_phase() {
        // The ripple's spectrum peaked at 4 rad: the phase is searched in 4 +- pi, whose
        // ends are the worst phases (a box from 0 drew a search to its bound at 0).
        let (motor, data) = one_record();
        let mut cx = test_context(&data, &[], motor);
        cx.peaks.ripple.phase = 4.0;
        let spec = cx.spec_of(&[Effect::TachoRipple], &motor).unwrap();
        let (lo, hi) = spec.bounds[ParamId::RipplePhase.index()];
        let pi = core::f32::consts::PI;
        assert!((lo - (4.0 - pi)).abs() < 1e-6 && (hi - (4.0 + pi)).abs() < 1e-6);
        assert!(spec.free[ParamId::RipplePhase.index()]);
        // A refit of a model that holds the ripple: the box is centred on its fitted phase,
        // not on the spectrum's (centred there, a phase of 0.1 was clamped to 3.06, the
        // worst phase).
        let fitted = motor
            .with(ParamId::RippleAmp, 0.03)
            .with(ParamId::RipplePhase, 0.1);
        let spec = cx.spec_of(&[Effect::TachoRipple], &fitted).unwrap();
        let (lo, hi) = spec.bounds[ParamId::RipplePhase.index()];
        assert!((lo - (0.1 - pi)).abs() < 1e-6 && (hi - (0.1 + pi)).abs() < 1e-6);
        // The user's fixed phase stays.
        let mut cx = test_context(&data, &[(ParamId::RipplePhase, 1.0)], motor);
        cx.peaks.ripple.phase = 4.0;
        let start = motor.with(ParamId::RipplePhase, 1.0);
        let spec = cx.spec_of(&[Effect::TachoRipple], &start).unwrap();
        assert!(!spec.free[ParamId::RipplePhase.index()]);
        assert_eq!(spec.base.get(ParamId::RipplePhase), 1.0);
    }

    #[test]
    fn a_model_holds_an_effect_itself_or_through_an_extension() {
        use Effect::{BridgeDeadtime, CoulombFriction, SensorDelay, StaticFriction};
        // A prefix [sensor_delay] of the chain [sensor_delay, static_friction] does not hold
        // Coulomb friction: its model refitted alone must not keep the final tc.
        assert!(!holds(&[SensorDelay], CoulombFriction));
        assert!(holds(&[SensorDelay, StaticFriction], CoulombFriction));
        assert!(holds(&[CoulombFriction], CoulombFriction));
        assert!(!holds(&[BridgeDeadtime], StaticFriction));
    }

    #[test]
    fn an_effect_taken_out_leaves_what_it_extends_unless_already_there() {
        use Effect::{AsymmetricFriction, BridgeDeadtime, CoulombFriction, StaticFriction};
        assert_eq!(
            reduced(&[BridgeDeadtime, StaticFriction], StaticFriction, &[]),
            vec![BridgeDeadtime, CoulombFriction]
        );
        assert_eq!(
            reduced(&[StaticFriction, BridgeDeadtime], BridgeDeadtime, &[]),
            vec![StaticFriction]
        );
        // Both extensions of Coulomb friction: taking one out leaves the other, which
        // holds Coulomb friction already.
        assert_eq!(
            reduced(&[StaticFriction, AsymmetricFriction], StaticFriction, &[]),
            vec![AsymmetricFriction]
        );
        // Coulomb friction left out by the user never takes its extension's place.
        assert_eq!(
            reduced(
                &[BridgeDeadtime, StaticFriction],
                StaticFriction,
                &[CoulombFriction]
            ),
            vec![BridgeDeadtime]
        );
    }
}
