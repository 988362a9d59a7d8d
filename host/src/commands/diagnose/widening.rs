//! The final model's fit widened before what it leaves is called unexplained.
//!
//! Every effect is fitted from the model it is added to: a short search of its own
//! parameters' basin, then least squares with everything free ([`super::effect_fit`]). A
//! refit that stalls short of its optimum leaves a misfit that is the search's, not the
//! model's, and the remainder would blame the records for it (an asymmetric friction named
//! right, its held-out misfit 0.97 rad/s where the true model reaches the noise, 0.78).
//! So when the final model holds an effect, its training fit stays above its noise floor
//! and its held-out misfit is above 1.2 times the floor (on the speed against the noise or
//! the repeatability floor, or on the current against its noise: what the remainder
//! judges, [`super::remainder`]), the search of its effects' own parameters is widened as
//! the escalation widens the base fit, and everything refitted from there
//! ([`crate::fit::widen_from`]). The widened fit replaces it where it lowers the training
//! cost by 1 % or more (`WIDER_GAIN`, the escalation's own rule), before the search builds
//! its chain's steps from the final fit and weighs the look-alikes on it
//! ([`super::search`]); otherwise the misfit is the model's, as the escalation concludes
//! of the base fit. (docs/ARCHITECTURE.md, the diagnosis' "Which".)

use super::data::{Data, Scored};
use super::effect_fit::effects_alone;
use super::remainder::{floor, unexplained};
use super::verdict::Holdout;
use crate::fit::{refit_from, widen_from, FitOptions};
use crate::report::Num;
use anyhow::Result;
use motor_id_shared::fit::identify::WIDER_GAIN;
use motor_id_shared::model::effects::{Effect, SWITCHES};
use motor_id_shared::ModelParams;
use serde::Serialize;

/// What the widened search of the final model did (the verdict's `widened`).
#[derive(Serialize, Debug, Clone)]
pub struct WidenedRefit {
    /// Evaluations on the records searched: least squares from the final model, then the
    /// wider FFO and its least squares.
    pub evaluations: u32,
    /// Rows of a record per sample of the records searched (1: every sample; a record too
    /// short for it is searched whole).
    pub decimation: usize,
    /// The training objective (the speed's and, when fitted, the current's misfit, each
    /// over its noise) on the records searched, at the final model's own optimum there.
    pub searched_before: Num,
    /// The same at the wider search's best.
    pub searched_widened: Num,
    /// Training speed RMSE of the final model as the search left it [rad/s].
    pub train_rmse_before: Num,
    /// The training objective of the final model as the search left it.
    pub objective_before: Num,
    /// Training speed RMSE of the refit on every sample from the wider search's best
    /// (`null`: the search gained under 1 %, nothing refitted) [rad/s].
    pub train_rmse_widened: Option<Num>,
    /// Its training objective.
    pub objective_widened: Option<Num>,
    /// Whether that refit lowered the training objective by 1 % or more and replaced the
    /// final model.
    pub taken: bool,
}

impl WidenedRefit {
    /// What it did, in words.
    pub fn line(&self) -> String {
        let records = match self.decimation {
            1 => "on every sample".to_string(),
            k => format!("on the records decimated {k}x"),
        };
        let searched = format!(
            "the final model's fit, above its noise, was widened before its remainder was judged ({} evaluations {records}: objective {:.4} -> {:.4})",
            self.evaluations, self.searched_before.0, self.searched_widened.0
        );
        let Some((rmse, objective)) = self.train_rmse_widened.zip(self.objective_widened) else {
            return format!(
                "{searched}, no better by 1 %: the misfit is the model's, not the search's"
            );
        };
        let what = match self.taken {
            true => "it fits better and replaces the search's",
            false => "no better by 1 % there: the search's stands",
        };
        format!(
            "{searched}; refitted on every sample: training rmse {:.4} -> {:.4} rad/s (objective {:.4} -> {:.4}), {what}",
            self.train_rmse_before.0, rmse.0, self.objective_before.0, objective.0
        )
    }
}

/// Whether `effect`'s form survives the widened search's decimation (readings averaged
/// over blocks of several samples): not a tacho ripple's or cogging's cycles, which the
/// mean over a block attenuates or aliases, nor a delay of a sample or less, nor a drive's
/// current limit, whose form is the current's flat top reached within a few electrical
/// time constants (a decimated record's step is taken long against `La/Ra`, as its doc
/// asks, docs/CONTRACTS.md, and the mean of a clamped voltage is not the mean voltage
/// clamped: on 40 s records at 10 kHz, decimated 43 times, the basin's search lost a
/// limit that every sample shows). Those are searched on every sample.
pub(super) fn seen_decimated(effect: Effect) -> bool {
    !matches!(
        effect,
        Effect::TachoRipple | Effect::Cogging | Effect::SensorDelay | Effect::CurrentLimit
    )
}

/// Whether a search of `effects` in the model `at` may read the records decimated: their
/// forms and that of every entry switched on in `at` (its switch non-zero, as the
/// simulator reads it: a user's fixed ripple too) survive it ([`seen_decimated`]).
pub(super) fn forms_survive_decimation(effects: &[Effect], at: &ModelParams) -> bool {
    let mut on = Effect::ALL
        .into_iter()
        .filter(|e| at.get(SWITCHES[*e as usize]) != 0.0);
    effects.iter().all(|e| seen_decimated(*e)) && on.all(seen_decimated)
}

/// Whether the final model `fin` leaves the held-out records of `holdout` unexplained:
/// its speed's misfit above 1.2 times the floor (the noise, or `repeat_floor` when larger)
/// or its current's above 1.2 times its noise, as [`super::remainder`] judges them.
pub fn leaves_unexplained(fin: &Scored, holdout: &Holdout, repeat_floor: Option<f32>) -> bool {
    let (speed_floor, _) = floor(holdout.noise, repeat_floor);
    unexplained(fin.holdout_rmse, speed_floor)
        || fin
            .holdout_rmse_current
            .zip(holdout.current_noise)
            .is_some_and(|(rmse, noise)| unexplained(rmse, noise))
}

/// The final model `fin` of the effects `set`, widened (with the search's fit options
/// `opts`) when it holds an effect, its training fit stays above its noise floor and it
/// leaves the held-out records unexplained ([`leaves_unexplained`]): the model to report
/// (the widened fit, scored on `data`, where it is taken) and what the widening did. A
/// widened search that fails (a record its start cannot simulate) leaves `fin` as it is
/// and says so on stderr: it is a second opinion, not the diagnosis.
pub fn widened_final(
    data: &Data,
    opts: &FitOptions,
    set: &[Effect],
    fin: Scored,
    holdout: &Holdout,
    repeat_floor: Option<f32>,
    say: &dyn Fn(String),
) -> (Scored, Option<WidenedRefit>) {
    let above = !fin.fit.result.at_noise_floor();
    if set.is_empty() || !above || !leaves_unexplained(&fin, holdout, repeat_floor) {
        return (fin, None);
    }
    say("widening the final model's search before judging what it leaves".into());
    match widen(data, opts, set, &fin) {
        Ok((refit, Some(widened))) => (widened, Some(refit)),
        Ok((refit, None)) => (fin, Some(refit)),
        Err(e) => {
            eprintln!(
                "warning: the final model's widened search failed ({e:#}); the search's fit stands"
            );
            (fin, None)
        }
    }
}

/// `last`, the final model of the effects `named`, widened: what the wider search did, and
/// the widened fit scored on `data` when it is taken.
fn widen(
    data: &Data,
    opts: &FitOptions,
    named: &[Effect],
    last: &Scored,
) -> Result<(WidenedRefit, Option<Scored>)> {
    let before = &last.fit.result;
    let spec = &last.fit.spec;
    let alone = effects_alone(spec, named, &before.params);
    let decimate = forms_survive_decimation(named, &before.params);
    let widened = widen_from(
        &data.train,
        opts,
        &alone,
        spec,
        &before.params,
        decimate,
        refit_from,
    )?;
    let after = widened.fit.as_ref().map(|f| f.result.cost);
    let taken = after.is_some_and(|a| a.fitness() < WIDER_GAIN * before.cost.fitness());
    let refit = WidenedRefit {
        evaluations: widened.search_evaluations,
        decimation: widened.decimation,
        searched_before: Num(widened.searched_start),
        searched_widened: Num(widened.searched_widened),
        train_rmse_before: Num(before.cost.rmse_omega),
        objective_before: Num(before.cost.fitness()),
        train_rmse_widened: after.map(|a| Num(a.rmse_omega)),
        objective_widened: after.map(|a| Num(a.fitness())),
        taken,
    };
    let scored = match (taken, widened.fit) {
        (true, Some(fit)) => Some(data.score(fit)?),
        _ => None,
    };
    Ok((refit, scored))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::commands::diagnose::data::simulated;
    use crate::fit::refit_from;
    use crate::fit::tests::{cogged, quiet};
    use motor_id_shared::fit::space::ProblemSpec;
    use motor_id_shared::{ModelParams, ParamId};

    /// [`widened_final`] with the tests' options, silent.
    fn widened(
        data: &Data,
        set: &[Effect],
        fin: Scored,
        holdout: &Holdout,
        floor: Option<f32>,
    ) -> (Scored, Option<WidenedRefit>) {
        widened_final(data, &quiet(), set, fin, holdout, floor, &|_| {})
    }

    /// The held-out scales of `data` as the search measures them (no ripple taken out).
    fn holdout_of(data: &Data) -> Holdout {
        Holdout {
            noise: data.holdout_noise().unwrap(),
            signal_rms: data.holdout_rms(),
            current_noise: data.holdout_current_noise().unwrap(),
        }
    }

    #[test]
    fn records_are_decimated_only_where_every_form_in_the_model_survives_it() {
        let motor = ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08);
        let survive = forms_survive_decimation;
        assert!(survive(&[Effect::CoulombFriction], &motor));
        assert!(survive(
            &[Effect::WindingHeating, Effect::BridgeDeadtime],
            &motor
        ));
        assert!(!survive(&[Effect::CurrentLimit], &motor));
        // A form a block's mean hides, searched or in the model (its switch on).
        assert!(!survive(&[Effect::SensorDelay], &motor));
        assert!(!survive(
            &[Effect::CoulombFriction, Effect::Cogging],
            &motor
        ));
        let rippled = motor.with(ParamId::RippleAmp, 0.01);
        assert!(!survive(&[Effect::CoulombFriction], &rippled));
        assert!(!survive(&[], &motor.with(ParamId::Td, 1e-4)));
        // A ripple's order alone does not switch it on (its first parameter does).
        let order_only = motor.with(ParamId::RippleCycles, 8.0);
        assert!(survive(&[Effect::CoulombFriction], &order_only));
        assert!(survive(&[], &motor.with(ParamId::Tc, 0.05)));
    }

    #[test]
    fn a_stalled_final_model_is_widened_and_replaced_a_converged_one_stands() {
        // A drive's current limit of 10 A; the final model's fit left it at 30 A, above
        // every current of the records, where its gradient is zero.
        let truth = ModelParams::motor(1.0, 0.02, 0.002, 0.001, 0.08).with(ParamId::Imax, 10.0);
        let data = simulated(&truth, &truth, (24, 8));
        let holdout = holdout_of(&data);
        let mut spec = ProblemSpec::default();
        spec.set_bounds(ParamId::Imax, 0.5, 40.0).unwrap();
        spec.free(ParamId::Imax);
        let scored = |data: &Data, start: &ModelParams| {
            let fit = refit_from(&data.train, &quiet(), &spec, start).unwrap();
            data.score(fit).unwrap()
        };
        let stalled = scored(&data, &truth.with(ParamId::Imax, 30.0));
        let limit = [Effect::CurrentLimit];
        assert!(leaves_unexplained(&stalled, &holdout, None));
        let (fin, refit) = widened(&data, &limit, stalled.clone(), &holdout, None);
        let refit = refit.expect("widened");
        assert!(refit.taken, "{refit:?}");
        // A current limit's flat top is searched on every sample ([`seen_decimated`]).
        assert_eq!(
            refit.decimation, 1,
            "24,000 training samples searched whole"
        );
        assert!(
            fin.holdout_rmse < 0.5 * stalled.holdout_rmse,
            "held out {} against {}",
            fin.holdout_rmse,
            stalled.holdout_rmse
        );
        assert!(!leaves_unexplained(&fin, &holdout, None), "explained");
        let imax = fin.fit.result.params.get(ParamId::Imax);
        assert!((imax - 10.0).abs() < 0.1, "imax {imax}");
        assert!(refit.line().contains("replaces"), "{}", refit.line());

        // No effect named (the baseline's own fit has the escalation), or a model the
        // repeatability floor explains: not widened.
        let none: [Effect; 0] = [];
        assert!(widened(&data, &none, stalled.clone(), &holdout, None)
            .1
            .is_none());
        // The speed's misfit against a repeatability floor that explains it (the current's
        // left out): not unexplained, and not widened.
        let speed_only = Holdout {
            current_noise: None,
            ..holdout
        };
        let floor = Some(stalled.holdout_rmse);
        assert!(leaves_unexplained(&stalled, &speed_only, None));
        assert!(!leaves_unexplained(&stalled, &speed_only, floor));
        let (kept, refit) = widened(&data, &limit, stalled.clone(), &speed_only, floor);
        assert!(refit.is_none() && kept.holdout_rmse == stalled.holdout_rmse);
        // Trained to its noise floor (held out on another motor's records, which it leaves
        // unexplained): not widened.
        let rubbing = truth.with(ParamId::Tc, 0.05);
        let elsewhere = simulated(&truth, &rubbing, (24, 8));
        let at_floor = scored(&elsewhere, &truth);
        let holdout_elsewhere = holdout_of(&elsewhere);
        assert!(at_floor.fit.result.at_noise_floor());
        assert!(leaves_unexplained(&at_floor, &holdout_elsewhere, None));
        let (_, refit) = widened(&elsewhere, &limit, at_floor, &holdout_elsewhere, None);
        assert!(refit.is_none());
        // The current's misfit alone above 1.2 times its noise is unexplained.
        let mut current_only = stalled.clone();
        current_only.holdout_rmse = holdout.noise;
        current_only.holdout_rmse_current = holdout.current_noise.map(|n| 1.3 * n);
        assert!(leaves_unexplained(&current_only, &holdout, None));
        current_only.holdout_rmse_current = holdout.current_noise.map(|n| 1.1 * n);
        assert!(!leaves_unexplained(&current_only, &holdout, None));

        // Converged above the floor (a Coulomb friction the model lacks): widened, no
        // better, not taken.
        let data = simulated(&rubbing, &rubbing, (24, 8));
        let converged = scored(&data, &truth);
        let holdout = holdout_of(&data);
        let before = converged.holdout_rmse;
        let (fin, refit) = widened(&data, &limit, converged, &holdout, None);
        let refit = refit.expect("widened");
        assert!(!refit.taken && fin.holdout_rmse == before, "{refit:?}");
        assert!(refit.line().contains("the model's, not the search's"));
    }

    #[test]
    fn a_cogging_s_stalled_fit_is_widened_on_every_sample() {
        // Cogging's fit started half a turn off its phase: least squares took its
        // amplitude to zero. Widened on every sample (a block's mean hides the detents).
        let truth = cogged();
        let data = simulated(&truth, &truth, (12, 6));
        let holdout = holdout_of(&data);
        let mut spec = ProblemSpec::default();
        spec.fix(ParamId::CogCycles, 8.0).unwrap();
        for (id, hi) in [(ParamId::CogAmp, 0.5), (ParamId::CogPhase, 6.2)] {
            spec.set_bounds(id, 0.0, hi).unwrap();
            spec.free(id);
        }
        let start = truth.with(ParamId::CogPhase, 1.0 + core::f32::consts::PI);
        let fit = refit_from(&data.train, &quiet(), &spec, &start).unwrap();
        let stalled = data.score(fit).unwrap();
        let cogging = [Effect::Cogging];
        let (fin, refit) = widened(&data, &cogging, stalled.clone(), &holdout, None);
        let refit = refit.expect("widened");
        assert!(refit.taken && refit.decimation == 1, "{refit:?}");
        assert!(
            fin.holdout_rmse < 0.2 * stalled.holdout_rmse,
            "{} against {}",
            fin.holdout_rmse,
            stalled.holdout_rmse
        );
        let amp = fin.fit.result.params.get(ParamId::CogAmp);
        assert!((amp - 0.1).abs() < 0.01, "cogging amplitude {amp}");
    }
}
