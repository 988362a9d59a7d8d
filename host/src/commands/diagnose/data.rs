//! The records of a diagnosis and the models fitted on them: the training and held-out
//! records with the quantities measured on them, a fitted model scored on both sets, and the
//! conclusions the records cannot support.

use super::stalled::Restarted;
use super::verdict::{Candidate, HeldOut};
use crate::csvio::OwnedRecord;
use crate::fit::{Fit, FitOptions};
use anyhow::{anyhow, Result};
use motor_id_shared::fit::objective::{Cost, Objective};
use motor_id_shared::model::effects::{Effect, Scales};
use motor_id_shared::{ModelParams, ParamId};

/// How many times worse (each over its noise) than the training records, or than the noise
/// when those fit below it, a held-out record must be predicted before it is reported as
/// likely of another set-up.
pub const FOREIGN_RATIO: f32 = 20.0;

/// One record's baseline residual and what the model says about its operating point.
pub struct Trace {
    /// File name.
    pub name: String,
    /// "train" or "holdout".
    pub set: &'static str,
    /// Sample step [s].
    pub dt: f32,
    /// measured - baseline speed [rad/s].
    pub residual: Vec<f32>,
    /// Baseline simulated speed [rad/s].
    pub omega: Vec<f32>,
    /// Armature current [A] (measured, else simulated).
    pub current: Vec<f32>,
    /// measured - modelled current [A], when the current is measured and fitted.
    pub current_residual: Option<Vec<f32>>,
}

impl Trace {
    /// The residual of `channel`: `speed`, else the current's (when it is held).
    pub fn of_channel(&self, channel: &str) -> Option<&[f32]> {
        match channel {
            "speed" => Some(&self.residual),
            _ => self.current_residual.as_deref(),
        }
    }
}

/// Largest magnitude of `x` (0 when empty).
pub fn peak(x: &[f32]) -> f32 {
    x.iter().fold(0.0f32, |m, v| m.max(v.abs()))
}

/// A record `name` of the voltage `v` and the speed `omega`, 1 ms samples (for tests).
#[cfg(test)]
pub fn record(name: &str, v: Vec<f32>, omega: Vec<f32>) -> OwnedRecord {
    OwnedRecord::readings(name, 1e-3, v, omega, None)
}

/// A training record of `train` and a held-out one of `held` ([`crate::fit::tests::record`],
/// with current), each of the length given [s] (for tests).
#[cfg(test)]
pub fn simulated(
    train: &motor_id_shared::ModelParams,
    held: &motor_id_shared::ModelParams,
    (long, held_long): (usize, usize),
) -> Data {
    use crate::fit::tests::record;
    Data {
        train: vec![record(train, long, 11)],
        holdout: vec![record(held, held_long, 29)],
        with_current: true,
    }
}

/// The training and held-out records.
pub struct Data {
    /// Records the models are fitted on.
    pub train: Vec<OwnedRecord>,
    /// Records the models are judged on.
    pub holdout: Vec<OwnedRecord>,
    /// Whether every record has a current that is fitted.
    pub with_current: bool,
}

/// One fitted model and how it does on both sets.
#[derive(Clone)]
pub struct Scored {
    /// The fit on the training records.
    pub fit: Fit,
    /// Its speed RMSE on the training records [rad/s].
    pub train_rmse: f32,
    /// Its speed RMSE on the held-out records [rad/s].
    pub holdout_rmse: f32,
    /// Its current RMSE on the held-out records [A], when current is fitted.
    pub holdout_rmse_current: Option<f32>,
    /// Its held-out misfit of both channels, each over its measured noise, in speed units:
    /// `sigma_w sqrt(((rmse_w / sigma_w)^2 + (rmse_i / sigma_i)^2) / 2)` (the speed RMSE
    /// without current): what the significance rule and the ranking judge, so that an
    /// effect seen on the current channel counts as much as one seen on the speed.
    pub holdout_joint: f32,
    /// Where the fit, an effect added to a model, stalled above a model nested in it and
    /// was searched again from there ([`super::stalled`]).
    pub restarted: Option<Restarted>,
}

impl Data {
    /// The options of the search's fits on these records: the user's `opts` without
    /// progress bars, the current fitted only where every record holds it.
    pub fn fit_options(&self, opts: &FitOptions) -> FitOptions {
        FitOptions {
            quiet: true,
            speed_only: !self.with_current,
            ..opts.clone()
        }
    }

    /// `f` of the held-out records' objective.
    fn on_holdout<T>(&self, f: impl FnOnce(&Objective) -> T) -> Result<T> {
        let recs = OwnedRecord::as_records(&self.holdout, self.with_current);
        let objective = Objective::new(&recs).map_err(|e| anyhow!("holdout: {e}"))?;
        Ok(f(&objective))
    }

    /// Speed RMSE of `p` on the held-out records `which` (indices) [rad/s].
    pub fn holdout_rmse_of(&self, p: &ModelParams, which: &[usize]) -> Result<f32> {
        Ok(self.holdout_cost_of(p, which)?.0.rmse_omega)
    }

    /// The cost of `p` on the held-out records `which` (indices), with their measured speed
    /// and current noise.
    fn holdout_cost_of(
        &self,
        p: &ModelParams,
        which: &[usize],
    ) -> Result<(Cost, f32, Option<f32>)> {
        let recs: Vec<_> = which
            .iter()
            .map(|&k| self.holdout[k].as_record(self.with_current))
            .collect();
        let objective = Objective::new(&recs).map_err(|e| anyhow!("holdout: {e}"))?;
        let cost = objective
            .cost(p)
            .ok_or_else(|| anyhow!("holdout records cannot be simulated with the fitted model"))?;
        Ok((cost, objective.sigma_omega(), objective.sigma_current()))
    }

    /// RMS of the held-out measured speed [rad/s].
    pub fn holdout_rms(&self) -> f32 {
        let (sum, n) = self
            .holdout
            .iter()
            .flat_map(|r| r.omega.iter())
            .fold((0.0f64, 0usize), |(s, n), w| {
                (s + (*w as f64) * (*w as f64), n + 1)
            });
        (sum / n.max(1) as f64).sqrt() as f32
    }

    /// Measured speed noise of the held-out records [rad/s].
    pub fn holdout_noise(&self) -> Result<f32> {
        self.on_holdout(|o| o.sigma_omega())
    }

    /// Measured current noise of the held-out records [A], when current is fitted.
    pub fn holdout_current_noise(&self) -> Result<Option<f32>> {
        self.on_holdout(|o| o.sigma_current())
    }

    /// The records' scales, with `p`'s resistance for the current when none was measured.
    pub fn scales(&self, p: &ModelParams) -> Scales {
        let all = self.train.iter().chain(&self.holdout);
        let v_max = all.clone().map(|r| peak(&r.v)).fold(0.0, f32::max);
        let omega_max = all.clone().map(|r| peak(&r.omega)).fold(0.0, f32::max);
        let measured = all
            .clone()
            .filter_map(|r| r.current.as_deref().map(peak))
            .fold(0.0, f32::max);
        let current_max = if measured > 0.0 {
            measured
        } else {
            v_max / p.get(ParamId::Ra)
        };
        let dt = all.map(|r| r.dt).fold(f32::INFINITY, f32::min);
        Scales {
            v_max,
            omega_max,
            current_max,
            dt,
        }
    }

    /// `fit` scored on both sets.
    pub fn score(&self, fit: Fit) -> Result<Scored> {
        let all: Vec<usize> = (0..self.holdout.len()).collect();
        let (holdout, sigma_w, sigma_i) = self.holdout_cost_of(&fit.result.params, &all)?;
        let joint = match (holdout.rmse_current, sigma_i) {
            (Some(rmse_i), Some(sigma_i)) => {
                let (w, i) = (holdout.rmse_omega / sigma_w, rmse_i / sigma_i);
                sigma_w * ((w * w + i * i) / 2.0).sqrt()
            }
            _ => holdout.rmse_omega,
        };
        Ok(Scored {
            train_rmse: fit.result.cost.rmse_omega,
            holdout_rmse: holdout.rmse_omega,
            holdout_rmse_current: holdout.rmse_current,
            holdout_joint: joint,
            fit,
            restarted: None,
        })
    }

    /// The residual traces of `p` on every record (train and holdout).
    pub fn traces(&self, p: &ModelParams) -> Result<Vec<Trace>> {
        self.traces_of(&[("train", &self.train), ("holdout", &self.holdout)], p)
    }

    /// The residual traces of `p` on the held-out records only.
    pub fn holdout_traces(&self, p: &ModelParams) -> Result<Vec<Trace>> {
        self.traces_of(&[("holdout", &self.holdout)], p)
    }

    /// The residual traces of `p` on each named set of records.
    fn traces_of(
        &self,
        sets: &[(&'static str, &Vec<OwnedRecord>)],
        p: &ModelParams,
    ) -> Result<Vec<Trace>> {
        let mut out = Vec::new();
        for &(set, recs) in sets {
            let borrowed = OwnedRecord::as_records(recs, self.with_current);
            let obj = Objective::new(&borrowed).map_err(|e| anyhow!("{e}"))?;
            for (k, r) in recs.iter().enumerate() {
                let mut w = vec![0.0; r.len()];
                let mut i = vec![0.0; r.len()];
                obj.simulate(p, k, &mut w, &mut i)
                    .map_err(|e| anyhow!("{e}"))?;
                let current_residual = match (&r.current, self.with_current) {
                    (Some(m), true) => Some(m.iter().zip(&i).map(|(m, s)| m - s).collect()),
                    _ => None,
                };
                let current = r.current.clone().unwrap_or(i);
                out.push(Trace {
                    name: r.name(),
                    set,
                    dt: r.dt,
                    residual: r.omega.iter().zip(&w).map(|(m, s)| m - s).collect(),
                    omega: w,
                    current,
                    current_residual,
                });
            }
        }
        Ok(out)
    }

    /// Held-out records the baseline predicts far worse than it fits the training records
    /// (each RMSE over its own noise, the held-out one more than [`FOREIGN_RATIO`] times the
    /// training one): a record of another motor, wiring or sensor scale, which no effect of
    /// the catalogue should be asked to explain.
    pub fn foreign_holdouts(&self, baseline: &Scored) -> Result<Vec<String>> {
        let fit = &baseline.fit.result;
        let train = fit.cost.rmse_omega / fit.sigma_omega.max(f32::MIN_POSITIVE);
        let mut out = Vec::new();
        for (k, r) in self.holdout.iter().enumerate() {
            let (cost, sigma, _) = self.holdout_cost_of(&fit.params, &[k])?;
            let held = cost.rmse_omega / sigma.max(f32::MIN_POSITIVE);
            if held > FOREIGN_RATIO * train.max(1.0) {
                out.push(format!(
                    "held-out {} is predicted to {held:.0} times its noise while the training \
                     records fit to {train:.1} times theirs: is it a record of the same motor, \
                     wiring and sensor scale?",
                    r.name()
                ));
            }
        }
        Ok(out)
    }

    /// Conclusions this data cannot support (identifiability), with `chosen` the verdict's
    /// effect.
    pub fn cannot_support(
        &self,
        baseline: &Scored,
        chosen: Option<&(Effect, Scored)>,
    ) -> Vec<String> {
        let mut out = Vec::new();
        let unpinned = |s: &Scored| -> Vec<ParamId> {
            let params = s.fit.result.identifiability.params.iter();
            params.filter(|c| !c.pinned).map(|c| c.id).collect()
        };
        let names = |ids: &[ParamId]| ids.iter().map(|p| p.name()).collect::<Vec<_>>().join(", ");
        let base = unpinned(baseline);
        if !base.is_empty() {
            out.push(format!(
                "the baseline does not pin {}: how they move when an effect is added says nothing",
                names(&base)
            ));
        }
        if !self.with_current {
            out.push(
                "no current was measured: brush_drop and armature_reaction act through the current, so \
                 they are told apart from each other and from Ra, Kv only by the speed trace"
                    .into(),
            );
        }
        let has_load = |recs: &[OwnedRecord]| recs.iter().any(|r| r.load.is_some());
        if !self.with_current
            && has_load(&self.holdout)
            && !has_load(&self.train)
            && !base.is_empty()
        {
            out.push(
                "the held-out records have a known load torque, whose effect on speed the training \
                 records (speed only, voltage only) do not pin: their RMSE judges the unpinned \
                 parameters as much as any effect"
                    .into(),
            );
        }
        if let Some((e, s)) = chosen {
            let not: Vec<ParamId> = unpinned(s)
                .into_iter()
                .filter(|id| e.params().contains(id))
                .collect();
            if !not.is_empty() {
                out.push(format!(
                    "{} improves the fit, but its parameter(s) {} are not pinned",
                    e.name(),
                    names(&not)
                ));
            }
        }
        out
    }
}

impl Scored {
    /// The significance rule's view of this fit with `effect` added: a tacho delay under
    /// half a sample is below what the sampling resolves (see [`super::verdict`]).
    pub fn candidate(&self, effect: Effect, scales: &Scales) -> Candidate {
        let too_short = effect == Effect::SensorDelay
            && self.fit.result.params.get(ParamId::Td) < 0.5 * scales.dt;
        let spec = effect.spec();
        let acts_on = (spec.acts_on_speed(), spec.acts_on_current());
        Candidate::of(&self.fit, self.held_out(), effect.params().len(), acts_on)
            .unresolvable(too_short)
    }

    /// Its held-out misfit, joint and each channel's.
    fn held_out(&self) -> HeldOut {
        HeldOut {
            joint: self.holdout_joint,
            speed: self.holdout_rmse,
            current: self.holdout_rmse_current,
        }
    }

    /// The significance rule's view of this fit as the reference others add an effect to.
    pub fn reference(&self) -> Candidate {
        Candidate::of(&self.fit, self.held_out(), 0, (false, false))
    }
}
