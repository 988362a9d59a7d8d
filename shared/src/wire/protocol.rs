//! Messages between the host and a drive board, defined once for both ends (postcard over
//! the frames of [`crate::wire::frame`]). A hello exchange carries [`PROTOCOL_VERSION`] so that a
//! host and a firmware that disagree refuse politely instead of misreading each other.

use crate::capacity::MAX_ESTIMATES;
use crate::wire::limits::Limits;
use serde::{Deserialize, Serialize};

/// Bumped whenever a message changes shape.
pub const PROTOCOL_VERSION: u16 = 12;

/// Samples per [`HostMessage::RecordChunk`].
pub const CHUNK: usize = 16;

/// Samples per [`BoardMessage::RecordData`]: fewer than [`CHUNK`], because every board
/// message is as large as its largest variant and the identification's progress messages
/// are built on the board's deepest stack.
pub const READ_CHUNK: usize = 8;

/// What the host asks.
// No allocator on the board: a record chunk travels inline, so this enum is as large as it.
#[allow(clippy::large_enum_variant)]
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum HostMessage {
    /// Open a session; the board answers [`BoardMessage::Hello`] or refuses.
    Hello {
        /// The host's [`PROTOCOL_VERSION`].
        version: u16,
    },
    /// Announce a record to identify from: `samples` samples of step `dt` follow in chunks.
    IdentifyBegin {
        /// Sample step [s].
        dt: f32,
        /// Number of samples.
        samples: u32,
        /// Whether chunks carry current.
        with_current: bool,
        /// First sample of the record's coast-down (bridge open from there to the end; its
        /// voltage not applied), if it has one (protocol 9).
        coast_from: Option<u32>,
    },
    /// Samples `offset..offset + v.len()` of the announced record.
    RecordChunk {
        /// Index of the first sample.
        offset: u32,
        /// Armature voltage [V].
        v: heapless::Vec<f32, CHUNK>,
        /// Speed [rad/s].
        omega: heapless::Vec<f32, CHUNK>,
        /// Current [A] (empty when the record has none).
        current: heapless::Vec<f32, CHUNK>,
    },
    /// Identify from the record streamed in (every chunk received); progress frames follow,
    /// then [`BoardMessage::Identified`].
    Identify {
        /// Random seed of the identification.
        seed: u64,
        /// Which pipeline (the same settings as the host's `identify --pipeline`).
        pipeline: PipelineName,
    },
    /// Run self-commissioning now (bounded experiment, identify, store).
    Commission {
        /// Random seed of the identification.
        seed: u64,
    },
    /// Report the stored parameters.
    ReadParams,
    /// Erase the stored parameters (the board commissions again at next power-up).
    ClearParams,
    /// Stop the running identification or experiment.
    Abort,
    /// Set the limits commissioning works within and store them beside the parameters
    /// (protocol 9); the board answers [`BoardMessage::Limits`] or refuses
    /// [`Refusal::BadLimits`].
    Configure(Limits),
    /// Report the limits commissioning works within (protocol 9).
    ReadLimits,
    /// Samples `offset..` of record `record` the board holds (protocol 9): the commissioning
    /// experiment's (0 slow, 1 fast) or the one streamed in; the board answers
    /// [`BoardMessage::RecordData`].
    ReadRecord {
        /// Which record (0 first).
        record: u8,
        /// Index of the first sample wanted.
        offset: u32,
    },
}

/// Which identification pipeline the board runs: the settings of the host's
/// `identify --pipeline` of the same name, so that the two answers agree bit for bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum PipelineName {
    /// Start and least squares, a short FFO above the noise floor, the host's escalation.
    Default,
    /// The same within a board's memory (commissioning's).
    Board,
    /// The paper's FFO alone.
    Paper,
}

/// Stage of a long job, in progress reports.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum JobStage {
    /// Running the commissioning experiment's records (protocol 8: `iteration` and `total`
    /// are milliseconds of the commissioning so far and of its time budget).
    Experiment,
    /// FFO iterations.
    Search,
    /// Least-squares iterations.
    Refine,
    /// The profile check of the uncertainty: its least-squares iterations, after the fit
    /// (protocol 7).
    Check,
    /// The commissioning probe: offset, resistance and break-away, electrical and mechanical
    /// time scales (protocol 8: `iteration` and `total` in milliseconds, as `Experiment`).
    Probe,
}

/// What the commissioning probe measured and the experiment designed from it (protocol 8),
/// sent before the experiment's records. Estimates of the probe are rough (within tens of
/// per cent): they size the experiment; the fit of its records gives the parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Plan {
    /// Current sensor offset measured at 0 V at rest and subtracted from every reading [A].
    pub current_offset: f32,
    /// Voltage at which the shaft broke away on the probe's ramp [V] (NaN: it did not move
    /// before the ramp ended at its calibration current).
    pub breakaway_volts: f32,
    /// Armature resistance from the electrical step [ohm].
    pub ra: f32,
    /// Electrical time constant La/Ra from the electrical step [s].
    pub tau_e: f32,
    /// Back-EMF constant from the mechanical step [V s/rad].
    pub kv: f32,
    /// Mechanical time scale from the mechanical step [s].
    pub tau_m: f32,
    /// Current the back-EMF took away at the mechanical step's end, (V - Ra i) / Ra [A]
    /// (protocol 11).
    pub back_emf_current: f32,
    /// Largest voltage of the experiment's records [V].
    pub volts: f32,
    /// Step of the fast record (electrical mode) [s].
    pub fast_dt: f32,
    /// Samples of the fast record.
    pub fast_samples: u16,
    /// Step of the slow record (mechanical mode, ending with a coast-down) [s].
    pub slow_dt: f32,
    /// Samples of the slow record.
    pub slow_samples: u16,
    /// Time the probe took [s].
    pub probe_seconds: f32,
    /// Time of the probe and the two records as planned [s] (the waits for the shaft to
    /// stand still before each record, at most 5 % of the budget each, not counted).
    pub planned_seconds: f32,
}

/// An identified motor as the board reports and stores it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct MotorReport {
    /// The five motor parameters (Ra, La, J, B, Kv), then every effect parameter that was
    /// identified (commissioning: Coulomb friction `tc`, which its coast-down shows).
    pub estimates: heapless::Vec<Estimate, MAX_ESTIMATES>,
    /// Speed RMSE [rad/s].
    pub rmse_omega: f32,
    /// Model evaluations spent.
    pub evaluations: u32,
    /// Pinned directions.
    pub rank: u8,
}

impl MotorReport {
    /// The estimate of the parameter with wire code `param`, if the report has one.
    pub fn get(&self, param: u8) -> Option<Estimate> {
        self.estimates.iter().copied().find(|e| e.param == param)
    }
}

/// One identified parameter with its uncertainty: the same for the five motor parameters
/// and for the parameters of effects.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Estimate {
    /// The parameter, by its wire code: its position in the model's parameter list (ra 0,
    /// la 1, j 2, b 3, kv 4, tc 5, ...; `docs/CONTRACTS.md` lists them). Codes are never
    /// reused: a new parameter takes the next one.
    pub param: u8,
    /// The value, in the parameter's unit.
    pub value: f32,
    /// One standard deviation; NaN when the data does not pin the parameter.
    pub std: f32,
}

impl Estimate {
    /// Whether the data pins the parameter (a finite standard deviation).
    pub fn pinned(&self) -> bool {
        self.std.is_finite()
    }
}

/// Why a parameter store holds no report this firmware reads (see [`crate::wire::stored`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum NotStored {
    /// Erased or never written: nothing stored.
    Empty,
    /// A record of another layout version (an older or newer firmware's): not read.
    OtherLayout {
        /// The layout version found.
        found: u16,
    },
    /// A torn or corrupted record (length or CRC wrong): not read.
    Corrupt,
}

impl core::fmt::Display for NotStored {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            NotStored::Empty => f.write_str("no parameters stored"),
            NotStored::OtherLayout { found } => write!(
                f,
                "stored parameters of another layout ({found}) are not read: commission again"
            ),
            NotStored::Corrupt => {
                f.write_str("stored parameters are corrupted (CRC): commission again")
            }
        }
    }
}

/// Why the board refused or failed a request.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum Refusal {
    /// Protocol versions differ; the board's is given.
    VersionMismatch {
        /// The board's [`PROTOCOL_VERSION`].
        board: u16,
    },
    /// A request came before the hello.
    NoSession,
    /// The record does not fit in the board's memory.
    RecordTooLong {
        /// Largest number of samples.
        max: u32,
    },
    /// A chunk arrived out of order or outside the record.
    BadChunk,
    /// The record or the identification was invalid.
    InvalidRecord,
    /// A safety limit tripped during the experiment.
    Trip,
    /// Safety check: the motor turned before any voltage was applied.
    NotAtRest,
    /// Safety check: a sensor reads non-finite values or an offset at 0 V.
    SensorFault,
    /// Busy with another job.
    Busy,
    /// The pipeline needs more memory than the board has (the paper-faithful population).
    PipelineTooLarge,
    /// Commissioning probe: the shaft did not turn at the largest voltage the limits allow
    /// (its break-away needs more current than the current limit allows).
    NoMotion,
    /// Commissioning probe: the speed limit is reached at the smallest voltage that turns
    /// the shaft (the motor cannot be run slowly enough within the speed limit).
    TooFast,
    /// Commissioning probe: the limits are not usable (a voltage, current, speed or time
    /// budget that is not a finite positive number, or a budget too short for any probe).
    BadLimits,
    /// No record with that index is held, or the offset lies past its end (protocol 9).
    NoRecord,
    /// Commissioning probe: the back-EMF at the mechanical step's speed is lost in the
    /// resistive drop (V - Ra i is not above zero within the probe's resolution), so Kv
    /// and the speed the voltages would give cannot be measured: resistive or viscous loss
    /// dominates (protocol 10).
    NoBackEmf,
}

impl core::fmt::Display for Refusal {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Refusal::VersionMismatch { board } => {
                write!(f, "protocol version mismatch (the board speaks {board})")
            }
            Refusal::NoSession => f.write_str("no session (hello first)"),
            Refusal::RecordTooLong { max } => {
                write!(f, "record too long (the board holds {max} samples)")
            }
            Refusal::BadChunk => f.write_str("record chunk out of order or incomplete record"),
            Refusal::InvalidRecord => f.write_str("the record cannot be identified"),
            Refusal::Trip => f.write_str("a current or speed limit tripped: drive stopped"),
            Refusal::NotAtRest => f.write_str("safety check: the motor turns at 0 V"),
            Refusal::SensorFault => {
                f.write_str("safety check: a sensor reads non-finite values or an offset at 0 V")
            }
            Refusal::Busy => f.write_str("busy with another job"),
            Refusal::PipelineTooLarge => {
                f.write_str("the board's memory cannot hold this pipeline (its population)")
            }
            Refusal::NoMotion => f.write_str(
                "probe: the shaft does not turn at the largest voltage the limits allow (its break-away needs more current than the current limit)",
            ),
            Refusal::TooFast => f.write_str(
                "probe: the speed limit is reached at the smallest voltage that turns the shaft",
            ),
            Refusal::BadLimits => f.write_str(
                "the commissioning limits are not finite positive numbers, or the time budget is too short",
            ),
            Refusal::NoRecord => f.write_str(
                "the board holds no such record (commission, or stream one in, first)",
            ),
            Refusal::NoBackEmf => f.write_str(
                "probe: the back-EMF is lost in the armature's resistive drop, so Kv cannot be measured (resistive or viscous loss dominates the motor)",
            ),
        }
    }
}

/// What the board answers.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum BoardMessage {
    /// Session open.
    Hello {
        /// The board's [`PROTOCOL_VERSION`].
        version: u16,
        /// Largest record it accepts.
        max_samples: u32,
    },
    /// Request refused or failed.
    Refused(Refusal),
    /// Chunk received; the next expected offset.
    ChunkOk {
        /// Next sample index expected.
        next: u32,
    },
    /// Progress of a long job.
    Progress {
        /// Stage.
        stage: JobStage,
        /// Iteration within it (during [`JobStage::Experiment`], the sample index).
        iteration: u32,
        /// Iterations the stage runs at most (during [`JobStage::Experiment`], the samples of
        /// the experiment): the length of the host's progress bar.
        total: u32,
        /// Evaluations so far.
        evaluations: u32,
        /// Best fitness so far.
        best: f32,
    },
    /// Identification finished.
    Identified(MotorReport),
    /// The stored parameters, or why there are none.
    Params(Result<MotorReport, NotStored>),
    /// Stored parameters erased.
    Cleared,
    /// The job was stopped on request.
    Aborted,
    /// Commissioning: what the probe measured and the experiment it designed (protocol 8;
    /// after the older variants, so that they keep their encoding).
    Planned(Plan),
    /// The limits commissioning works within, as stored (protocol 9).
    Limits(Limits),
    /// Part of a record the board holds (protocol 9).
    RecordData(RecordPart),
}

/// Samples of a record the board holds, with what a record file needs (protocol 9).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RecordPart {
    /// Which record (0 first).
    pub record: u8,
    /// Records held.
    pub records: u8,
    /// Sample step [s].
    pub dt: f32,
    /// Samples of the record.
    pub samples: u32,
    /// First sample of its coast-down (bridge open from there to the end), if any.
    pub coast_from: Option<u32>,
    /// Drive readings each reading is the mean of, over the step that ends at it (1: the
    /// readings at the instants; `Record::averaged`; protocol 12).
    pub averaged: u32,
    /// Index of the first sample of this part.
    pub offset: u32,
    /// Voltage applied [V] (0 where the bridge is open).
    pub v: heapless::Vec<f32, READ_CHUNK>,
    /// Speed read [rad/s].
    pub omega: heapless::Vec<f32, READ_CHUNK>,
    /// Current read, the sensor's offset removed [A] (empty when the record has none).
    pub current: heapless::Vec<f32, READ_CHUNK>,
}

#[cfg(test)]
#[path = "protocol_tests.rs"]
mod tests;
