//! One effect added to a model: its parameters freed within bounds scaled to the model's
//! (`with_effect`), then fitted in two stages, the effect alone and then everything
//! (`fit_effect`). Used by the search ([`super::search`]).

use super::data::Data;
use super::data::Trace;
use super::spectrum::{order_fit, order_peak, OrderPeak, Shape};
use super::widening::forms_survive_decimation;
use crate::fit::{fit_basin_from, refit_from, searched_records, Fit, FitOptions};
use crate::spec::FixSpec;
use anyhow::{anyhow, Result};
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::model::effects::{Effect, Scales};
use motor_id_shared::param_id::PARAM_COUNT;
use motor_id_shared::{ModelParams, ParamId};

/// The parameters the user held with `--fix`, told by name and not by value: a fix at a
/// parameter's default (`--fix tc=0`, `--fix ripple_cycles=1`) is a fix too (judged by
/// value, it was freed for Coulomb friction, and a once-per-revolution ripple took the
/// residual's order).
#[derive(Clone, Copy, Debug, Default)]
pub struct UserFixes([bool; PARAM_COUNT]);

impl UserFixes {
    /// The parameters of the user's `--fix` options.
    pub fn of(fix: &[FixSpec]) -> UserFixes {
        let mut out = UserFixes::default();
        for (id, _) in fix.iter().flat_map(|f| &f.0) {
            out.0[id.index()] = true;
        }
        out
    }

    /// Whether the user fixed `id`.
    pub fn holds(&self, id: ParamId) -> bool {
        self.0[id.index()]
    }

    /// Whether the user left `effect` something to fit: not switched off (its first
    /// parameter, which turns it on, fixed at zero), and not every one of its parameters
    /// fixed (the baseline then holds it as the user gave it).
    pub fn leave_to_fit(&self, effect: Effect, spec: &ProblemSpec) -> bool {
        let own = effect.params();
        let off = own
            .first()
            .is_some_and(|&id| self.holds(id) && spec.base.get(id) == 0.0);
        !off && !own.iter().all(|&id| self.holds(id))
    }

    /// The entries no model of the search takes in, not even in place of an extension
    /// dropped from it: those left out (`without`), and those these fixes switch off or
    /// hold whole ([`UserFixes::leave_to_fit`]).
    pub fn left_out(&self, without: &[Effect], spec: &ProblemSpec) -> Vec<Effect> {
        Effect::ALL
            .into_iter()
            .filter(|e| without.contains(e) || !self.leave_to_fit(*e, spec))
            .collect()
    }
}

/// The order spectra's peaks of a model's residual (the baseline's, or that of the model an
/// effect is added to: [`super::search_context::Context::for_adding`]) that start the angle
/// effects' fits.
#[derive(Clone, Copy, Debug)]
pub struct Peaks {
    /// The tacho ripple's ([`Shape::Ripple`]).
    pub ripple: OrderPeak,
    /// Cogging's detents per revolution, when the user gives them (`--fix cog_cycles=N`):
    /// its speed ripple is too weak to find the order in the residual (static friction
    /// mimics the detents' hold at a start; a search over orders picks a trend's at order
    /// 1), so that the diagnosis tries cogging only when told.
    pub detents: Option<u32>,
    /// Cogging's fit at those detents ([`Shape::Cogging`]).
    pub cogging: OrderPeak,
}

impl Peaks {
    /// The peaks of a model's residual `traces` for the user's problem `spec`.
    pub fn of(traces: &[Trace], spec: &ProblemSpec) -> Peaks {
        let id = ParamId::CogCycles.index();
        let detents = match spec.free[id] {
            false => Some(spec.base.get(ParamId::CogCycles))
                .filter(|n| *n >= 1.0)
                .map(|n| n.round() as u32),
            true => None,
        };
        Peaks {
            ripple: order_peak(traces),
            detents,
            cogging: detents
                .and_then(|n| order_fit(traces, Shape::Cogging, n))
                .unwrap_or(OrderPeak::NONE),
        }
    }
}

impl Peaks {
    /// The phase the order spectrum's peak gives `effect`'s ripple, in [0, 2 pi): the tacho
    /// ripple's, or cogging's (the speed ripple of a detent torque `A sin(n theta + phi)` is
    /// `A / (J n w) cos(n theta + phi)`, paper Eq. 4 over one detent period: the peak's
    /// phase less a quarter turn); None for another effect.
    pub fn phase_of(&self, effect: Effect) -> Option<f32> {
        let tau = std::f64::consts::TAU;
        let phase = match effect {
            Effect::TachoRipple => self.ripple.phase,
            Effect::Cogging => self.cogging.phase - std::f64::consts::FRAC_PI_2,
            _ => return None,
        };
        // (None for a spectrum of a residual that is not finite.)
        phase.is_finite().then(|| phase.rem_euclid(tau) as f32)
    }
}

/// `spec` with `effect` free within bounds scaled to `base`, and the effect it extends with
/// it (user bounds or fixes on their parameters are kept); for the tacho ripple and cogging
/// the number of cycles is the order found in the residual of the model it is added to
/// ([`Peaks`]), held fixed (the phase and amplitude are fitted).
pub fn with_effect(
    spec: &ProblemSpec,
    effect: Effect,
    base: &ModelParams,
    (scales, peaks): (&Scales, &Peaks),
    fixes: &UserFixes,
) -> Result<ProblemSpec> {
    let mut s = *spec;
    s.base = *base;
    let own = effect.bounds(base, scales);
    let parents = effect.parent().map(|p| p.bounds(base, scales));
    for (id, lo, hi) in own.into_iter().chain(parents.into_iter().flatten()) {
        let order = match id {
            ParamId::RippleCycles => Some(peaks.ripple.order),
            ParamId::CogCycles => Some(peaks.cogging.order),
            _ => None,
        };
        let user_fixed = fixes.holds(id);
        if let Some(order) = order {
            // The user's bounds or value stand (a motor's detents per revolution are on its
            // datasheet); otherwise the order the residual shows.
            if spec.free[id.index()] || user_fixed {
                continue;
            }
            s.fix(id, order as f32).map_err(|e| anyhow!("{e}"))?;
            continue;
        }
        if user_fixed || spec.free[id.index()] {
            continue;
        }
        // A phase's box is a turn centred on the phase the model it is added to holds (a
        // refit's), or else on the spectrum's: its ends are the worst phases, where nothing
        // draws a search (a box from 0 drew the ripple's search to its bound at 0, 2 rad
        // off, as the tracker of the ripple's angle flattens the phase's objective away
        // from the truth; and a refit's phase held in a box centred elsewhere was clamped
        // to an end of it).
        let (lo, hi) = match phase_centre(effect, id, base, peaks) {
            Some(phase) => (phase - core::f32::consts::PI, phase + core::f32::consts::PI),
            None => (lo, hi),
        };
        s.set_bounds(id, lo, hi)
            .map_err(|e| anyhow!("{} bounds: {e}", effect.name()))?;
        s.free(id);
    }
    Ok(s)
}

/// The centre of the box of `id` when it is `effect`'s phase: the phase `base` holds when
/// the effect is on there (a refit of a model that holds it), else the spectrum's
/// ([`Peaks::phase_of`]).
fn phase_centre(effect: Effect, id: ParamId, base: &ModelParams, peaks: &Peaks) -> Option<f32> {
    let switch = match id {
        ParamId::RipplePhase => ParamId::RippleAmp,
        ParamId::CogPhase => ParamId::CogAmp,
        _ => return None,
    };
    let held = base.get(id);
    match base.get(switch) != 0.0 && held.is_finite() {
        true => Some(held),
        false => peaks.phase_of(effect),
    }
}

/// Fit `spec` (an effect added to the model in `spec.base`) in two stages
/// ([`in_two_stages`]): the effect's parameters alone with everything else held at `base`
/// (a short global search of one to three dimensions for the basin, [`fit_basin_from`],
/// started for the ripple and for cogging from the order spectrum's amplitude and phase),
/// then everything free from there by least squares on every sample (the start lies in the
/// basin already).
pub fn fit_effect(
    data: &Data,
    opts: &FitOptions,
    spec: &ProblemSpec,
    effect: Effect,
    peaks: &Peaks,
) -> Result<Fit> {
    // The spec's base holds the model to add the effect to, and the effect's fixed values;
    // the angle effects start at the spectrum's amplitude and phase, where free (within
    // their boxes: `ProblemSpec::point`; a fixed one keeps its value).
    let mut start = spec.base;
    let phase = peaks.phase_of(effect).unwrap_or(0.0);
    match effect {
        Effect::TachoRipple => {
            start.set(ParamId::RippleAmp, peaks.ripple.amp as f32);
            start.set(ParamId::RipplePhase, phase);
        }
        Effect::Cogging => {
            // The spectrum's amplitude of the speed ripple times J n is the detent torque
            // ([`Peaks::phase_of`]).
            let peak = &peaks.cogging;
            let torque = peak.amp * spec.base.get(ParamId::J) as f64 * peak.order as f64;
            start.set(ParamId::CogAmp, torque as f32);
            start.set(ParamId::CogPhase, phase);
        }
        _ => {}
    }
    let start = spec.point(&start);
    let alone = effects_alone(spec, &[effect], &start);
    let decimate = forms_survive_decimation(&[effect], &start);
    Ok(in_two_stages(data, opts, (spec, &alone), &start, decimate)?.fit)
}

/// An effect's fit from `start` in its two stages ([`fit_effect`], and a stalled refit's
/// search again, [`super::stalled`]), with what the first one searched.
pub(super) struct TwoStages {
    /// The refit with everything free on every sample.
    pub fit: Fit,
    /// Evaluations of the basin's search (on the records it searched).
    pub basin_evaluations: u32,
    /// Rows of a record per sample of the records the basin's search read (1: every sample).
    pub decimation: usize,
}

/// The basin of `alone` (an effect's parameters, added to `spec`'s model, the rest held at
/// `start`) searched from `start` on the training records as the widened search reads
/// them ([`searched_records`]: with `decimate`, decimated to at most
/// [`crate::fit::WIDENED_SAMPLES`] samples; [`forms_survive_decimation`] says when), then
/// `spec` refitted by least squares on every sample from its best. The basin's search
/// finds the basin, the refit on every sample converges in it: on the lab motor's 86,000
/// training samples the search reads a ninth of them.
pub(super) fn in_two_stages(
    data: &Data,
    opts: &FitOptions,
    (spec, alone): (&ProblemSpec, &ProblemSpec),
    start: &ModelParams,
    decimate: bool,
) -> Result<TwoStages> {
    let (searched, decimation) = searched_records(&data.train, decimate);
    let basin = fit_basin_from(&searched, opts, alone, start)?;
    let fit = refit_from(&data.train, opts, spec, &basin.result.params)?;
    Ok(TwoStages {
        fit,
        basin_evaluations: basin.result.evaluations,
        decimation,
    })
}

/// `spec` with only the parameters of `effects` and of the entries they extend free,
/// everything else held at `at`: the search of the effects' own basin.
pub fn effects_alone(spec: &ProblemSpec, effects: &[Effect], at: &ModelParams) -> ProblemSpec {
    let mut alone = *spec;
    alone.base = *at;
    for id in ParamId::ALL {
        let part = effects.iter().any(|e| {
            e.params().contains(&id) || e.parent().is_some_and(|p| p.params().contains(&id))
        });
        if !part {
            alone.free[id.index()] = false;
        }
    }
    alone
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The parameters `spec` leaves free.
    fn free(spec: &ProblemSpec) -> Vec<ParamId> {
        ParamId::ALL
            .into_iter()
            .filter(|id| spec.free[id.index()])
            .collect()
    }

    #[test]
    fn an_effect_alone_frees_its_own_and_its_parent_s_parameters_only() {
        let mut spec = ProblemSpec::default();
        for id in [ParamId::Tc, ParamId::Ts, ParamId::Ws, ParamId::RippleAmp] {
            spec.set_bounds(id, 0.0, 0.1).unwrap();
            spec.free(id);
        }
        let at = ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08).with(ParamId::Tc, 0.3);
        let alone = effects_alone(&spec, &[Effect::StaticFriction], &at);
        assert_eq!(free(&alone), [ParamId::Tc, ParamId::Ts, ParamId::Ws]);
        assert_eq!(alone.base, at);
        assert_eq!(alone.bounds, spec.bounds);
        let both = effects_alone(&spec, &[Effect::StaticFriction, Effect::TachoRipple], &at);
        assert_eq!(
            free(&both),
            [ParamId::Tc, ParamId::RippleAmp, ParamId::Ts, ParamId::Ws]
        );
        // A parameter the user fixed stays fixed.
        let mut fixed = spec;
        fixed.free[ParamId::Ts.index()] = false;
        let alone = effects_alone(&fixed, &[Effect::StaticFriction], &at);
        assert_eq!(free(&alone), [ParamId::Tc, ParamId::Ws]);
    }

    #[test]
    fn an_effect_s_basin_is_searched_on_the_records_decimated_where_every_form_survives() {
        // 14 s at 1 kHz (14,000 samples, above the 10,000 a widened search reads) of a motor
        // with Coulomb friction of 0.05 N m.
        use crate::commands::diagnose::data::simulated;
        use crate::fit::tests::quiet;
        let motor = ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08);
        let truth = motor.with(ParamId::Tc, 0.05);
        let data = simulated(&truth, &truth, (14, 2));
        let scales = data.scales(&motor);
        let peaks = Peaks {
            ripple: OrderPeak::NONE,
            detents: None,
            cogging: OrderPeak::NONE,
        };
        let fixes = UserFixes::default();
        let two_stages = |at: &ModelParams, effect: Effect| {
            let model = crate::spec::problem(&[], &[]).unwrap();
            let spec = with_effect(&model, effect, at, (&scales, &peaks), &fixes).unwrap();
            let alone = effects_alone(&spec, &[effect], at);
            let decimate = forms_survive_decimation(&[effect], at);
            in_two_stages(&data, &quiet(), (&spec, &alone), at, decimate).unwrap()
        };
        // Coulomb friction's basin on the records decimated by 2, its refit on every sample
        // converged there: within 2 % of the truth's own least squares, `tc` within 2 %.
        let coulomb = two_stages(&motor, Effect::CoulombFriction);
        assert_eq!(coulomb.decimation, 2);
        let spec = coulomb.fit.spec;
        let at_truth = refit_from(&data.train, &quiet(), &spec, &truth).unwrap();
        let objective = |f: &Fit| f.result.cost.fitness();
        assert!(objective(&coulomb.fit) < 1.02 * objective(&at_truth));
        let tc = coulomb.fit.result.params.get(ParamId::Tc);
        assert!((tc - 0.05).abs() < 1e-3, "tc {tc}");
        // Not where a form in the model is lost by the means over blocks: Coulomb friction
        // added to a model with a tacho ripple.
        let rippled = motor
            .with(ParamId::RippleAmp, 0.01)
            .with(ParamId::RippleCycles, 8.0);
        assert_eq!(two_stages(&rippled, Effect::CoulombFriction).decimation, 1);
    }
}
