//! The search over the catalogue: the baseline fitted on the training records, every effect
//! added to it and refitted, the first that passes the significance rule, then effects added
//! one at a time on top of the model so far, each only when it passes the rule against that
//! model, until none does (no fixed limit: forward selection). Then backward elimination:
//! each named effect is taken out of the final model again and the rest refitted; one whose
//! removal the rule does not call significant is dropped (an effect that only rode on an
//! earlier step's imperfect fit), until every effect left earns its place against the
//! final model without it.

use super::data::{Data, Scored};
use super::effect_fit::{fit_effect, with_effect, Peaks};
use super::found::{Search, StandingIn};
use super::regimes;
use super::spectrum::without_ripple;
use super::verdict::{significant, Holdout};
use crate::fit::{fit_spec, refit_from, FitOptions};
use anyhow::Result;
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::fit::sums::pooled_sigma;
use motor_id_shared::model::effects::{Effect, Scales};
use motor_id_shared::ModelParams;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// What every fit of the search shares: the records, the quiet fit options, the user's
/// problem, the baseline's parameters and scales, and the order peaks of a ripple and of
/// cogging.
struct Context<'a> {
    data: &'a Data,
    quiet: FitOptions,
    spec: ProblemSpec,
    base_params: ModelParams,
    scales: Scales,
    peaks: Peaks,
}

impl Context<'_> {
    /// The user's problem with every effect of `set` free (and what each extends), the
    /// fixed values taken from `start`.
    fn spec_of(&self, set: &[Effect], start: &ModelParams) -> Result<ProblemSpec> {
        let mut s = self.spec;
        s.base = *start;
        for e in set {
            s = with_effect(&s, *e, start, &self.scales, &self.peaks)?;
        }
        Ok(s)
    }

    /// `p` with `effect`'s own parameters back at the baseline's values (the effect taken
    /// out; what it extends stays).
    fn without(&self, p: &ModelParams, effect: Effect) -> ModelParams {
        let mut out = *p;
        for id in effect.params() {
            out.set(*id, self.base_params.get(*id));
        }
        out
    }

    /// `p` reduced to the model of `prefix`: the parameters of every effect not in it back
    /// at the baseline's values, those of an effect it extends too unless `prefix` holds
    /// that effect (itself, or another that extends it).
    fn only(&self, p: &ModelParams, prefix: &[Effect], dropped: &[Effect]) -> ModelParams {
        dropped.iter().fold(*p, |q, e| {
            let q = self.without(&q, *e);
            match e.parent() {
                Some(parent) if !holds(prefix, parent) => self.without(&q, parent),
                _ => q,
            }
        })
    }

    /// `effect` added to the model `model` fitted at `at` ([`fit_effect`]), and scored.
    fn add(&self, model: &ProblemSpec, effect: Effect, at: &ModelParams) -> Result<Scored> {
        let s = with_effect(model, effect, at, &self.scales, &self.peaks)?;
        self.data
            .score(fit_effect(self.data, &self.quiet, &s, effect, &self.peaks)?)
    }

    /// The model of `set` fitted on the training records from `start`, and scored.
    fn refit(&self, set: &[Effect], start: &ModelParams) -> Result<Scored> {
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
fn reduced(set: &[Effect], effect: Effect, without: &[Effect]) -> Vec<Effect> {
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
    let baseline = data.score(fit_spec(&data.train, &quiet, &spec)?)?;
    let base_params = baseline.fit.result.params;
    let traces = data.traces(&base_params)?;
    let where_ = regimes::analyse(&traces, baseline.fit.result.sigma_omega);
    let peaks = Peaks::of(&traces, &spec);
    let ripple = peaks.ripple;
    // The held-out noise floor, unless a ripple at the residual's order hides it: the noise
    // estimate reads a ripple above 0.15 cycles per sample as noise (2.7 % at 8 per
    // revolution read 0.37 rad/s of noise for 0.2). Both are upper bounds of the noise
    // (subtracting a ripple that is not there adds one), so the smaller is taken.
    let cleaned: Vec<Vec<f32>> = traces
        .iter()
        .filter(|t| t.set == "holdout")
        .map(|t| without_ripple(t, ripple.order))
        .collect();
    let holdout = Holdout {
        noise: data
            .holdout_noise()?
            .min(pooled_sigma(cleaned.iter().map(Vec::as_slice))),
        signal_rms: data.holdout_rms(),
    };
    let scales = data.scales(&base_params);
    let cx = Context {
        data,
        quiet: quiet.clone(),
        spec,
        base_params,
        scales,
        peaks,
    };

    // Which: every effect of the catalogue the records can show, refitted on the training
    // records.
    // (Cogging only when told its detents per revolution, above.)
    let usable: Vec<Effect> = Effect::ALL
        .into_iter()
        .filter(|e| (data.with_current || !e.needs_current()) && !without.contains(e))
        .filter(|e| *e != Effect::Cogging || peaks.detents.is_some())
        .collect();
    let mut scored: Vec<(Effect, Scored)> = Vec::new();
    let fits = in_parallel(usable.len(), |k| {
        let effect = usable[k];
        say(format!(
            "fitting with {} ({}/{})",
            effect.name(),
            k + 1,
            usable.len()
        ));
        cx.add(&spec, effect, &base_params)
    });
    for (effect, f) in usable.iter().zip(fits) {
        scored.push((*effect, f?));
    }
    scored.sort_by(|a, b| a.1.holdout_joint.total_cmp(&b.1.holdout_joint));
    // The entries left out that a usable effect extends: fitted as the reference its own
    // part is judged against, never named.
    let mut left_out_parents: Vec<(Effect, Scored)> = Vec::new();
    for p in usable.iter().filter_map(|e| e.parent()) {
        if without.contains(&p) && left_out_parents.iter().all(|(q, _)| *q != p) {
            left_out_parents.push((p, cx.add(&spec, p, &base_params)?));
        }
    }
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

/// `f(0..n)` on the machine's cores (the fits of different effects are independent, each
/// deterministic, so the results do not depend on the threads), in order.
fn in_parallel<T: Send>(n: usize, f: impl Fn(usize) -> T + Sync) -> Vec<T> {
    let workers = std::thread::available_parallelism()
        .map_or(1, |c| c.get())
        .min(n);
    let next = AtomicUsize::new(0);
    let results: Mutex<Vec<Option<T>>> = Mutex::new((0..n).map(|_| None).collect());
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| loop {
                let k = next.fetch_add(1, Ordering::Relaxed);
                if k >= n {
                    break;
                }
                let r = f(k);
                results.lock().expect("no worker panics holding the lock")[k] = Some(r);
            });
        }
    });
    let results = results.into_inner().expect("no worker panicked");
    results
        .into_iter()
        .map(|r| r.expect("every index was run"))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

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
