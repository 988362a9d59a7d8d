//! The identification pipelines' configurations: what each pipeline searches and refines,
//! how it escalates, and its name (the host's `--pipeline`, the board's `Identify`
//! request). The run is [`crate::fit::identify`].

use crate::fit::ffo::{FfoConfig, Soil};
use crate::fit::refine::LmConfig;

/// The identification pipelines, by name (the host's `--pipeline`, the board's
/// `Identify` request).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Pipeline {
    /// [`IdentifyConfig::default_pipeline`]: start and least squares, a short FFO above the
    /// noise floor, escalating to the paper's FFO.
    Default,
    /// [`IdentifyConfig::board`]: the same within a board's memory
    /// (what a board runs when it commissions itself).
    Board,
    /// [`IdentifyConfig::paper_faithful`]: the paper's FFO alone.
    Paper,
}

impl Pipeline {
    /// All pipelines.
    pub const ALL: [Pipeline; 3] = [Pipeline::Default, Pipeline::Board, Pipeline::Paper];

    /// The pipeline's settings with random seed `seed`.
    pub fn config(self, seed: u64) -> IdentifyConfig {
        match self {
            Pipeline::Default => IdentifyConfig::default_pipeline(seed),
            Pipeline::Board => IdentifyConfig::board(seed),
            Pipeline::Paper => IdentifyConfig::paper_faithful(seed),
        }
    }

    /// Name, as on the command line and in reports.
    pub const fn name(self) -> &'static str {
        match self {
            Pipeline::Default => "default",
            Pipeline::Board => "board",
            Pipeline::Paper => "paper",
        }
    }
}

/// How to identify.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IdentifyConfig {
    /// Global search.
    pub ffo: FfoConfig,
    /// Local refinement after it (`None`: FFO only, as the seed).
    pub refine: Option<LmConfig>,
    /// Search log-scaled where bounds are positive (false: linear, paper Eq. 9).
    pub log_scale: bool,
    /// Random seed.
    pub seed: u64,
    /// Extra refinements from the next best FFO members when the first stops above the noise.
    pub restarts: u32,
    /// Seed the search with the equation-error estimate of [`crate::fit::initial`].
    pub equation_error_start: bool,
    /// When the FFO runs.
    pub search: SearchWhen,
    /// The wider searches a fit that stays above the noise floor escalates to
    /// ([`identify_from`](crate::fit::identify::identify_from)).
    pub escalation: Escalation,
    /// Check the local uncertainty along the valley where the fit has a flat direction
    /// ([`crate::fit::profile_check`]); off for fits whose uncertainty nobody reads (the
    /// diagnosis' candidate effects), which saves its least-squares refits.
    pub profile_check: bool,
    /// The readings are an ADC's (a board's own records): the deviations count each
    /// record's steady rounding error ([`crate::model::rounding::Rounding`]), which
    /// averaging does not remove.
    pub adc_readings: bool,
}

/// The wider searches of [`identify_from`](crate::fit::identify::identify_from), for a fit that stays above the noise floor: a
/// stuck search is not yet a model that misses something.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Escalation {
    /// None: the fit is final.
    None,
    /// Within a board's memory (the short FFO's population): the short FFO run 5 and then
    /// 25 times as long (1,296 and 6,416 evaluations), each with other random numbers, then
    /// least squares from its best members.
    Board,
    /// The host's: an FFO of the paper's population for 20 iterations (4,100 evaluations),
    /// then the paper's whole FFO (40,100), both with the soil step towards the best, then
    /// least squares from their best members.
    Host,
}

/// When [`identify_from`](crate::fit::identify::identify_from) runs its global search (the FFO).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SearchWhen {
    /// Always, seeded with the start (the paper's FFO).
    Always,
    /// Only when refining the start first does not reach the measured noise floor (both
    /// pipelines: saves most evaluations, and a fit left above the floor escalates).
    AboveFloor,
    /// Never: least squares from the start only (a refit from a start known to lie in the
    /// optimum's basin, e.g. a model refitted after one effect was taken out of it).
    Never,
}

impl IdentifyConfig {
    /// The default pipeline: the equation-error start refined by least squares; above the
    /// noise floor a short FFO in log scale, then least squares; then the host's escalation.
    pub fn default_pipeline(seed: u64) -> Self {
        IdentifyConfig {
            ffo: FfoConfig::QUICK,
            refine: Some(LmConfig::default()),
            log_scale: true,
            seed,
            restarts: 3,
            equation_error_start: true,
            search: SearchWhen::AboveFloor,
            escalation: Escalation::Host,
            profile_check: true,
            adc_readings: false,
        }
    }

    /// The pipeline for a drive board: as [`IdentifyConfig::default_pipeline`], but its
    /// escalation stays within a board's memory ([`Escalation::Board`]).
    pub fn board(seed: u64) -> Self {
        IdentifyConfig {
            escalation: Escalation::Board,
            ..Self::default_pipeline(seed)
        }
    }

    /// The basin of a few parameters, the rest held (the diagnosis' first stage of an effect
    /// added to a fitted model, whose one to three parameters alone are searched before
    /// everything is refitted from there by [`IdentifyConfig::local`]): the default
    /// pipeline without its escalation or profile check, its short FFO run 4 iterations
    /// (144 evaluations instead of 272: a population of 16 covers one to three
    /// dimensions), least squares to a relative gain of 0.1 % and one restart. Only the
    /// basin matters here: the refit with every parameter free converges in it. On the
    /// lab motor's diagnosis (docs/measurements/lab-motor.md), with the baseline's
    /// escalation beside the first round, the CPU time fell from 28 to 18 s with the same
    /// verdict.
    pub fn basin(seed: u64) -> Self {
        IdentifyConfig {
            ffo: FfoConfig {
                iterations: 4,
                ..FfoConfig::QUICK
            },
            refine: Some(LmConfig {
                rel_tol: 1e-3,
                ..LmConfig::default()
            }),
            restarts: 1,
            escalation: Escalation::None,
            profile_check: false,
            ..Self::default_pipeline(seed)
        }
    }

    /// Least squares from a given start only, no global search ([`SearchWhen::Never`]).
    pub fn local(seed: u64) -> Self {
        IdentifyConfig {
            search: SearchWhen::Never,
            escalation: Escalation::None,
            ..Self::default_pipeline(seed)
        }
    }

    /// Wider search `step` (0, 1) of its [`Escalation`]: the FFO and its random seed (other
    /// random numbers than the pipeline's own search); `None` past the last.
    pub fn wider(&self, step: usize) -> Option<(FfoConfig, u64)> {
        let ffo = match (self.escalation, step) {
            (Escalation::Board, 0 | 1) => FfoConfig {
                iterations: [5, 25][step] * self.ffo.iterations,
                ..self.ffo
            },
            (Escalation::Host, 0 | 1) => FfoConfig {
                iterations: [20, FfoConfig::PAPER.iterations][step],
                soil: Soil::TowardsBest,
                ..FfoConfig::PAPER
            },
            _ => return None,
        };
        Some((ffo, self.seed.wrapping_add(step as u64 + 1)))
    }

    /// The paper's workflow: FFO with the paper's settings (40,100 evaluations) in linear
    /// scale over Table 1, no refinement.
    pub fn paper_faithful(seed: u64) -> Self {
        IdentifyConfig {
            ffo: FfoConfig::PAPER,
            refine: None,
            log_scale: false,
            seed,
            restarts: 0,
            equation_error_start: false,
            search: SearchWhen::Always,
            escalation: Escalation::None,
            profile_check: true,
            adc_readings: false,
        }
    }
}
