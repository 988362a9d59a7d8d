//! The search over the catalogue: the baseline and every effect added to it
//! ([`super::first_round`]), the first that passes the significance rule, then effects added
//! one at a time on top of the model so far, each only when it passes the rule against that
//! model, until none does (no fixed limit: forward selection). Then backward elimination:
//! each named effect is taken out of the final model again and the rest refitted; one whose
//! removal the rule does not call significant is dropped (an effect that only rode on an
//! earlier step's imperfect fit), until every effect left earns its place against the
//! final model without it.

use super::data::{Data, Scored};
use super::effect_fit::with_effect;
use super::first_round::{baseline_and_first_round, FirstRound};
use super::found::{as_shown, at_limit, rival, LookAlike, Search, StandingIn};
use super::parallel::in_parallel;
use super::regime_shares::{misfit_where_named_act, told_apart_where_it_acts};
use super::search_context::{reduced, Context};
use super::stalled::fitted_unstalled;
use super::verdict::{predicts_better, significant, Holdout};
use super::widening::widened_final;
use crate::fit::FitOptions;
use anyhow::Result;
use motor_id_shared::model::effects::Effect;

/// Run the search on `data` with the user's fit options (`opts.quiet` silences the steps'
/// messages; the fits themselves show no progress bar), the catalogue less `without`; the
/// final model is widened where it would leave the held-out records unexplained, against
/// the noise or their run-to-run floor `repeat_floor` ([`widened_final`]).
pub fn search(
    data: &Data,
    opts: &FitOptions,
    without: &[Effect],
    repeat_floor: Option<f32>,
) -> Result<Search> {
    let say = |msg: String| {
        if !opts.quiet {
            eprintln!("{msg}");
        }
    };
    let quiet = data.fit_options(opts);
    let spec = crate::spec::problem(&opts.bounds, &opts.fix)?;
    say("fitting the baseline model on the training records".into());
    let (baseline, round) = baseline_and_first_round(data, &quiet, &spec, without, &say)?;
    let FirstRound {
        cx,
        where_,
        holdout,
        usable,
        never,
        scored,
        left_out_parents,
    } = round;
    let (base_params, scales, peaks) = (cx.base_params, cx.scales, cx.peaks);
    let without = &never[..];
    let baseline = data.score(baseline)?;
    let mut found = Search {
        baseline,
        holdout,
        scales,
        where_,
        scored,
        chain: Vec::new(),
        left_out_parents,
        standing_in: Vec::new(),
        look_alikes: Vec::new(),
        widened: None,
    };
    // The first effect: the best significant one the data needs; one that only matches
    // the entry it extends, left out, stands in for it and is passed over.
    let mut first = None;
    let mut standing_in: Vec<StandingIn> = Vec::new();
    // Extensions of a left-out entry whose own part the records do not show: never in a
    // model, at this step or a later one (on top of other effects there is no fit of the
    // left-out entry to judge their own part against).
    let mut passed_over: Vec<Effect> = Vec::new();
    for (e, s) in &found.scored {
        let needed = found.needed(*e);
        if needed.is_none() {
            passed_over.push(*e);
        }
        if !found.significant(*e, s) {
            continue;
        }
        match needed {
            Some(needed) => first = first.or(Some(needed)),
            None => standing_in.push(StandingIn {
                effect: *e,
                parent: e.parent().expect("only an extension stands in"),
                before: found.baseline.holdout_rmse,
                after: s.holdout_rmse,
            }),
        }
    }
    found.standing_in = standing_in;
    let Some(first) = first else {
        return Ok(found);
    };
    let passed_first = |e: Effect| {
        found
            .fit(e)
            .is_some_and(|s| found.significant(e, s) && found.needed(e) == Some(e))
    };
    let first = match found.fit(first) {
        Some(fit) => as_shown(first, fit, passed_first, &say),
        None => first,
    };
    let first_fit = found
        .fit(first)
        .expect("every usable effect was scored")
        .clone();
    // The others significant against the baseline, each as the data needs it.
    let rivals: Vec<(Effect, f32)> = found
        .scored
        .iter()
        .filter(|(e, s)| found.significant(*e, s))
        .filter_map(|(e, _)| found.needed(*e))
        .filter_map(|e| found.fit(e).and_then(|s| rival(e, s, data.with_current)))
        .collect();
    let chosen = (first, first_fit.holdout_joint);
    // The look-alikes met at the search's steps, weighed again on the final model.
    let mut met: Vec<LookAlike> = Vec::new();
    met.extend(LookAlike::among(chosen, rivals, &found.holdout));
    // An extension whose own part another entry beside its parent explains as well: the
    // search goes on from the parent, where the two are weighed at the next step.
    // (Not where a rival of another form ties with it already: it is then weighed on the
    // final model.)
    let parent = match met.is_empty() {
        true => own_part_alike(&cx, &found, &usable, first, &first_fit, &say)?,
        false => None,
    };
    let (first, first_fit) = match parent {
        Some(parent) => {
            let fit = found.fit(parent).expect("the parent was scored").clone();
            (parent, fit)
        }
        None => (first, first_fit),
    };

    // Forward: more effects, one at a time, on what is left after the ones named so far.
    let mut chain: Vec<(Effect, Scored)> = vec![(first, first_fit)];
    let mut in_model = vec![first];
    let mut model = with_effect(&spec, first, &base_params, (&scales, &peaks), &cx.fixes)?;
    loop {
        let (_, last) = chain.last().expect("the chain holds the first effect");
        let params = last.fit.result.params;
        model.base = params;
        let reference = last.reference();
        // An effect whose parameters are all in the model already (Coulomb friction under
        // its extension) adds nothing.
        let adds = |e: &Effect| e.params().iter().any(|id| !model.free[id.index()]);
        let names: Vec<&str> = in_model.iter().map(|e| e.name()).collect();
        let candidates: Vec<Effect> = usable
            .iter()
            .copied()
            .filter(|e| !in_model.contains(e) && adds(e) && !passed_over.contains(e))
            .collect();
        let step = cx.for_adding(&candidates, &params)?;
        let add = |_, effect: Effect| {
            say(format!(
                "fitting {} on top of {}",
                effect.name(),
                names.join(" + ")
            ));
            step.add(&model, effect, &params)
        };
        let fits = fitted_unstalled(&step, &candidates, &last.fit, add, &say)?;
        let mut passing: Vec<(Effect, Scored)> = candidates
            .iter()
            .copied()
            .zip(fits)
            .filter(|(e, f)| significant(&reference, &f.candidate(*e, &scales), &found.holdout))
            .collect();
        let best = passing
            .iter()
            .enumerate()
            .min_by(|a, b| a.1 .1.holdout_joint.total_cmp(&b.1 .1.holdout_joint))
            .map(|(k, _)| k);
        let Some(best) = best else { break };
        let passed = |e: Effect| passing.iter().any(|(p, _)| *p == e);
        let shown = as_shown(passing[best].0, &passing[best].1, passed, &say);
        let k = passing
            .iter()
            .position(|(e, _)| *e == shown)
            .expect("the best effect or its limit passed");
        let (effect, f) = passing.swap_remove(k);
        let rivals = passing
            .iter()
            .filter_map(|(e, s)| rival(*e, s, data.with_current));
        met.extend(LookAlike::among(
            (effect, f.holdout_joint),
            rivals,
            &found.holdout,
        ));
        model = with_effect(&model, effect, &params, (&scales, &step.peaks), &cx.fixes)?;
        in_model.push(effect);
        chain.push((effect, f));
    }

    // The set named: an effect that extends another one in the model stands for both.
    let forward: Vec<Effect> = chain.iter().map(|(e, _)| *e).collect();
    let mut set: Vec<Effect> = forward
        .iter()
        .copied()
        .filter(|e| !forward.iter().any(|c| c.parent() == Some(*e)))
        .collect();
    let (_, last) = chain.last().expect("the chain holds the first effect");
    let mut fin = last.clone();

    // Backward: drop the effect whose removal matters least while the rule does not call
    // its removal significant.
    while set.len() > 1 {
        say(format!(
            "checking each of {} against the model without it",
            set.iter().map(|e| e.name()).collect::<Vec<_>>().join(" + ")
        ));
        let fits = in_parallel(set.len(), |k| {
            let rest = reduced(&set, set[k], without);
            // What the rest does not hold goes back to the baseline's values (the entry
            // `set[k]` extends too, when it is left out).
            let start = cx.only(&fin.fit.result.params, &rest, &set[k..=k]);
            cx.refit(&rest, &start)
        });
        let mut weakest: Option<(usize, Scored)> = None;
        for (k, f) in fits.into_iter().enumerate() {
            let f = f?;
            let earns = significant(
                &f.reference(),
                &fin.candidate(set[k], &scales),
                &found.holdout,
            );
            if !earns
                && weakest
                    .as_ref()
                    .is_none_or(|(_, w)| f.holdout_joint < w.holdout_joint)
            {
                weakest = Some((k, f));
            }
        }
        let Some((k, f)) = weakest else { break };
        say(format!(
            "{} dropped: not significant in the final model",
            set[k].name()
        ));
        set = reduced(&set, set[k], without);
        fin = f;
    }

    let (set, fin) = limits_taken(&cx, set, fin, &usable, without, &found.holdout, &say)?;
    let (fin, widened) = widened_final(data, &quiet, &set, fin, &found.holdout, repeat_floor, &say);
    found.widened = widened;

    // The chain reported: the forward steps while they agree with the final set, then the
    // models of the final set's prefixes refitted from the final fit, the last one the
    // final fit itself.
    let mut kept = Vec::new();
    for (k, (effect, s)) in chain.into_iter().enumerate() {
        if k + 1 < set.len() && forward[..=k] == set[..=k] {
            kept.push((effect, s));
        } else {
            break;
        }
    }
    for k in kept.len()..set.len() {
        let step = if k + 1 == set.len() {
            fin.clone()
        } else {
            let start = cx.only(&fin.fit.result.params, &set[..=k], &set[k + 1..]);
            cx.refit(&set[..=k], &start)?
        };
        kept.push((set[k], step));
    }
    found.chain = kept;
    found.look_alikes = confirmed(&cx, &set, &fin, met, without, &found.holdout)?;
    Ok(found)
}

/// The final model `fin` of `set` with each effect whose fit has reached its limit's form
/// ([`at_limit`]) swapped for the limit's entry when that is `usable` (the model without
/// it, the limit added and everything refitted), where that predicts the held-out records
/// as well. The search takes the limit where it passes the rule at the same step
/// ([`as_shown`]); a refit after it can still move a dead time's band to its floor (a brush
/// drop beside a current offset, whose dead time was added while the brush drop was not yet
/// significant).
fn limits_taken(
    cx: &Context,
    mut set: Vec<Effect>,
    mut fin: Scored,
    usable: &[Effect],
    without: &[Effect],
    holdout: &Holdout,
    say: &dyn Fn(String),
) -> Result<(Vec<Effect>, Scored)> {
    for k in 0..set.len() {
        let limit = at_limit(set[k], &fin).filter(|l| usable.contains(l) && !set.contains(l));
        let Some(limit) = limit else {
            continue;
        };
        let rest = reduced(&set, set[k], without);
        let start = cx.only(&fin.fit.result.params, &rest, &set[k..=k]);
        let swapped = cx.add(&cx.spec_of(&rest, &start)?, limit, &start)?;
        if !predicts_better(swapped.holdout_joint, fin.holdout_joint, holdout) {
            say(format!("{} at its limit: {}", set[k].name(), limit.name()));
            set[k] = limit;
            fin = swapped;
        }
    }
    Ok((set, fin))
}

/// The look-alikes `met` at the search's steps that hold on the final model `fin` of `set`:
/// the effect swapped for its look-alike (the model without it, the look-alike added and
/// everything refitted) predicts the held-out records as well, and the look-alike passes
/// the rule a named effect must where its form shows ([`misfit_where_named_act`], against
/// the noise: the run-to-run floor comes after the search): a brush drop in a bridge dead
/// time's place that left the current near standstill at 2-5 times its noise would be no
/// look-alike of it. Nor is one that leaves the effect's own regime unexplained where the
/// effect keeps it within ([`told_apart_where_it_acts`]). A step's fits, made before the
/// later effects joined, can be far from the final model's: a bridge dead time beside
/// asymmetric friction tied with a brush drop at its step (1.79 against 1.79), where the
/// final model with it predicts to 0.63 (`tests/tests/diagnose_reference.rs`).
fn confirmed(
    cx: &Context,
    set: &[Effect],
    fin: &Scored,
    met: Vec<LookAlike>,
    without: &[Effect],
    holdout: &Holdout,
) -> Result<Vec<LookAlike>> {
    let pending: Vec<LookAlike> = met
        .into_iter()
        .filter(|l| set.contains(&l.effect) && !set.contains(&l.alike))
        .collect();
    let swapped = in_parallel(pending.len(), |k| {
        let l = &pending[k];
        let rest = reduced(set, l.effect, without);
        let start = cx.only(&fin.fit.result.params, &rest, &[l.effect]);
        let model = cx.spec_of(&rest, &start)?;
        cx.for_adding(&[l.alike], &start)?
            .add(&model, l.alike, &start)
    });
    let current_noise = holdout.current_noise.filter(|_| cx.data.with_current);
    let final_traces = match pending.is_empty() {
        true => Vec::new(),
        false => cx.data.holdout_traces(&fin.fit.result.params)?,
    };
    let mut out = Vec::new();
    for (l, s) in pending.into_iter().zip(swapped) {
        let s = s?;
        // Judged as a named effect would be where its form shows (against the noise: the
        // run-to-run floor comes after the search).
        let traces = cx.data.holdout_traces(&s.fit.result.params)?;
        let form_fits =
            misfit_where_named_act(&traces, &[l.alike], holdout.noise, current_noise).is_empty();
        let told_apart = told_apart_where_it_acts(
            &final_traces,
            &traces,
            l.effect,
            holdout.noise,
            current_noise,
        );
        if form_fits && !told_apart && !predicts_better(s.holdout_joint, fin.holdout_joint, holdout)
        {
            out.push(LookAlike {
                effect_rmse: fin.holdout_joint,
                alike_rmse: s.holdout_joint,
                ..l
            });
        }
    }
    Ok(out)
}

/// Whether the own part of `first`, an extension chosen as the first effect with its fit
/// `fit`, may be another entry's: each other usable entry fitted on top of the entry
/// `first` extends (itself significant), and `first` predicts the held-out records no better
/// than the closest of those that pass the significance rule against it ([`LookAlike`]).
/// Then that entry is returned: the search goes on from it, and the next step weighs the
/// extension and the look-alike on top of it. A Coulomb friction beside a fan load was
/// named `static_friction` (a break-away excess fading over the speeds, with a larger
/// viscous `B`, bends the friction's curve like the load's `kq w^2`): single effects
/// were compared, the fan load never beside the Coulomb friction. None for an effect that
/// extends nothing (its rivals were weighed at the same step).
fn own_part_alike(
    cx: &Context,
    found: &Search,
    usable: &[Effect],
    first: Effect,
    fit: &Scored,
    say: &(dyn Fn(String) + Sync),
) -> Result<Option<Effect>> {
    let Some(parent) = first.parent() else {
        return Ok(None);
    };
    let Some(parent_fit) = found.fit(parent).filter(|f| found.significant(parent, f)) else {
        return Ok(None);
    };
    let model = with_effect(
        &cx.spec,
        parent,
        &cx.base_params,
        (&cx.scales, &cx.peaks),
        &cx.fixes,
    )?;
    let at = parent_fit.fit.result.params;
    // Every usable entry: one the records do not show by itself may show beside the parent
    // (a fan load beside a Coulomb friction that dwarfs it).
    let others: Vec<Effect> = usable
        .iter()
        .copied()
        .filter(|e| *e != parent && e.parent() != Some(parent))
        .collect();
    let on_parent = cx.for_adding(&others, &at)?;
    let fits = in_parallel(others.len(), |k| {
        say(format!(
            "fitting {} on top of {} (against {})",
            others[k].name(),
            parent.name(),
            first.name()
        ));
        on_parent.add(&model, others[k], &at)
    });
    let mut rivals = Vec::new();
    for (e, f) in others.iter().zip(fits) {
        let f = f?;
        let candidate = f.candidate(*e, &found.scales);
        if significant(&parent_fit.reference(), &candidate, &found.holdout) {
            rivals.extend(rival(*e, &f, cx.data.with_current));
        }
    }
    let chosen = (first, fit.holdout_joint);
    Ok(LookAlike::among(chosen, rivals, &found.holdout).map(|_| parent))
}
