//! One effect added to a model: its parameters freed within bounds scaled to the model's
//! (`with_effect`), then fitted in two stages, the effect alone and then everything
//! (`fit_effect`). Used by the search ([`super::search`]).

use super::data::Data;
use super::spectrum::OrderPeak;
use crate::fit::{fit_from, refit_from, Fit, FitOptions};
use anyhow::{anyhow, Result};
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::model::effects::{Effect, Scales};
use motor_id_shared::{ModelParams, ParamId};

/// `spec` with `effect` free within bounds scaled to `base`, and the effect it extends with
/// it (user bounds or fixes on their parameters are kept); for the tacho ripple the number of cycles is the order found in the
/// residual, held fixed (the phase and amplitude are fitted).
pub fn with_effect(
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
/// parameters alone with everything else held at `base` (a global search of one to three
/// dimensions, started for the ripple from the order spectrum's amplitude and phase), then
/// everything free from there by least squares (the start lies in the basin already).
pub fn fit_effect(
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
    let first = fit_from(&data.train, opts, &alone, &start)?;
    refit_from(&data.train, opts, spec, &first.result.params)
}
