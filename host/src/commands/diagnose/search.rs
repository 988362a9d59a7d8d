//! The search over the catalogue: the baseline fitted on the training records, every effect
//! added to it and refitted, the first that passes the significance rule, and a second one
//! on top of that.

use super::data::{Data, Scored};
use super::regimes::{self, WhereReport};
use super::spectrum::{order_peak, OrderPeak};
use super::verdict::{significant, Holdout};
use crate::fit::{fit_from, Fit, FitOptions};
use anyhow::{anyhow, Result};
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::model::effects::{Effect, Scales};
use motor_id_shared::{ModelParams, ParamId};

/// What the search found.
pub struct Search {
    /// The model without effects.
    pub baseline: Scored,
    /// The held-out records' scales.
    pub holdout: Holdout,
    /// The records' scales.
    pub scales: Scales,
    /// Where the baseline misfits.
    pub where_: WhereReport,
    /// Every effect of the catalogue added to the baseline, best held-out RMSE first.
    pub scored: Vec<(Effect, Scored)>,
    /// The best effect that passes the significance rule.
    pub first: Option<Effect>,
    /// The best effect on top of the first that passes it.
    pub second: Option<(Effect, Scored)>,
}

impl Search {
    /// The first effect with its fit.
    pub fn chosen(&self) -> Option<&(Effect, Scored)> {
        self.first
            .and_then(|e| self.scored.iter().find(|(x, _)| *x == e))
    }

    /// The effect the data needs of `effect` and the one it extends: the parent, unless
    /// `effect`'s fit passes the significance rule against the parent's own fit (a nested
    /// effect that only matches its parent is not named).
    pub fn needed(&self, effect: Effect) -> Effect {
        let Some(parent) = effect.parent() else {
            return effect;
        };
        let fit = |e: Effect| self.scored.iter().find(|(x, _)| *x == e).map(|(_, s)| s);
        match (fit(effect), fit(parent)) {
            (Some(child), Some(parent_fit)) if self.significant(parent, parent_fit) => {
                let candidate = child.candidate(effect, &self.scales);
                if significant(&parent_fit.reference(), &candidate, &self.holdout) {
                    effect
                } else {
                    parent
                }
            }
            _ => effect,
        }
    }

    /// Whether `effect`'s fit passes the significance rule against the baseline.
    pub fn significant(&self, effect: Effect, s: &Scored) -> bool {
        let candidate = s.candidate(effect, &self.scales);
        significant(&self.baseline.reference(), &candidate, &self.holdout)
    }
}

/// Run the search on `data` with the user's fit options (`opts.quiet` silences the steps'
/// messages; the fits themselves show no progress bar).
pub fn search(data: &Data, opts: &FitOptions) -> Result<Search> {
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
    let baseline = data.score(fit_from(&data.train, &quiet, &spec, None)?)?;
    let base_params = baseline.fit.result.params;
    let holdout = Holdout {
        noise: data.holdout_noise()?,
        signal_rms: data.holdout_rms(),
    };
    let traces = data.traces(&base_params)?;
    let where_ = regimes::analyse(&traces, baseline.fit.result.sigma_omega);
    let ripple = order_peak(&traces);
    let order = ripple.order;
    let scales = data.scales(&base_params);

    // Which: every effect of the catalogue, refitted on the training records.
    let mut scored: Vec<(Effect, Scored)> = Vec::new();
    for (k, effect) in Effect::ALL.iter().enumerate() {
        say(format!(
            "fitting with {} ({}/{})",
            effect.name(),
            k + 1,
            Effect::ALL.len()
        ));
        let s = with_effect(&spec, *effect, &base_params, &scales, order)?;
        let f = fit_effect(data, &quiet, &s, *effect, &ripple)?;
        scored.push((*effect, data.score(f)?));
    }
    scored.sort_by(|a, b| a.1.holdout_rmse.total_cmp(&b.1.holdout_rmse));
    let mut found = Search {
        baseline,
        holdout,
        scales,
        where_,
        scored,
        first: None,
        second: None,
    };
    found.first = found
        .scored
        .iter()
        .find(|(e, s)| found.significant(*e, s))
        .map(|(e, _)| found.needed(*e));

    // A second effect, on what is left after the first.
    let mut second: Option<(Effect, Scored)> = None;
    if let Some((e1, first_fit)) = found.chosen() {
        let p1 = first_fit.fit.result.params;
        let mut spec1 = with_effect(&spec, *e1, &base_params, &scales, order)?;
        spec1.base = p1;
        let reference1 = first_fit.reference();
        for effect in Effect::ALL.iter().filter(|e| *e != e1) {
            say(format!("fitting {} on top of {}", effect.name(), e1.name()));
            let s = with_effect(&spec1, *effect, &p1, &scales, order)?;
            let f = data.score(fit_effect(data, &quiet, &s, *effect, &ripple)?)?;
            if significant(&reference1, &f.candidate(*effect, &scales), &found.holdout)
                && second
                    .as_ref()
                    .is_none_or(|(_, b)| f.holdout_rmse < b.holdout_rmse)
            {
                second = Some((*effect, f));
            }
        }
    }
    found.second = second;
    Ok(found)
}

/// `spec` with `effect` free within bounds scaled to `base`, and the effect it extends with
/// it (user bounds or fixes on their parameters are kept); for the tacho ripple the number of cycles is the order found in the
/// residual, held fixed (the phase and amplitude are fitted).
fn with_effect(
    spec: &ProblemSpec,
    effect: Effect,
    base: &ModelParams,
    scales: &Scales,
    order: u32,
) -> Result<ProblemSpec> {
    let mut s = *spec;
    s.base = *base;
    let own = effect.bounds(base, scales);
    let parents = effect.parent().map(|p| p.bounds(base, scales));
    for (id, lo, hi) in own.into_iter().chain(parents.into_iter().flatten()) {
        if id == ParamId::RippleCycles {
            if spec.free[id.index()] {
                continue;
            }
            s.fix(id, order as f32).map_err(|e| anyhow!("{e}"))?;
            continue;
        }
        let user_fixed = !spec.free[id.index()] && spec.base.get(id) != 0.0;
        if user_fixed || spec.free[id.index()] {
            continue;
        }
        s.set_bounds(id, lo, hi)
            .map_err(|e| anyhow!("{} bounds: {e}", effect.name()))?;
        s.free(id);
    }
    Ok(s)
}

/// Fit `spec` (an effect added to the model in `spec.base`) in two stages: the effect's
/// parameters alone with everything else held at `base` (a search of one to three
/// dimensions, started for the ripple from the order spectrum's amplitude and phase), then
/// everything free from there.
fn fit_effect(
    data: &Data,
    opts: &FitOptions,
    spec: &ProblemSpec,
    effect: Effect,
    ripple: &OrderPeak,
) -> Result<Fit> {
    // The spec's base holds the model to add the effect to, and the effect's fixed values.
    let mut start = spec.base;
    if effect == Effect::TachoRipple {
        let (lo, hi) = spec.bounds[ParamId::RippleAmp.index()];
        start.set(ParamId::RippleAmp, (ripple.amp as f32).clamp(lo, hi));
        start.set(ParamId::RipplePhase, ripple.phase as f32);
    }
    let mut alone = *spec;
    alone.base = start;
    let parent = effect.parent().map_or(&[][..], |p| p.params());
    for id in ParamId::ALL {
        let part = effect.params().contains(&id) || parent.contains(&id);
        if !part && alone.free[id.index()] {
            alone.free[id.index()] = false;
        }
    }
    let first = fit_from(&data.train, opts, &alone, Some(&start))?;
    fit_from(&data.train, opts, spec, Some(&first.result.params))
}
