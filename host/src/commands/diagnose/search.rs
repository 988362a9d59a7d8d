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
use super::found::{Search, StandingIn};
use super::parallel::in_parallel;
use super::search_context::reduced;
use super::verdict::significant;
use crate::fit::FitOptions;
use anyhow::Result;
use motor_id_shared::model::effects::Effect;

/// Run the search on `data` with the user's fit options (`opts.quiet` silences the steps'
/// messages; the fits themselves show no progress bar), the catalogue less `without`.
pub fn search(data: &Data, opts: &FitOptions, without: &[Effect]) -> Result<Search> {
    let say = |msg: String| {
        if !opts.quiet {
            eprintln!("{msg}");
        }
    };
    let quiet = FitOptions {
        quiet: true,
        speed_only: !data.with_current,
        ..opts.clone()
    };
    let spec = crate::spec::problem(&opts.bounds, &opts.fix)?;
    say("fitting the baseline model on the training records".into());
    let (baseline, round) = baseline_and_first_round(data, &quiet, &spec, without, &say)?;
    let FirstRound {
        cx,
        where_,
        holdout,
        usable,
        scored,
        left_out_parents,
    } = round;
    let (base_params, scales, peaks) = (cx.base_params, cx.scales, cx.peaks);
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
    let first_fit = found
        .fit(first)
        .expect("every usable effect was scored")
        .clone();

    // Forward: more effects, one at a time, on what is left after the ones named so far.
    let mut chain: Vec<(Effect, Scored)> = vec![(first, first_fit)];
    let mut in_model = vec![first];
    let mut model = with_effect(&spec, first, &base_params, &scales, &peaks)?;
    loop {
        let (_, last) = chain.last().expect("the chain holds the first effect");
        let params = last.fit.result.params;
        model.base = params;
        let reference = last.reference();
        let mut best: Option<(Effect, Scored)> = None;
        // An effect whose parameters are all in the model already (Coulomb friction under
        // its extension) adds nothing.
        let adds = |e: &Effect| e.params().iter().any(|id| !model.free[id.index()]);
        let names: Vec<&str> = in_model.iter().map(|e| e.name()).collect();
        let candidates: Vec<Effect> = usable
            .iter()
            .copied()
            .filter(|e| !in_model.contains(e) && adds(e) && !passed_over.contains(e))
            .collect();
        let fits = in_parallel(candidates.len(), |k| {
            let effect = candidates[k];
            say(format!(
                "fitting {} on top of {}",
                effect.name(),
                names.join(" + ")
            ));
            cx.add(&model, effect, &params)
        });
        for (effect, f) in candidates.iter().zip(fits) {
            let f = f?;
            if !significant(&reference, &f.candidate(*effect, &scales), &found.holdout) {
                continue;
            }
            if best
                .as_ref()
                .is_none_or(|(_, b)| f.holdout_joint < b.holdout_joint)
            {
                best = Some((*effect, f));
            }
        }
        let Some((effect, f)) = best else { break };
        model = with_effect(&model, effect, &params, &scales, &peaks)?;
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
    Ok(found)
}
