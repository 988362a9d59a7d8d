//! A candidate's refit that ends worse than a model nested in it, searched again from
//! there before it is judged (docs/ARCHITECTURE.md, the diagnosis' "Which").
//!
//! An effect added to a model holds that model (the effect switched off: its first
//! parameter at zero), and an extension added beside its parent holds the parent's fit on
//! the same model (its own part switched off). Its optimum on the training records cannot
//! be worse than theirs, so a refit that ends more than 1 % above the training objective of
//! one of them (`WIDER_GAIN`, the escalation's rule) stalled on its way there, and the
//! significance rule would reject an effect for its search's fault: on the lab motor,
//! static friction's refit stopped at a training misfit of 3.91 rad/s where Coulomb
//! friction, nested in it, reaches 3.26. Such a refit is searched again from the nested
//! model's fit in the escalation's order: first the two stages its fit ran from the model
//! it was added to ([`in_two_stages`]: the short search of the effect's own parameters'
//! basin, on the training records decimated as the wider search reads them, and least
//! squares with everything free on every sample from its best); where that gains under 1 %
//! on the nested model, the escalation's wider FFO as the final model's widening runs it
//! ([`super::widening`], [`widen_from`]). The better fit of the stalled and the new one
//! stands and is judged. A refit that ends below every nested model is not searched again:
//! a wider search of each candidate that stays above the noise would cost more than the
//! whole search (a stall is not provable there).

use super::data::Scored;
use super::effect_fit::{effects_alone, in_two_stages, TwoStages};
use super::parallel::in_parallel;
use super::search_context::Context;
use super::widening::forms_survive_decimation;
use crate::fit::{refit_from, widen_from, Fit};
use crate::report::Num;
use anyhow::Result;
use motor_id_shared::fit::identify::WIDER_GAIN;
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::model::effects::{Effect, SWITCHES};
use motor_id_shared::ModelParams;
use serde::Serialize;
use std::sync::OnceLock;

/// A candidate's refit that stalled above a model nested in it, searched again from that
/// model's fit (an effect's `restarted` in the report).
#[derive(Serialize, Debug, Clone)]
pub struct Restarted {
    /// The nested model: `the model it is added to`, or the entry the effect extends.
    pub from: &'static str,
    /// The training objective where the candidate's refit stalled.
    pub stalled: Num,
    /// The nested model's training objective.
    pub nested: Num,
    /// The training objective of the fit from the nested model (taken when below
    /// `stalled`).
    pub refitted: Num,
    /// Whether the wider search ran: the basin's search from the nested model and its least
    /// squares gained under 1 % on it.
    pub wider: bool,
    /// Evaluations of the searches on the records searched (the basin's, and the wider
    /// one's when it ran).
    pub evaluations: u32,
    /// Rows of a record per sample of the records searched (1: every sample).
    pub decimation: usize,
}

impl Restarted {
    /// What it did, in words (the effects' list of the text report).
    pub fn line(&self) -> String {
        let how = match self.wider {
            true => "searched again, widened,",
            false => "searched again",
        };
        let kept = match self.refitted.0 < self.stalled.0 {
            true => "",
            false => ", no better: the stalled fit is judged",
        };
        format!(
            "its refit stalled above {} (objective {:.4} > {:.4}): {how} from there to {:.4}{kept}",
            self.from, self.stalled.0, self.nested.0, self.refitted.0
        )
    }
}

/// What a candidate's fit tells the fits of the entries that extend it: its parameters and
/// its training objective (`None` for a fit that failed).
type Published = Option<(ModelParams, f32)>;

/// Sets a candidate's [`Published`] slot to `None` when its fit ends without setting it (a
/// panic), so that no extension waits for it forever.
struct Unpublished<'a>(&'a OnceLock<Published>);

impl Drop for Unpublished<'_> {
    fn drop(&mut self) {
        let _ = self.0.set(None);
    }
}

/// The `candidates` added to the model of the fit `reference`, each fitted by
/// `add(k, effect)` on the machine's cores ([`in_parallel`]), and each refit that stalled
/// above a model nested in it searched again from there ([`Restarted`]; `say` tells which), in the
/// candidates' order. An extension waits for its parent's fit when the parent is an earlier
/// candidate (the catalogue lists parents first), so that its stall is judged against it;
/// the restart then runs beside the other candidates' fits, and the result does not
/// depend on the threads' timing.
pub(super) fn fitted_unstalled(
    cx: &Context,
    candidates: &[Effect],
    reference: &Fit,
    add: impl Fn(usize, Effect) -> Result<Scored> + Sync,
    say: &(impl Fn(String) + Sync),
) -> Result<Vec<Scored>> {
    let objective = |f: &Fit| f.result.cost.fitness();
    let published: Vec<OnceLock<Published>> = candidates.iter().map(|_| OnceLock::new()).collect();
    let fits = in_parallel(candidates.len(), |k| {
        let effect = candidates[k];
        let unpublished = Unpublished(&published[k]);
        let fit = add(k, effect);
        let mine = fit
            .as_ref()
            .ok()
            .map(|s| (s.fit.result.params, objective(&s.fit)));
        let _ = published[k].set(mine);
        drop(unpublished);
        let fit = fit?;
        // The best nested model: the parent's fit beside it where that is better than the
        // model both are added to (only an earlier candidate's: one a later job fits could
        // wait on this one).
        let parent = effect.parent().and_then(|p| {
            let j = candidates[..k].iter().position(|e| *e == p)?;
            published[j].wait().map(|fit| (p.name(), fit))
        });
        let (from, nested, nested_objective) = match parent {
            Some((name, (params, o))) if o < objective(reference) => (name, params, o),
            _ => (
                "the model it is added to",
                reference.result.params,
                objective(reference),
            ),
        };
        if WIDER_GAIN * objective(&fit.fit) <= nested_objective {
            return Ok(fit);
        }
        let Some(start) = nested_point(effect, &fit.fit.spec, &nested) else {
            return Ok(fit);
        };
        say(format!(
            "{}'s refit stalled above {from}: searching it again from there",
            effect.name()
        ));
        // The search again is a second opinion: where it fails (a record its start cannot
        // simulate), the stalled fit is judged, as before it.
        match restart(cx, effect, &fit, (from, &start, nested_objective)) {
            Ok(again) => Ok(again),
            Err(e) => {
                eprintln!(
                    "warning: {}'s refit searched again failed ({e:#}); its stalled fit is judged",
                    effect.name()
                );
                Ok(fit)
            }
        }
    });
    fits.into_iter().collect()
}

/// The nested model's parameters `nested` as a point of `effect`'s problem `spec`
/// ([`ProblemSpec::point`]: its fixed values, the order a ripple is fitted at, the
/// candidate's). `None` where the effect's switch (its first parameter, 0 for off) lies
/// outside its box there (a current limit's `imax`, a winding's `rth`): the nested model is
/// then no point of the candidate's problem, and no stall is proven by it.
fn nested_point(effect: Effect, spec: &ProblemSpec, nested: &ModelParams) -> Option<ModelParams> {
    let switch = SWITCHES[effect as usize];
    let (lo, hi) = spec.bounds[switch.index()];
    let outside = spec.free[switch.index()] && !(lo..=hi).contains(&nested.get(switch));
    (!outside).then(|| spec.point(nested))
}

/// The candidate `effect`'s stalled fit `scored` searched again from `start`, the fit of
/// the model `from` nested in it as a point of its problem ([`nested_point`]; its training
/// objective `nested_objective`): the better of the new fit and `scored`, with what was
/// done.
fn restart(
    cx: &Context,
    effect: Effect,
    scored: &Scored,
    (from, start, nested_objective): (&'static str, &ModelParams, f32),
) -> Result<Scored> {
    let spec = &scored.fit.spec;
    let alone = effects_alone(spec, &[effect], start);
    let data = cx.data;
    let opts = &cx.quiet;
    // The escalation's order: first the two stages its fit ran from the model it was added
    // to (the short search of the effect's own basin, least squares on every sample).
    let decimate = forms_survive_decimation(&[effect], start);
    let TwoStages {
        mut fit,
        basin_evaluations: mut evaluations,
        decimation,
    } = in_two_stages(data, opts, (spec, &alone), start, decimate)?;
    // Where that gains under 1 % on the nested model (the effect adds nothing to it, or its
    // search stalls again: the basin's search starts at the nested model, so it never
    // ends above it on records it does not decimate), the wider search, as the escalation
    // widens a fit before it blames the model.
    let wider = fit.result.cost.fitness() > WIDER_GAIN * nested_objective;
    if wider {
        let wide = widen_from(&data.train, opts, &alone, spec, start, decimate, refit_from)?;
        evaluations += wide.search_evaluations;
        if let Some(better) = wide
            .fit
            .filter(|f| f.result.cost.fitness() < fit.result.cost.fitness())
        {
            fit = better;
        }
    }
    let stalled = scored.fit.result.cost.fitness();
    let refitted = fit.result.cost.fitness();
    let mut out = match refitted < stalled {
        true => data.score(fit)?,
        false => scored.clone(),
    };
    out.restarted = Some(Restarted {
        from,
        stalled: Num(stalled),
        nested: Num(nested_objective),
        refitted: Num(refitted),
        wider,
        evaluations,
        decimation,
    });
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands::diagnose::data::{simulated, Data};
    use crate::commands::diagnose::search_context::test_context;
    use crate::fit::refit_from;
    use crate::fit::tests::quiet;
    use motor_id_shared::fit::space::ProblemSpec;
    use motor_id_shared::ParamId;

    #[test]
    fn a_fit_that_panics_publishes_none_so_that_no_extension_waits_for_it() {
        let slot: OnceLock<Published> = OnceLock::new();
        let ended = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
            let _unpublished = Unpublished(&slot);
            panic!("a candidate's fit panics before it publishes");
        }));
        assert!(ended.is_err());
        assert!(matches!(slot.get(), Some(None)), "{:?}", slot.get());
        // A fit that published keeps what it published.
        let slot: OnceLock<Published> = OnceLock::new();
        let unpublished = Unpublished(&slot);
        let _ = slot.set(Some((
            ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08),
            2.5,
        )));
        drop(unpublished);
        assert!(matches!(slot.get(), Some(Some((_, o))) if *o == 2.5));
    }

    /// A motor and the records of it with Coulomb friction of 0.05 N m (the tests' case).
    fn with_coulomb_friction() -> (ModelParams, Data) {
        let motor = ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08);
        let truth = motor.with(ParamId::Tc, 0.05);
        (motor, simulated(&truth, &truth, (6, 2)))
    }

    #[test]
    fn a_search_again_that_ends_no_better_keeps_the_stalled_fit_and_says_so() {
        // Coulomb friction's fit on a motor with Coulomb friction, listed as if it had
        // reached half the objective it has (no search from the motor's fit reaches that):
        // searched again from the motor's fit, it ends above it, and the fit listed stands.
        let (motor, data) = with_coulomb_friction();
        let cx = test_context(&data, &[], motor);
        let reference = refit_from(&data.train, &quiet(), &cx.spec, &motor).unwrap();
        let mut listed = cx.add(&cx.spec, Effect::CoulombFriction, &motor).unwrap();
        listed.fit.result.cost.sse *= 0.25;
        let stalled = listed.fit.result.cost.fitness();
        let nested = reference.result.cost.fitness();
        let start = nested_point(
            Effect::CoulombFriction,
            &listed.fit.spec,
            &reference.result.params,
        )
        .expect("the motor is a point of Coulomb friction's problem");
        let from = "the model it is added to";
        let out = restart(
            &cx,
            Effect::CoulombFriction,
            &listed,
            (from, &start, nested),
        )
        .unwrap();
        for id in ParamId::ALL {
            let (a, b) = (
                out.fit.result.params.get(id),
                listed.fit.result.params.get(id),
            );
            assert_eq!(a.to_bits(), b.to_bits(), "{id:?}");
        }
        assert_eq!(out.fit.result.cost.sse, listed.fit.result.cost.sse);
        let r = out.restarted.as_ref().expect("searched again");
        assert_eq!(r.stalled.0, stalled);
        assert!(r.refitted.0 > 1.5 * stalled, "{r:?}");
        assert!(
            r.line().ends_with("no better: the stalled fit is judged"),
            "{}",
            r.line()
        );
    }

    #[test]
    fn a_refit_stalled_above_a_nested_model_is_searched_again_from_it() {
        // A motor with Coulomb friction: static friction, which extends it, and a fan load
        // are tried beside it. Each candidate's fit ended at a poor point of its problem
        // (fitted in a box around it, reported with the problem's box).
        let (motor, data) = with_coulomb_friction();
        let cx = test_context(&data, &[], motor);
        let reference = refit_from(&data.train, &quiet(), &cx.spec, &motor).unwrap();
        let coulomb = cx.add(&cx.spec, Effect::CoulombFriction, &motor).unwrap();
        let stalled_in = |own: &[(ParamId, f32, f32, f32)]| {
            let (mut wide, mut tight) = (cx.spec, cx.spec);
            for &(id, lo, hi, at) in own {
                wide.set_bounds(id, lo, hi).unwrap();
                wide.free(id);
                tight.set_bounds(id, at, 1.01 * at + 1e-6).unwrap();
                tight.free(id);
            }
            let mut fit = refit_from(&data.train, &quiet(), &tight, &motor).unwrap();
            fit.spec = wide;
            data.score(fit).unwrap()
        };
        // Static friction's break-away of 0.05 N m over 200 rad/s, no Coulomb torque.
        let stribeck = stalled_in(&[
            (ParamId::Tc, 0.0, 0.5, 0.0),
            (ParamId::Ts, 0.0, 0.5, 0.05),
            (ParamId::Ws, 0.1, 250.0, 200.0),
        ]);
        // A fan load of 1e-4 N m s^2/rad^2 (9 N m at the top speed).
        let fan = stalled_in(&[(ParamId::Kq, 0.0, 1e-3, 1e-4)]);
        let objective = |s: &Scored| s.fit.result.cost.fitness();
        let nested = objective(&coulomb);
        assert!(objective(&stribeck) > 1.5 * nested, "stalled above Coulomb");
        assert!(objective(&stribeck) < objective(&data.score(reference.clone()).unwrap()));
        assert!(objective(&fan) > 1.5 * reference.result.cost.fitness());
        // A drive's current limit of 2 A (its box from 0.5 A: no point of it is the motor
        // without a limit).
        let limit = stalled_in(&[(ParamId::Imax, 0.5, 40.0, 2.0)]);
        assert!(objective(&limit) > 1.5 * reference.result.cost.fitness());
        let effects = [
            Effect::CoulombFriction,
            Effect::StaticFriction,
            Effect::QuadraticLoad,
            Effect::CurrentLimit,
        ];
        let fits = [
            coulomb.clone(),
            stribeck.clone(),
            fan.clone(),
            limit.clone(),
        ];
        let add = |k: usize, e: Effect| {
            assert_eq!(e, effects[k]);
            Ok(fits[k].clone())
        };
        let out = fitted_unstalled(&cx, &effects, &reference, add, &|_| {}).unwrap();
        // Coulomb friction, below every model nested in it: as it was.
        assert!(out[0].restarted.is_none());
        assert_eq!(objective(&out[0]), nested);
        // Static friction from Coulomb friction's fit, the better of its nested models:
        // no worse than it by 1 %.
        let (stribeck_now, fan_now) = (&out[1], &out[2]);
        let r = stribeck_now
            .restarted
            .as_ref()
            .expect("static friction searched again");
        assert_eq!(r.from, "coulomb_friction");
        assert!(r.stalled.0 == objective(&stribeck) && r.nested.0 == nested);
        assert!(objective(stribeck_now) < 1.01 * nested, "{r:?}");
        assert!((stribeck_now.fit.result.params.get(ParamId::Tc) - 0.05).abs() < 0.005);
        assert!(r.line().contains("stalled above coulomb_friction"));
        // Its search again gained under 1 % on Coulomb friction (the plant holds no
        // break-away): the wider search ran too before it is judged.
        assert!(r.wider && r.line().contains("widened"), "{r:?}");
        // The fan load from the model it is added to.
        let r = fan_now
            .restarted
            .as_ref()
            .expect("the fan load searched again");
        assert_eq!(r.from, "the model it is added to");
        assert!(r.wider, "{r:?}");
        assert!(objective(fan_now) < 1.01 * reference.result.cost.fitness());
        assert!(fan_now.fit.result.params.get(ParamId::Kq) < 1e-5);
        // The current limit: no stall proven, its fit as it was.
        assert!(out[3].restarted.is_none());
        assert_eq!(objective(&out[3]), objective(&limit));
        // The candidates' problems stand.
        let free = |s: &ProblemSpec| s.free;
        assert_eq!(free(&stribeck_now.fit.spec), free(&stribeck.fit.spec));
        // Static friction listed before Coulomb friction is judged against the model it
        // is added to alone (it does not wait for a later job), below which it ended.
        let swapped = [stribeck.clone(), coulomb.clone()];
        let effects = [Effect::StaticFriction, Effect::CoulombFriction];
        let add = |k: usize, _| Ok(swapped[k].clone());
        let out = fitted_unstalled(&cx, &effects, &reference, add, &|_| {}).unwrap();
        assert!(out.iter().all(|s| s.restarted.is_none()));
        assert_eq!(objective(&out[0]), objective(&stribeck));
    }
}
