//! Typed, allocation-free errors of the identification core.

use crate::param_id::ParamId;
use core::fmt;

/// Why a parameter set, a record or an identification request was refused.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Error {
    /// A motor parameter is not a finite positive number.
    NonPositiveParameter(ParamId),
    /// An effect parameter is not finite or out of its physical range.
    InvalidEffectParameter(ParamId),
    /// The sample step is not a finite positive number.
    InvalidStep,
    /// A record's columns have different lengths.
    LengthMismatch,
    /// A record holds fewer samples than the fit needs.
    TooFewSamples,
    /// A record holds a NaN or infinite value.
    NonFiniteSample,
    /// No record was given.
    NoRecords,
    /// A bound has `lo >= hi`, or is not finite, or is not positive for a log-scaled parameter.
    InvalidBound(ParamId),
    /// A fixed value lies outside the physically meaningful range.
    InvalidFixedValue(ParamId),
    /// Every parameter is fixed: there is nothing to identify.
    NothingToIdentify,
    /// More free parameters than the fixed-size solver holds.
    TooManyParameters,
    /// The FFO configuration is inconsistent (population does not fit, zero iterations...).
    InvalidConfig,
    /// No candidate produced a finite cost.
    NoFiniteCandidate,
    /// The tacho delay exceeds what the simulator holds (`MAX_DELAY_SAMPLES` steps).
    DelayTooLong,
    /// A record's coast-down starts beyond its last sample.
    CoastOutsideRecord,
    /// An effect that this build's simulator does not hold is on (a board simulates the
    /// five motor parameters and Coulomb friction; see `crate::capacity`).
    EffectNotInBuild(ParamId),
    /// A record's readings are means over its sample step, which the model with these
    /// effects does not simulate (it simulates them with no effect but Coulomb friction and
    /// no sensor delay; see `crate::model::step_mean`).
    AveragedReadingsNotModelled,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Error::NonPositiveParameter(p) => {
                write!(f, "motor parameter {} must be finite and > 0", p.name())
            }
            Error::InvalidEffectParameter(p) => {
                write!(f, "effect parameter {} is out of range", p.name())
            }
            Error::InvalidStep => f.write_str("sample step must be finite and > 0"),
            Error::LengthMismatch => f.write_str("record columns have different lengths"),
            Error::TooFewSamples => f.write_str("record has too few samples (need at least 8)"),
            Error::NonFiniteSample => f.write_str("record holds a NaN or infinite sample"),
            Error::NoRecords => f.write_str("no record given"),
            Error::InvalidBound(p) => write!(
                f,
                "bound of {} must satisfy lo < hi, finite (and lo > 0 for log-scaled parameters)",
                p.name()
            ),
            Error::InvalidFixedValue(p) => write!(f, "fixed value of {} is out of range", p.name()),
            Error::NothingToIdentify => {
                f.write_str("every parameter is fixed: nothing to identify")
            }
            Error::TooManyParameters => f.write_str("too many free parameters"),
            Error::InvalidConfig => f.write_str("inconsistent optimiser configuration"),
            Error::NoFiniteCandidate => f.write_str("no candidate gave a finite cost"),
            Error::DelayTooLong => write!(
                f,
                "tacho delay td is longer than {} samples",
                crate::capacity::MAX_DELAY_SAMPLES
            ),
            Error::CoastOutsideRecord => f.write_str("the coast-down must start within the record"),
            Error::EffectNotInBuild(p) => write!(
                f,
                "effect parameter {} is not simulated by this build",
                p.name()
            ),
            Error::AveragedReadingsNotModelled => f.write_str(
                "readings averaged over the sample step are simulated with no effect but Coulomb friction",
            ),
        }
    }
}

#[cfg(feature = "std")]
impl std::error::Error for Error {}
