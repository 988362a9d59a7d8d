//! The `identify` JSON report (docs/CONTRACTS.md: `params`, `rmse_omega`, `evaluations`,
//! `identifiability`, plus more fields), also what `demo` writes.

use super::{estimates, ByParam, Num, ParamEstimate};
use motor_id_shared::fit::identifiability::Identifiability;
use motor_id_shared::fit::identify::Identification;
use motor_id_shared::fit::space::ProblemSpec;
use motor_id_shared::ParamId;
use serde::Serialize;

/// RMSE above this multiple of the measured noise means the model misfits the data.
pub const MISFIT_RATIO: f32 = 1.5;

/// The whole `identify` report.
#[derive(Serialize, Debug)]
pub struct IdentifyReport {
    /// Version of this report's schema ([`crate::report::SCHEMA_VERSION`]).
    pub schema_version: u32,
    /// Parameters reported ([`reported_params`]).
    pub params: ByParam<Num>,
    /// Speed RMSE [rad/s].
    pub rmse_omega: Num,
    /// Current RMSE [A], when current was fitted.
    pub rmse_current: Option<Num>,
    /// Model evaluations of the fit.
    pub evaluations: u32,
    /// Model evaluations of the identifiability analysis.
    pub analysis_evaluations: u32,
    /// What the data pins.
    pub identifiability: IdentifiabilityReport,
    /// Measured noise.
    pub noise: NoiseReport,
    /// The objective's value.
    pub fitness: Num,
    /// How the fit compares to the noise.
    pub fit_quality: FitQuality,
    /// Widened searches run after the pipeline because its fit stayed above the noise (0:
    /// none needed); a fit still flagged then is the model's, not the search's.
    pub search_widened: u32,
    /// Whether the search ran to its end.
    pub completed: bool,
    /// Best fitness by model evaluations.
    pub convergence: Vec<ConvergencePoint>,
    /// Record files fitted.
    pub records: Vec<String>,
    /// Random seed.
    pub seed: u64,
    /// Pipeline name.
    pub mode: &'static str,
    /// Cheap explanations of an inadequate fit that a refit confirmed
    /// ([`crate::hints`]); empty when the fit is adequate or none holds.
    pub hints: Vec<String>,
}

/// Measured noise of the records.
#[derive(Serialize, Debug)]
pub struct NoiseReport {
    /// Speed noise [rad/s].
    pub sigma_omega: Num,
    /// Current noise [A], when current was fitted.
    pub sigma_current: Option<Num>,
}

/// How the fit compares to the noise, channel by channel.
#[derive(Serialize, Debug)]
pub struct FitQuality {
    /// Speed RMSE over the measured speed noise (the same as `speed.rmse_over_noise`).
    pub rmse_over_noise: Num,
    /// Every fitted channel is adequate (speed, and current when it was fitted).
    pub model_adequate: bool,
    /// The speed channel.
    pub speed: ChannelQuality,
    /// The current channel, when current was fitted.
    pub current: Option<ChannelQuality>,
}

/// How one channel's fit compares to its noise: the one rule of the text and the JSON.
#[derive(Serialize, Debug, Clone, Copy)]
pub struct ChannelQuality {
    /// RMSE over the measured noise.
    pub rmse_over_noise: Num,
    /// Whether that ratio is at most [`MISFIT_RATIO`].
    pub model_adequate: bool,
}

impl ChannelQuality {
    /// A channel fitted to `rmse` with measured noise `sigma`.
    pub fn new(rmse: f32, sigma: f32) -> ChannelQuality {
        let ratio = rmse / sigma;
        ChannelQuality {
            rmse_over_noise: Num(ratio),
            model_adequate: ratio <= MISFIT_RATIO,
        }
    }
}

impl FitQuality {
    /// The quality of identification `id`.
    pub fn of(id: &Identification) -> FitQuality {
        let speed = ChannelQuality::new(id.cost.rmse_omega, id.sigma_omega);
        let current = id
            .cost
            .rmse_current
            .zip(id.sigma_current)
            .map(|(rmse, sigma)| ChannelQuality::new(rmse, sigma));
        FitQuality {
            rmse_over_noise: speed.rmse_over_noise,
            model_adequate: speed.model_adequate && current.is_none_or(|c| c.model_adequate),
            speed,
            current,
        }
    }
}

/// One point of the convergence trace.
#[derive(Serialize, Debug)]
pub struct ConvergencePoint {
    /// Model evaluations so far.
    pub evaluations: u32,
    /// Best fitness so far.
    pub best: Num,
}

/// Which quantities are pinned, with uncertainty, and the flat directions.
#[derive(Serialize, Debug)]
pub struct IdentifiabilityReport {
    /// Directions the data pins.
    pub rank: usize,
    /// Free parameters.
    pub free: usize,
    /// Whether every free parameter is pinned.
    pub all_pinned: bool,
    /// Parameters and combinations pinned.
    pub pinned: Vec<&'static str>,
    /// Parameters and combinations not pinned.
    pub not_pinned: Vec<&'static str>,
    /// Every free parameter's estimate.
    pub parameters: ByParam<ParamEstimate>,
    /// Combinations of parameters the data may pin when the parameters are not.
    pub combinations: Vec<CombinationReport>,
    /// Directions the data does not pin.
    pub unpinned_directions: Vec<DirectionReport>,
    /// How to read the directions.
    pub note: &'static str,
}

/// A combination of parameters.
#[derive(Serialize, Debug)]
pub struct CombinationReport {
    /// Name.
    pub name: &'static str,
    /// Value.
    pub value: Num,
    /// Whether the data pins it.
    pub pinned: bool,
    /// Relative standard deviation.
    pub rel_std: Option<Num>,
}

/// A direction the data does not pin.
#[derive(Serialize, Debug)]
pub struct DirectionReport {
    /// Components of 0.005 or more, rounded to 0.001.
    pub components: ByParam<Num>,
    /// One standard deviation along it.
    pub std: Num,
}

/// Parameters reported: the five motor ones, and every effect parameter that is free or
/// non-zero (an effect that is part of the model).
pub fn reported_params(id: &Identification, spec: &ProblemSpec) -> ByParam<Num> {
    ParamId::ALL
        .into_iter()
        .filter(|&p| {
            let v = id.params.get(p);
            p.is_motor()
                || spec.free[p.index()]
                || (v != 0.0 && p != ParamId::RippleCycles)
                || (p == ParamId::RippleCycles && id.params.get(ParamId::RippleAmp) != 0.0)
        })
        .map(|p| (p, Num(id.params.get(p))))
        .collect()
}

impl IdentifiabilityReport {
    /// The report of an identifiability analysis.
    pub fn new(ident: &Identifiability) -> IdentifiabilityReport {
        let names = |pinned: bool| -> Vec<&'static str> {
            let params = ident.params.iter().filter(|p| p.pinned == pinned);
            let combinations = ident.combinations.iter().filter(|c| c.pinned == pinned);
            params
                .map(|p| p.id.name())
                .chain(combinations.map(|c| c.combination.name()))
                .collect()
        };
        let combinations = ident
            .combinations
            .iter()
            .map(|c| CombinationReport {
                name: c.combination.name(),
                value: Num(c.value),
                pinned: c.pinned,
                rel_std: c.rel_std.map(Num),
            })
            .collect();
        let unpinned_directions = ident
            .unpinned
            .iter()
            .map(|d| DirectionReport {
                components: ident
                    .params
                    .iter()
                    .zip(d.components.iter())
                    .filter(|(_, c)| c.abs() >= 0.005)
                    .map(|(p, c)| (p.id, Num((c * 1000.0).round() / 1000.0)))
                    .collect(),
                std: Num(d.std),
            })
            .collect();
        IdentifiabilityReport {
            rank: ident.rank,
            free: ident.params.len(),
            all_pinned: ident.all_pinned(),
            pinned: names(true),
            not_pinned: names(false),
            parameters: estimates(ident),
            combinations,
            unpinned_directions,
            note: "directions are in natural coordinates: ln(p) for log-scaled parameters; std is one standard deviation there",
        }
    }
}

impl IdentifyReport {
    /// The report of identifying `spec` from `records` with `seed` and the pipeline `mode`.
    pub fn new(
        id: &Identification,
        spec: &ProblemSpec,
        records: Vec<String>,
        seed: u64,
        mode: &'static str,
    ) -> IdentifyReport {
        IdentifyReport {
            schema_version: crate::report::SCHEMA_VERSION,
            params: reported_params(id, spec),
            rmse_omega: Num(id.cost.rmse_omega),
            rmse_current: id.cost.rmse_current.map(Num),
            evaluations: id.evaluations,
            analysis_evaluations: id.analysis_evaluations,
            identifiability: IdentifiabilityReport::new(&id.identifiability),
            noise: NoiseReport {
                sigma_omega: Num(id.sigma_omega),
                sigma_current: id.sigma_current.map(Num),
            },
            fitness: Num(id.cost.fitness()),
            fit_quality: FitQuality::of(id),
            search_widened: id.widened,
            completed: id.completed,
            convergence: id
                .trace
                .iter()
                .map(|t| ConvergencePoint {
                    evaluations: t.evaluations,
                    best: Num(t.best),
                })
                .collect(),
            records,
            seed,
            mode,
            hints: Vec::new(),
        }
    }

    /// This report with the `hints` found.
    pub fn with_hints(mut self, hints: Vec<String>) -> IdentifyReport {
        self.hints = hints;
        self
    }
}
