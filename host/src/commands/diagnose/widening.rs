//! The final model's fit widened before what it leaves is called unexplained.
//!
//! Every effect is fitted from the model it is added to: a short search of its own
//! parameters' basin, then least squares with everything free ([`super::effect_fit`]). A
//! refit that stalls short of its optimum leaves a misfit that is the search's, not the
//! model's, and the remainder would blame the records for it (an asymmetric friction named
//! right, its held-out misfit 0.97 rad/s where the true model reaches the noise, 0.78).
//! So when the final model holds an effect (the baseline's own fit has the escalation
//! already), its training fit stays above its noise floor and its held-out misfit is
//! unexplained, its search is widened as the escalation widens the base fit
//! ([`crate::fit::widen_from`]). The widened fit replaces it where it lowers the training
//! cost by 1 % or more (`WIDER_GAIN`, the escalation's own rule), and the verdict is judged
//! on it; otherwise the misfit is the model's, as the escalation concludes of the base fit.
//! (docs/ARCHITECTURE.md, the diagnosis' "Which".)

use super::data::{Data, Scored};
use super::effect_fit::effects_alone;
use crate::fit::{widen_from, FitOptions};
use crate::report::Num;
use anyhow::Result;
use motor_id_shared::fit::identify::WIDER_GAIN;
use motor_id_shared::model::effects::Effect;
use serde::Serialize;

/// What the widened search of the final model did (the verdict's `widened`).
#[derive(Serialize, Debug, Clone)]
pub struct WidenedRefit {
    /// Training speed RMSE of the final model as the search left it [rad/s].
    pub train_rmse_before: Num,
    /// Training speed RMSE of the widened fit [rad/s].
    pub train_rmse_widened: Num,
    /// Whether the widened fit lowered the training cost by 1 % or more and replaced the
    /// final model.
    pub taken: bool,
    /// Evaluations of the wider search.
    pub evaluations: u32,
    /// Rows of the records per sample of the wider search's (1: not decimated).
    pub decimation: usize,
}

impl WidenedRefit {
    /// What it did, in words.
    pub fn line(&self) -> String {
        let what = match self.taken {
            true => "it fits better and replaces the search's",
            false => "no better by 1 %: the misfit is the model's, not the search's",
        };
        format!(
            "the final model's fit, above its noise, was widened before its remainder was judged ({} evaluations, records decimated {}x): training rmse {:.4} -> {:.4} rad/s, {what}",
            self.evaluations, self.decimation, self.train_rmse_before.0, self.train_rmse_widened.0
        )
    }
}

/// Whether `effect`'s form survives the widened search's decimation (readings averaged
/// over blocks of several samples): not a tacho ripple's or cogging's cycles, which the
/// mean over a block attenuates or aliases, nor a delay of a sample or less. Those are
/// searched on every sample.
fn seen_decimated(effect: Effect) -> bool {
    !matches!(
        effect,
        Effect::TachoRipple | Effect::Cogging | Effect::SensorDelay
    )
}

/// The final model `last`, with the effects `named`, widened (with the user's fit options
/// `opts`, quiet) when it holds an effect and its training fit stays above its noise
/// floor: what the wider search did, and the widened fit scored on `data` when it is
/// taken. `None` when not widened.
pub fn widen(
    data: &Data,
    opts: &FitOptions,
    named: &[Effect],
    last: &Scored,
) -> Result<Option<(WidenedRefit, Option<Scored>)>> {
    let before = &last.fit.result;
    if named.is_empty() || before.at_noise_floor() {
        return Ok(None);
    }
    let spec = &last.fit.spec;
    let alone = effects_alone(spec, named, &before.params);
    let decimate = named.iter().all(|e| seen_decimated(*e));
    let widened = widen_from(&data.train, opts, &alone, spec, &before.params, decimate)?;
    let after = &widened.fit.result;
    let taken = after.cost.fitness() < WIDER_GAIN * before.cost.fitness();
    let refit = WidenedRefit {
        train_rmse_before: Num(before.cost.rmse_omega),
        train_rmse_widened: Num(after.cost.rmse_omega),
        taken,
        evaluations: widened.search_evaluations,
        decimation: widened.decimation,
    };
    let scored = match taken {
        true => Some(data.score(widened.fit)?),
        false => None,
    };
    Ok(Some((refit, scored)))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::refit_from;
    use crate::fit::tests::{quiet, record, rippled};
    use motor_id_shared::fit::space::ProblemSpec;
    use motor_id_shared::{ModelParams, ParamId};

    #[test]
    fn a_stalled_final_model_is_widened_and_replaced_a_converged_one_stands() {
        // A drive's current limit of 10 A; the final model's fit left it at 30 A, above
        // every current of the records, where its gradient is zero.
        let truth = ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08).with(ParamId::Imax, 10.0);
        let data = Data {
            train: vec![record(&truth, 24, 11)],
            holdout: vec![record(&truth, 8, 29)],
            with_current: true,
        };
        let mut spec = ProblemSpec::default();
        spec.set_bounds(ParamId::Imax, 0.5, 40.0).unwrap();
        spec.free(ParamId::Imax);
        let scored = |start: &ModelParams| {
            let fit = refit_from(&data.train, &quiet(), &spec, start).unwrap();
            data.score(fit).unwrap()
        };
        let stalled = scored(&truth.with(ParamId::Imax, 30.0));
        let limit = [Effect::CurrentLimit];
        let (refit, widened) = widen(&data, &quiet(), &limit, &stalled).unwrap().unwrap();
        assert!(refit.taken, "{refit:?}");
        assert_eq!(
            refit.decimation, 3,
            "24,000 training samples searched as 8,000"
        );
        let widened = widened.expect("taken: scored");
        assert!(
            widened.holdout_rmse < 0.5 * stalled.holdout_rmse,
            "held out {} against {}",
            widened.holdout_rmse,
            stalled.holdout_rmse
        );
        let imax = widened.fit.result.params.get(ParamId::Imax);
        assert!((imax - 10.0).abs() < 0.1, "imax {imax}");
        assert!(refit.line().contains("replaces"), "{}", refit.line());

        // At its noise floor: not widened.
        assert!(widen(&data, &quiet(), &limit, &scored(&truth))
            .unwrap()
            .is_none());

        // Converged above the floor (a Coulomb friction the model lacks): widened, no
        // better, not taken.
        let rubbing = truth.with(ParamId::Tc, 0.05);
        let data = Data {
            train: vec![record(&rubbing, 24, 11)],
            holdout: vec![record(&rubbing, 8, 29)],
            with_current: true,
        };
        let fit = refit_from(&data.train, &quiet(), &spec, &truth).unwrap();
        let converged = data.score(fit).unwrap();
        let (refit, widened) = widen(&data, &quiet(), &limit, &converged).unwrap().unwrap();
        assert!(!refit.taken && widened.is_none(), "{refit:?}");
        assert!(refit.line().contains("the model's, not the search's"));
        // No effect named: the baseline's own fit had the escalation.
        assert!(widen(&data, &quiet(), &[], &stalled).unwrap().is_none());
    }

    #[test]
    fn a_verdict_is_judged_on_the_widened_model_where_it_is_taken() {
        // The search names the tacho's ripple; its fit then stalled (started half a turn
        // off its phase, least squares took its amplitude to zero): the verdict says what
        // is left of the widened model, not of it. (What the search found leaves a
        // remainder here: the ripple's phase follows the model's integrated angle.)
        let truth = rippled();
        let data = Data {
            train: vec![record(&truth, 12, 11)],
            holdout: vec![record(&truth, 6, 29)],
            with_current: true,
        };
        let opts = quiet();
        let mut found = super::super::search::search(&data, &opts, &[]).unwrap();
        let named: Vec<Effect> = found.named().map(|(e, _)| e).collect();
        assert_eq!(named, [Effect::TachoRipple]);
        let last = found.last().fit.clone();
        let searched_rmse = found.last().holdout_rmse;
        let phase = last.result.params.get(ParamId::RipplePhase);
        let off = (phase + core::f32::consts::PI).rem_euclid(core::f32::consts::TAU);
        let stalled = last.result.params.with(ParamId::RipplePhase, off);
        let fit = refit_from(&data.train, &opts, &last.spec, &stalled).unwrap();
        found.chain[0].1 = data.score(fit).unwrap();
        let stalled_rmse = found.last().holdout_rmse;
        assert!(
            stalled_rmse > 5.0 * found.holdout.noise,
            "stalled: {stalled_rmse}"
        );
        let mut reader = crate::csvio::RecordReader::new(&Default::default());
        let repeats = super::super::repeatability::Repeats::find(&data, &[], &mut reader).unwrap();
        let current_noise = found.holdout.current_noise;
        let (_, left) =
            super::super::judge(&data, &mut found, &opts, &repeats, current_noise).unwrap();
        let refit = left.widened.expect("widened");
        assert!(refit.taken && refit.decimation == 1, "{refit:?}");
        // Back to what the search had found, and what is left is the widened model's.
        let after = found.last();
        assert!(
            after.holdout_rmse < 1.01 * searched_rmse,
            "{} against {searched_rmse}",
            after.holdout_rmse
        );
        if let Some(r) = &left.remainder {
            let over_noise = after.holdout_rmse / found.holdout.noise;
            assert!(
                (r.over_noise.0 - over_noise).abs() < 1e-3 * over_noise,
                "{r:?}"
            );
        }
        let amp = after.fit.result.params.get(ParamId::RippleAmp);
        assert!((amp - 0.05).abs() < 0.005, "ripple amplitude {amp}");
    }
}
