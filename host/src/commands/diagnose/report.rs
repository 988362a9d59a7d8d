//! The `diagnose` report: what the search found, as JSON and as the text summary printed on
//! stdout (both read [`DiagnoseReport`]).

use super::coverage::{self, CoverageGap};
use super::data::{Data, Scored};
use super::found::Search;
use super::naming::{Channel, PartialStandIn};
use super::regime_shares::RegimeShare;
use super::regimes::WhereReport;
use super::remainder::{floor, unexplained, Remainder};
use super::repeatability::Repeatability;
use super::stalled::Restarted;
use super::stand_ins::Judged;
use super::widening::WidenedRefit;
use super::WhatIsLeft;
use crate::report::identify::reported_params;
use crate::report::{estimates, ByParam, Num};
use motor_id_shared::model::effects::Effect;
use motor_id_shared::{ModelParams, ParamId};
use serde::Serialize;

/// The whole `diagnose` report.
#[derive(Serialize, Debug)]
pub struct DiagnoseReport {
    /// Version of this report's schema ([`crate::report::SCHEMA_VERSION`]).
    pub schema_version: u32,
    /// The model without effects.
    pub baseline: Baseline,
    /// Every effect of the catalogue added to the baseline, best held-out misfit of both
    /// channels (`holdout_joint`) first.
    pub effects: Vec<EffectFit>,
    /// Which effect, if any, and how much it helps.
    pub verdict: Verdict,
    /// Where the baseline misfits.
    #[serde(rename = "where")]
    pub where_: WhereReport,
    /// The records.
    pub data: DataReport,
    /// Conclusions the data cannot support.
    pub cannot_support: Vec<String>,
    /// Inputs that look wrong (a held-out record of another set-up).
    pub warnings: Vec<String>,
    /// Regimes the held-out records visit and the training records do not.
    pub coverage_gaps: Vec<CoverageGap>,
    /// How far repeat runs of one experiment differ.
    pub repeatability: Repeatability,
}

/// The model without effects.
#[derive(Serialize, Debug)]
pub struct Baseline {
    /// Speed RMSE on the training records [rad/s].
    pub train_rmse: Num,
    /// Speed RMSE on the held-out records [rad/s].
    pub holdout_rmse: Num,
    /// Parameters, as `identify` reports them.
    pub params: ByParam<Num>,
    /// Measured speed noise of the training records [rad/s].
    pub noise_train: Num,
    /// Measured speed noise of the held-out records [rad/s].
    pub noise_holdout: Num,
}

/// One effect added to the baseline and refitted.
#[derive(Serialize, Debug)]
pub struct EffectFit {
    /// The effect.
    pub name: &'static str,
    /// Speed RMSE on the training records [rad/s].
    pub train_rmse: Num,
    /// Speed RMSE on the held-out records [rad/s].
    pub holdout_rmse: Num,
    /// Held-out misfit of both channels, each over its noise, in speed units [rad/s] (the
    /// speed RMSE without current): what the ranking and the significance rule judge.
    pub holdout_joint: Num,
    /// The motor's and the effect's parameters.
    pub params: ByParam<Num>,
    /// Standard deviation of the effect's free parameters.
    pub effect_std: ByParam<Option<Num>>,
    /// Whether it passes the significance rule against the baseline.
    pub significant: bool,
    /// Where its refit stalled above a model nested in it and was searched again from there
    /// (`null`: it did not).
    pub restarted: Option<Restarted>,
}

/// Which effect, if any, and how much it helps.
#[derive(Serialize, Debug)]
pub struct Verdict {
    /// The effect (`null`: none passes the significance rule).
    pub effect: Option<&'static str>,
    /// Held-out speed RMSE of the baseline [rad/s].
    pub holdout_rmse_before: Num,
    /// Held-out speed RMSE after every named effect [rad/s].
    pub holdout_rmse_after: Num,
    /// Training speed RMSE of the baseline [rad/s].
    pub train_rmse_before: Num,
    /// Training speed RMSE after every named effect [rad/s].
    pub train_rmse_after: Num,
    /// Share of the held-out misfit above noise that the named effects remove.
    pub share_of_misfit_removed: Num,
    /// Measured speed noise of the held-out records [rad/s].
    pub holdout_noise: Num,
    /// The effect's fit, when there is an effect.
    #[serde(flatten)]
    pub chosen: Option<Chosen>,
    /// A second effect on top of the first.
    pub second: Second,
    /// Every effect named, in the order they were added (empty: none).
    pub effects: Vec<NamedEffect>,
    /// Effects the search found significant but that are not named: together they leave
    /// most of a channel's misfit above its floor, so they may stand in for a cause the
    /// catalogue does not hold ([`super::naming`]; empty when the effects are named).
    pub partial: Vec<PartialStandIn>,
    /// The final model's parameters (the baseline's with no effect named), as `identify`
    /// reports them: what `validate --params` reads.
    pub params: ByParam<Num>,
    /// Run-to-run spread of the held-out records that have repeats [rad/s] (`null`: none).
    pub repeatability_floor: Option<Num>,
    /// The held-out misfit after every named effect is still significantly above the floor
    /// (the noise, or the repeatability floor when larger; see [`super::remainder`]).
    pub unexplained: bool,
    /// What is left, how large against the floor and where (`null` when explained).
    pub remainder: Option<Remainder>,
    /// The final model's search, widened before what it leaves was judged (`null` when
    /// it was not: no effect in it, its fit at the noise, the misfit explained, or the
    /// widened search failed).
    pub widened: Option<WidenedRefit>,
    /// The current channel, when current is measured.
    pub current: Option<ChannelVerdict>,
}

/// One named effect of the verdict.
#[derive(Serialize, Debug)]
pub struct NamedEffect {
    /// The effect.
    pub name: &'static str,
    /// Its parameters as fitted with it.
    pub params: ByParam<Num>,
    /// Held-out speed RMSE of the model up to and with it [rad/s].
    pub holdout_rmse_after: Num,
    /// Where its fit at the search's step stalled above a model nested in it and was
    /// searched again from there (as an effect's of the first round).
    pub restarted: Option<Restarted>,
}

/// The verdict on the current channel.
#[derive(Serialize, Debug)]
pub struct ChannelVerdict {
    /// Held-out current RMSE of the baseline [A].
    pub holdout_rmse_before: Num,
    /// Held-out current RMSE after every named effect [A].
    pub holdout_rmse_after: Num,
    /// Measured current noise of the held-out records [A].
    pub holdout_noise: Num,
    /// The current misfit is significantly above its noise.
    pub unexplained: bool,
    /// Where the final model's current misfit lies when it is unexplained and the speed's is
    /// not (with the speed's, in `remainder.current_regimes`): the regimes, the most
    /// over-represented first, and the findings in words.
    pub regimes: Vec<RegimeShare>,
    /// The findings in words.
    #[serde(rename = "where")]
    pub where_: Vec<String>,
}

/// The verdict's effect as fitted.
#[derive(Serialize, Debug)]
pub struct Chosen {
    /// The effect's parameters.
    pub effect_params: ByParam<Num>,
    /// Their standard deviations.
    pub effect_std: ByParam<Option<Num>>,
    /// Relative change of the motor parameters from the baseline's.
    pub base_params_shift: ByParam<Num>,
}

/// A second effect on top of the first (`effect: null` when none passes the rule).
#[derive(Serialize, Debug)]
pub struct Second {
    /// The effect.
    pub effect: Option<&'static str>,
    /// Its fit, when there is one.
    #[serde(flatten)]
    pub fit: Option<SecondFit>,
}

/// The second effect's fit.
#[derive(Serialize, Debug)]
pub struct SecondFit {
    /// Held-out speed RMSE with both effects [rad/s].
    pub holdout_rmse_after: Num,
    /// Training speed RMSE with both effects [rad/s].
    pub train_rmse_after: Num,
    /// The second effect's parameters.
    pub effect_params: ByParam<Num>,
}

/// The records.
#[derive(Serialize, Debug)]
pub struct DataReport {
    /// Whether current was fitted.
    pub current: bool,
    /// Training record files.
    pub train: Vec<String>,
    /// Held-out record files.
    pub holdout: Vec<String>,
}

/// `ids` of `p`.
fn values(p: &ModelParams, ids: &[ParamId]) -> ByParam<Num> {
    ids.iter().map(|&id| (id, Num(p.get(id)))).collect()
}

/// Relative change of each motor parameter from `base` to `after`.
fn motor_shift(base: &ModelParams, after: &ModelParams) -> ByParam<Num> {
    ParamId::MOTOR
        .into_iter()
        .map(|id| (id, Num(after.get(id) / base.get(id) - 1.0)))
        .collect()
}

/// Standard deviations of `effect`'s free parameters in `s`.
fn effect_std(s: &Scored, effect: Effect) -> ByParam<Option<Num>> {
    let all = estimates(&s.fit.result.identifiability);
    all.iter()
        .filter(|(id, _)| effect.params().contains(id))
        .map(|(id, e)| (*id, e.std))
        .collect()
}

/// Share of the misfit above `noise` that going from `before` to `after` removes, in [0, 1].
fn share_removed(before: f32, after: f32, noise: f32) -> f32 {
    let (b2, a2, n2) = (before.powi(2), after.powi(2), noise.powi(2));
    let excess = (b2 - n2).max(f32::MIN_POSITIVE);
    ((b2 - a2) / excess).clamp(0.0, 1.0)
}

impl DiagnoseReport {
    /// The report of `search` on `data`, with what is left of the misfit (`remainder`) and
    /// the held-out records' current noise (`current_noise`, when current is measured).
    pub fn new(
        data: &Data,
        search: &Search,
        repeatability: Repeatability,
        left: WhatIsLeft,
        current_noise: Option<f32>,
        warnings: Vec<String>,
    ) -> DiagnoseReport {
        let WhatIsLeft {
            remainder,
            current_where,
            where_it_acts,
        } = left;
        let baseline = &search.baseline;
        let holdout_noise = search.holdout.noise;
        let after = search.last();
        let current = baseline
            .holdout_rmse_current
            .zip(after.holdout_rmse_current)
            .zip(current_noise)
            .map(|((before, after), noise)| {
                let unexplained = unexplained(after, noise);
                let (regimes, where_) = current_where
                    .filter(|_| unexplained && remainder.is_none())
                    .unwrap_or_default();
                ChannelVerdict {
                    holdout_rmse_before: Num(before),
                    holdout_rmse_after: Num(after),
                    holdout_noise: Num(noise),
                    unexplained,
                    regimes,
                    where_,
                }
            });
        // A name only for what the effects explain: on every channel, most of the excess
        // above the floor gone, or what is left within the floor.
        let (floor_rmse, _) = floor(holdout_noise, repeatability.holdout_floor().map(|f| f.0));
        let speed = Channel {
            before: baseline.holdout_rmse,
            after: after.holdout_rmse,
            floor: floor_rmse,
            unexplained: remainder.is_some(),
            name: "speed",
        };
        let channels: Vec<Channel> = std::iter::once(speed)
            .chain(current.as_ref().map(|c| Channel {
                before: c.holdout_rmse_before.0,
                after: c.holdout_rmse_after.0,
                floor: c.holdout_noise.0,
                unexplained: c.unexplained,
                name: "current",
            }))
            .collect();
        let judged = Judged::of(search, data.with_current, &channels, &where_it_acts);
        let names = |e: &Effect| judged.names(*e);
        // The verdict's effect: the first one named (a stand-in before it passed over).
        let mut named_chain = search.chain.iter().filter(|(e, _)| names(e));
        let chosen = named_chain.next();
        let then = named_chain.next();
        let first = chosen.map(|(e, _)| *e);
        // The model the verdict's effect was added to: the step before it in the chain (a
        // stand-in passed over may lie there), or the baseline.
        let added_to = chosen
            .and_then(|(e, _)| search.chain.iter().position(|(c, _)| c == e))
            .and_then(|k| k.checked_sub(1))
            .map_or(&baseline.fit.result.params, |k| {
                &search.chain[k].1.fit.result.params
            });
        let effects = search
            .scored
            .iter()
            .map(|(e, s)| EffectFit {
                name: e.name(),
                train_rmse: Num(s.train_rmse),
                holdout_rmse: Num(s.holdout_rmse),
                holdout_joint: Num(s.holdout_joint),
                params: values(
                    &s.fit.result.params,
                    &[&ParamId::MOTOR[..], e.params()].concat(),
                ),
                effect_std: effect_std(s, *e),
                significant: first == Some(*e) || search.significant(*e, s),
                restarted: s.restarted.clone(),
            })
            .collect();
        let verdict = Verdict {
            effect: first.map(|e| e.name()),
            holdout_rmse_before: Num(baseline.holdout_rmse),
            holdout_rmse_after: Num(after.holdout_rmse),
            train_rmse_before: Num(baseline.train_rmse),
            train_rmse_after: Num(after.train_rmse),
            share_of_misfit_removed: Num(share_removed(
                baseline.holdout_rmse,
                after.holdout_rmse,
                holdout_noise,
            )),
            holdout_noise: Num(holdout_noise),
            chosen: chosen.map(|(e, s)| Chosen {
                effect_params: values(&s.fit.result.params, e.params()),
                effect_std: effect_std(s, *e),
                base_params_shift: motor_shift(added_to, &s.fit.result.params),
            }),
            second: Second {
                effect: then.map(|(e, _)| e.name()),
                fit: then.map(|(e, s)| SecondFit {
                    holdout_rmse_after: Num(s.holdout_rmse),
                    train_rmse_after: Num(s.train_rmse),
                    effect_params: values(&s.fit.result.params, e.params()),
                }),
            },
            effects: search
                .named()
                .filter(|(e, _)| names(e))
                .map(|(e, s)| NamedEffect {
                    name: e.name(),
                    params: values(&s.fit.result.params, e.params()),
                    holdout_rmse_after: Num(s.holdout_rmse),
                    restarted: s.restarted.clone(),
                })
                .collect(),
            params: reported_params(&after.fit.result, &after.fit.spec),
            repeatability_floor: repeatability.holdout_floor(),
            // A stand-in's share of the misfit has no named cause.
            unexplained: remainder.is_some()
                || current.as_ref().is_some_and(|c| c.unexplained)
                || !judged.loose.is_empty(),
            partial: judged.partial,
            remainder,
            widened: search.widened.clone(),
            current,
        };
        DiagnoseReport {
            schema_version: crate::report::SCHEMA_VERSION,
            baseline: Baseline {
                train_rmse: Num(baseline.train_rmse),
                holdout_rmse: Num(baseline.holdout_rmse),
                params: reported_params(&baseline.fit.result, &baseline.fit.spec),
                noise_train: Num(baseline.fit.result.sigma_omega),
                noise_holdout: Num(holdout_noise),
            },
            effects,
            verdict,
            where_: search.where_.clone(),
            data: DataReport {
                current: data.with_current,
                train: data.train.iter().map(|r| r.name()).collect(),
                holdout: data.holdout.iter().map(|r| r.name()).collect(),
            },
            cannot_support: data.cannot_support(baseline, chosen),
            warnings,
            coverage_gaps: coverage::gaps(&data.train, &data.holdout),
            repeatability,
        }
    }
}

#[cfg(test)]
#[path = "report_tests.rs"]
mod tests;
