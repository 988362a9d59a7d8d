//! The baseline fitted with its escalation beside the first round of the search, every
//! usable effect of the catalogue added to it ([`super::search`]).

use super::data::{Data, Scored};
use super::effect_fit::{Peaks, UserFixes};
use super::regimes;
use super::search_context::Context;
use super::spectrum::without_ripple;
use super::stalled::fitted_unstalled;
use super::verdict::Holdout;
use super::widening::forms_survive_decimation;
use crate::csvio::OwnedRecord;
use crate::fit::{fit_spec_unwidened, refit_checked_from, widen_from, Fit, FitOptions};
use anyhow::Result;
use motor_id_shared::fit::identify::WIDER_GAIN;
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::fit::sums::pooled_sigma;
use motor_id_shared::model::effects::Effect;
use motor_id_shared::ModelParams;

/// The baseline fitted on the training records of `data` (the user's problem `spec`, the
/// search's quiet options), and the [`FirstRound`] from it, the catalogue less `without`;
/// `say` tells the steps.
pub(super) fn baseline_and_first_round<'a>(
    data: &'a Data,
    quiet: &FitOptions,
    spec: &ProblemSpec,
    without: &[Effect],
    say: &(impl Fn(String) + Sync),
) -> Result<(Fit, FirstRound<'a>)> {
    // The baseline's escalation (a wider search where it stays above the noise floor, so that
    // a stuck search is not taken for a missing effect) runs beside the first round of
    // effects, which starts from the baseline as its first search left it. It is widened as
    // the final model is ([`widened_baseline`]). Where the wider search gains less than 1 %
    // on it (the escalation's own rule: it agrees that the misfit is the model's,
    // `WIDER_GAIN`), that fit stands and so does the round; where it gains 1 % or more, the
    // first search was stuck, and the round is run again from the widened baseline. Either
    // way the result does not depend on the threads' timing.
    let unwidened = fit_spec_unwidened(&data.train, quiet, spec)?;
    if unwidened.result.at_noise_floor() {
        // No wider search runs from a fit at the noise floor: it is the escalated fit.
        let round = first_round(data, quiet, spec, &unwidened, without, say)?;
        return Ok((unwidened, round));
    }
    let (widened, round) = std::thread::scope(|scope| {
        let widened = scope.spawn(|| widened_baseline(&data.train, quiet, spec, &unwidened));
        let round = first_round(data, quiet, spec, &unwidened, without, say);
        let widened = widened
            .join()
            .expect("the baseline's escalation does not panic");
        (widened, round)
    });
    // The wider search is a second opinion, as the final model's is: where it fails (a
    // record its start cannot simulate decimated), the first search's fit stands.
    let widened = match widened {
        Ok(fit) => fit,
        Err(e) => {
            eprintln!(
                "warning: the baseline's widened search failed ({e:#}); its first fit stands"
            );
            return Ok((unwidened, round?));
        }
    };
    let (baseline, improved) = settled(unwidened, widened);
    if !improved {
        return Ok((baseline, round?));
    }
    say("the baseline's wider search improved it: the effects are fitted again from there".into());
    let round = first_round(data, quiet, spec, &baseline, without, say)?;
    Ok((baseline, round))
}

/// The baseline's escalation: `first`, its first search of `spec` on the training records
/// `train`, widened as the final model is ([`widen_from`], everything `spec` frees
/// searched): the escalation's first wider FFO from its own optimum on the records
/// decimated to at most [`crate::fit::WIDENED_SAMPLES`] samples (on every sample where a
/// form of the model, or of an effect the user's bounds free, would not survive that:
/// [`forms_survive_decimation`]). Where that search gains 1 % on its start, the fit
/// refitted on every sample from its best, with the profile check of a base fit (the
/// baseline's unpinned parameters are reported); else `first`; either with every
/// evaluation counted. On the lab motor's 86,000 training samples the search simulates a
/// ninth of what `identify`'s escalation does on every sample
/// (docs/measurements/lab-motor.md, last section).
fn widened_baseline(
    train: &[OwnedRecord],
    quiet: &FitOptions,
    spec: &ProblemSpec,
    first: &Fit,
) -> Result<Fit> {
    let at = &first.result.params;
    let decimate = baseline_decimates(spec, at);
    let wide = widen_from(train, quiet, spec, spec, at, decimate, refit_checked_from)?;
    let searched = first.result.evaluations + wide.search_evaluations;
    let mut fit = wide.fit.unwrap_or_else(|| {
        let mut first = first.clone();
        first.result.evaluations = 0;
        first
    });
    fit.result.widened = 1;
    fit.result.evaluations += searched;
    Ok(fit)
}

/// Whether the baseline's escalation ([`widened_baseline`]) of `spec` from its first fit
/// `at` may search the records decimated: every form of the model and of each effect whose
/// parameters the user's bounds free survives that ([`forms_survive_decimation`]).
fn baseline_decimates(spec: &ProblemSpec, at: &ModelParams) -> bool {
    let freed: Vec<Effect> = Effect::ALL
        .into_iter()
        .filter(|e| e.params().iter().any(|id| spec.free[id.index()]))
        .collect();
    forms_survive_decimation(&freed, at)
}

/// What the search derives from the baseline before it picks an effect: what every fit of
/// the search shares (the baseline's parameters, the effects' scales, the order peaks of its
/// residual), where the baseline misfits, the held-out noise floor, and the first round, every usable effect of the catalogue added to the baseline and
/// scored (best held-out misfit first), with the left-out entries that a usable effect
/// extends (the reference its own part is judged against, never named).
pub(super) struct FirstRound<'a> {
    pub(super) cx: Context<'a>,
    pub(super) where_: regimes::WhereReport,
    pub(super) holdout: Holdout,
    pub(super) usable: Vec<Effect>,
    /// The entries no model takes in ([`super::effect_fit::UserFixes::left_out`]).
    pub(super) never: Vec<Effect>,
    pub(super) scored: Vec<(Effect, Scored)>,
    pub(super) left_out_parents: Vec<(Effect, Scored)>,
}

/// The [`FirstRound`] from the baseline fit `baseline` (a function of its parameters alone).
fn first_round<'a>(
    data: &'a Data,
    quiet: &FitOptions,
    spec: &ProblemSpec,
    baseline: &Fit,
    without: &[Effect],
    say: &(impl Fn(String) + Sync),
) -> Result<FirstRound<'a>> {
    let base_params = baseline.result.params;
    let traces = data.traces(&base_params)?;
    let where_ = regimes::analyse(&traces, baseline.result.sigma_omega);
    let peaks = Peaks::of(&traces, spec);
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
        current_noise: data.holdout_current_noise()?,
    };
    let scales = data.scales(&base_params);
    let cx = Context {
        data,
        quiet: quiet.clone(),
        spec: *spec,
        fixes: UserFixes::of(&quiet.fix),
        base_params,
        scales,
        peaks,
    };
    // Which: every effect of the catalogue the records can show and the user left to fit,
    // refitted on the training records (cogging only when told its detents per
    // revolution, above).
    let never = cx.fixes.left_out(without, spec);
    let usable: Vec<Effect> = Effect::ALL
        .into_iter()
        .filter(|e| (data.with_current || !e.needs_current()) && !never.contains(e))
        .filter(|e| *e != Effect::Cogging || peaks.detents.is_some())
        .collect();
    let add = |k: usize, effect: Effect| {
        say(format!(
            "fitting with {} ({}/{})",
            effect.name(),
            k + 1,
            usable.len()
        ));
        cx.add(spec, effect, &base_params)
    };
    let fits = fitted_unstalled(&cx, &usable, baseline, add, say)?;
    let mut scored: Vec<(Effect, Scored)> = usable.iter().copied().zip(fits).collect();
    scored.sort_by(|a, b| a.1.holdout_joint.total_cmp(&b.1.holdout_joint));
    let mut left_out_parents: Vec<(Effect, Scored)> = Vec::new();
    for p in usable.iter().filter_map(|e| e.parent()) {
        if without.contains(&p) && left_out_parents.iter().all(|(q, _)| *q != p) {
            left_out_parents.push((p, cx.add(spec, p, &base_params)?));
        }
    }
    Ok(FirstRound {
        cx,
        where_,
        holdout,
        usable,
        never,
        scored,
        left_out_parents,
    })
}

/// The baseline from its first search `unwidened` and its escalation `widened`
/// ([`widened_baseline`]): where the wider search gains less than the
/// escalation's rule on it ([`WIDER_GAIN`]: a fitness at most 0.99 times the first's is a
/// gain) it agrees, and the first search's fit stands (its parameters, cost and analysis),
/// reported with the escalation's searches and evaluations: the wider search's slightly
/// better point, under 1 % in fitness, is not kept (the effects are judged against a
/// baseline up to that much short; the held-out rules, which ask an effect for 2 % or
/// more, are not moved by it). Otherwise the widened fit. True when the widened fit is
/// taken.
fn settled(unwidened: Fit, widened: Fit) -> (Fit, bool) {
    let (first, wide) = (&unwidened.result, &widened.result);
    if wide.cost.fitness() <= WIDER_GAIN * first.cost.fitness() {
        return (widened, true);
    }
    let mut fit = unwidened;
    fit.result.widened = wide.widened;
    fit.result.evaluations = wide.evaluations;
    (fit, false)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::refit_from;
    use motor_id_shared::ParamId;

    /// A fit of a first-order step response (speed only): any fit serves, [`settled`] reads
    /// its cost and counts.
    fn some_fit() -> Fit {
        let dt = 1e-3;
        let v: Vec<f32> = (0..600).map(|k| if k < 300 { 12.0 } else { 6.0 }).collect();
        let mut omega = Vec::with_capacity(v.len());
        let mut w = 0.0f32;
        for volts in &v {
            omega.push(w);
            w += (dt / 0.05) * (20.0 * volts - w);
        }
        let record = crate::csvio::OwnedRecord {
            path: "step.csv".into(),
            t0: 0.0,
            dt,
            v,
            omega,
            current: None,
            load: None,
            coast_from: None,
            averaged: 1,
        };
        let opts = FitOptions {
            quiet: true,
            ..FitOptions::default()
        };
        fit_spec_unwidened(&[record], &opts, &ProblemSpec::default()).expect("a fit")
    }

    #[test]
    fn a_baseline_widened_where_the_wider_search_agrees_keeps_its_fit_and_counts_the_search() {
        // A motor with cogging fitted without it, 12,000 samples: the baseline stays above
        // its noise floor, at its optimum, which the escalation's wider FFO (4,100
        // evaluations, on the records decimated by 2) cannot beat.
        use crate::fit::tests::{cogged, quiet, record};
        let records = [record(&cogged(), 12, 1)];
        let spec = ProblemSpec::default();
        let first = fit_spec_unwidened(&records, &quiet(), &spec).expect("a fit");
        assert!(!first.result.at_noise_floor(), "{:?}", first.result.cost);
        let wide = widened_baseline(&records, &quiet(), &spec, &first).expect("widened");
        let alone = widen_from(
            &records,
            &quiet(),
            &spec,
            &spec,
            &first.result.params,
            true,
            refit_from,
        )
        .expect("the widened search alone");
        assert_eq!(alone.decimation, 2);
        assert!(alone.fit.is_none(), "the wider search agrees");
        assert_eq!(
            wide.result.evaluations,
            first.result.evaluations + alone.search_evaluations,
            "the decimated search counted once"
        );
        assert!(alone.search_evaluations > 4_100);
        let (kept, improved) = settled(first.clone(), wide);
        assert!(!improved, "the wider search agrees");
        for id in ParamId::MOTOR {
            let (a, b) = (kept.result.params.get(id), first.result.params.get(id));
            assert_eq!(a.to_bits(), b.to_bits(), "{id:?}");
        }
        assert_eq!(kept.result.widened, 1);
    }

    #[test]
    fn a_baseline_stalled_on_a_ridge_is_widened_past_it_and_taken() {
        // The motor measured (`--fix`), the user's bounds free cogging (8 per revolution,
        // told), and the first fit sits on its ridge half a turn off the phase, where least
        // squares take the amplitude to zero (crate::fit::tests): the baseline's
        // escalation, on every sample (cogging is searched), finds the detents, and the
        // widened fit is the baseline.
        use crate::fit::tests::{cogged, quiet, record};
        let truth = cogged();
        let records = [record(&truth, 12, 11)];
        let mut spec = ProblemSpec::default();
        for id in ParamId::MOTOR {
            spec.fix(id, truth.get(id)).unwrap();
        }
        spec.set_bounds(ParamId::CogAmp, 0.0, 0.5).unwrap();
        spec.free(ParamId::CogAmp);
        spec.set_bounds(ParamId::CogPhase, 0.0, core::f32::consts::TAU)
            .unwrap();
        spec.free(ParamId::CogPhase);
        spec.fix(ParamId::CogCycles, 8.0).unwrap();
        let ridge = truth.with(ParamId::CogPhase, 1.0 + core::f32::consts::PI);
        let first = refit_from(&records, &quiet(), &spec, &ridge).expect("a fit");
        let wide = widened_baseline(&records, &quiet(), &spec, &first).expect("widened");
        let (baseline, improved) = settled(first, wide);
        assert!(improved, "the wider search gains on the ridge");
        let amp = baseline.result.params.get(ParamId::CogAmp);
        assert!((amp - 0.1).abs() < 0.01, "cogging amplitude {amp}");
        assert_eq!(baseline.result.widened, 1);
    }

    #[test]
    fn the_baseline_is_searched_decimated_unless_a_form_of_it_or_of_a_freed_effect_is_lost() {
        let plain = ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08);
        let spec = ProblemSpec::default();
        assert!(baseline_decimates(&spec, &plain));
        // Coulomb friction freed by the user's bounds: its form survives a block's mean.
        let mut friction = spec;
        friction.set_bounds(ParamId::Tc, 0.0, 0.1).unwrap();
        friction.free(ParamId::Tc);
        assert!(baseline_decimates(&friction, &plain));
        // Cogging freed, its amplitude still at zero in the first fit: searched on every
        // sample all the same.
        let mut cogging = spec;
        cogging.set_bounds(ParamId::CogAmp, 0.0, 0.5).unwrap();
        cogging.free(ParamId::CogAmp);
        assert!(!baseline_decimates(&cogging, &plain));
        // A tacho ripple the user held on (`--fix`): its switch is on in the fit.
        let rippled = plain.with(ParamId::RippleAmp, 0.02);
        assert!(!baseline_decimates(&spec, &rippled));
    }

    #[test]
    fn the_baseline_s_first_search_stands_where_its_escalation_gains_under_one_percent() {
        let mut first = some_fit();
        first.result.cost.sse = 1.0;
        let mut wide = first.clone();
        wide.result.widened = 1;
        wide.result.evaluations = first.result.evaluations + 4_100;
        let kv = wide.result.params.get(ParamId::Kv);
        wide.result.params.set(ParamId::Kv, kv * 1.01);
        // A fitness 0.5 % lower (the fitness is the root of sse over the residuals).
        wide.result.cost.sse = first.result.cost.sse * 0.995f64.powi(2);
        let (kept, improved) = settled(first.clone(), wide.clone());
        assert!(!improved, "a wider search that gains 0.5 % agrees");
        assert_eq!(kept.result.params.get(ParamId::Kv).to_bits(), kv.to_bits());
        assert_eq!(kept.result.cost.sse, first.result.cost.sse);
        assert_eq!(kept.result.widened, 1);
        assert_eq!(kept.result.evaluations, wide.result.evaluations);
        // 0.7 % lower (an SSE 1.4 % lower): the fitness is judged, not the SSE.
        wide.result.cost.sse = first.result.cost.sse * 0.993f64.powi(2);
        assert!(!settled(first.clone(), wide.clone()).1);
        // 3 % lower: the first search was stuck, and the widened fit is the baseline.
        wide.result.cost.sse = first.result.cost.sse * 0.97f64.powi(2);
        let (moved, improved) = settled(first, wide);
        assert!(improved, "a wider search that gains 3 % does not agree");
        assert_eq!(moved.result.params.get(ParamId::Kv), kv * 1.01);
    }
}
