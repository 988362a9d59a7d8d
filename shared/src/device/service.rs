//! The drive board's application state machine, independent of any register: at power-up
//! it commissions a motor it has no valid parameters for (safety checks, bounded experiment,
//! identification, store) or goes straight into service; in service it answers the host's
//! [`crate::wire::protocol`] requests over a [`Link`], identifies from a record the host
//! streams in, and commissions again on request. The board and QEMU builds implement the
//! traits of [`crate::device::hardware`]; the tests below drive it with the simulated plant
//! of [`crate::device::plant`].

use crate::device::commissioning::{commissioning_spec, run_experiment};
use crate::device::hardware::{Drive, Hardware, Link, ParamStore, Watchdog};
use crate::device::job::{abort_requested, fail, refuse, JobEnd};
use crate::device::record_store::RecordStore;
use crate::device::report::motor_report;
use crate::fit::identify::{
    identify_from, Identification, IdentifyConfig, Pipeline, Progress, Stage,
};
use crate::fit::space::ProblemSpec;
use crate::fit::workspace::FitWorkspace;
use crate::wire::limits::Limits;
use crate::wire::protocol::{
    BoardMessage, HostMessage, JobStage, MotorReport, NotStored, PipelineName, RecordPart, Refusal,
    PROTOCOL_VERSION, READ_CHUNK,
};
use crate::wire::stored::Stored;
use core::ops::ControlFlow;

/// Seed of the identification that power-up commissioning runs.
pub const BOOT_SEED: u64 = 1;

/// How power-up went.
#[derive(Clone, Debug, PartialEq)]
pub enum Boot {
    /// Valid parameters were stored: straight into service.
    InService(MotorReport),
    /// Nothing valid was stored (`found` says why): the motor was commissioned and its
    /// parameters stored.
    Commissioned {
        /// The new parameters.
        report: MotorReport,
        /// Why the store held none this firmware reads.
        found: NotStored,
    },
    /// Nothing valid was stored (`found` says why) and commissioning failed (safety check,
    /// trip, invalid data) or was aborted; the board serves the host without parameters.
    NotCommissioned {
        /// How commissioning ended.
        end: JobEnd,
        /// Why the store held none this firmware reads.
        found: NotStored,
    },
}

/// The pipeline a host asks for by name.
const fn pipeline_named(name: PipelineName) -> Pipeline {
    match name {
        PipelineName::Default => Pipeline::Default,
        PipelineName::Board => Pipeline::Board,
        PipelineName::Paper => Pipeline::Paper,
    }
}

/// Report an identification: store it beside `limits` (with `store`) and send it. In a frame
/// of its own, so that the report and its message take no stack while the identification
/// runs.
#[inline(never)]
fn deliver(
    id: &Identification,
    store: Option<&Limits>,
    params: &mut impl ParamStore,
    watchdog: &mut impl Watchdog,
    link: &mut impl Link,
) -> Result<MotorReport, JobEnd> {
    // The board's own problems always fit its report (see `motor_report`).
    let Some(report) = motor_report(id) else {
        return fail(JobEnd::Refused(Refusal::InvalidRecord), link);
    };
    if let Some(limits) = store {
        let stored = Stored {
            limits: *limits,
            report: Some(report.clone()),
        };
        params.save(&stored, watchdog);
    }
    // Sent in place and taken back (no copy of the report).
    let message = BoardMessage::Identified(report);
    link.send(&message);
    match message {
        BoardMessage::Identified(report) => Ok(report),
        _ => unreachable!("built as Identified above"),
    }
}

/// The application state.
pub struct Service<'s, const N: usize> {
    store: &'s mut RecordStore<N>,
    /// The fit's workspace, when lent ([`Service::with_workspace`]).
    workspace: Option<&'s FitWorkspace>,
    session: bool,
    limits: Limits,
    averaged: bool,
}

impl<'s, const N: usize> Service<'s, N> {
    /// A service using `store` for records, within `limits` when commissioning (until
    /// [`Service::boot`] reads the stored ones, or the host sets others).
    pub fn new(store: &'s mut RecordStore<N>, limits: Limits) -> Self {
        Service {
            store,
            workspace: None,
            session: false,
            limits,
            averaged: false,
        }
    }

    /// Commissioning records each sample as the mean of the drive's readings over its step
    /// (`on`), not the reading at its instant ([`crate::model::step_mean`]).
    pub fn with_averaged_records(mut self, on: bool) -> Self {
        self.averaged = on;
        self
    }

    /// The fits keep the Jacobian's simulators in `workspace` (a board's static RAM, off
    /// its stack: [`crate::fit::workspace`]).
    pub fn with_workspace(mut self, workspace: &'s FitWorkspace) -> Self {
        self.workspace = Some(workspace);
        self
    }

    /// Power-up: into service with valid stored parameters, otherwise self-commissioning
    /// (its progress and result go out on the link for whoever listens).
    pub fn boot<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
        &mut self,
        hw: &mut Hardware<L, D, P, W>,
    ) -> Boot {
        hw.watchdog.feed();
        let stored = hw.params.load();
        self.limits = Stored::limits(&stored);
        let found = match Stored::report(stored) {
            Ok(report) => return Boot::InService(report),
            Err(found) => found,
        };
        match self.commission(BOOT_SEED, hw) {
            Ok(report) => Boot::Commissioned { report, found },
            Err(end) => Boot::NotCommissioned { end, found },
        }
    }

    /// One turn of the service loop: feed the watchdog, handle a request if one came.
    pub fn poll<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
        &mut self,
        hw: &mut Hardware<L, D, P, W>,
    ) {
        hw.watchdog.feed();
        if let Some(msg) = hw.link.poll() {
            self.handle(msg, hw);
        }
    }

    /// Handle one request.
    pub fn handle<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
        &mut self,
        msg: HostMessage,
        hw: &mut Hardware<L, D, P, W>,
    ) {
        if let HostMessage::Hello { version } = msg {
            if version == PROTOCOL_VERSION {
                self.session = true;
                // Bound first: a promoted constant would be a whole message in flash.
                let hello = BoardMessage::Hello {
                    version: PROTOCOL_VERSION,
                    max_samples: N as u32,
                };
                hw.link.send(&hello);
            } else {
                self.session = false;
                refuse(
                    &mut hw.link,
                    Refusal::VersionMismatch {
                        board: PROTOCOL_VERSION,
                    },
                );
            }
            return;
        }
        if !self.session {
            refuse(&mut hw.link, Refusal::NoSession);
            return;
        }
        match msg {
            HostMessage::Hello { .. } => {}
            HostMessage::IdentifyBegin {
                dt,
                samples,
                with_current,
                coast_from,
            } => {
                if samples as usize > N {
                    refuse(&mut hw.link, Refusal::RecordTooLong { max: N as u32 });
                    return;
                }
                if coast_from.is_some_and(|k| k >= samples) {
                    refuse(&mut hw.link, Refusal::BadChunk);
                    return;
                }
                let s = &mut *self.store;
                s.clear(with_current);
                s.open(dt, coast_from.map(|k| k as usize), 1);
                s.expected = samples as usize;
                let first = BoardMessage::ChunkOk { next: 0 };
                hw.link.send(&first);
            }
            HostMessage::RecordChunk {
                offset,
                v,
                omega,
                current,
            } => {
                let s = &mut *self.store;
                let n = v.len();
                let len = s.streamed();
                // A repeat of the last chunk (its acknowledgement was lost) is acknowledged again.
                // Subtracted, not added: `offset + n` overflows the board's 32-bit usize.
                if n > 0 && len.checked_sub(n) == Some(offset as usize) {
                    hw.link.send(&BoardMessage::ChunkOk { next: len as u32 });
                    return;
                }
                let ok = offset as usize == len
                    && omega.len() == n
                    && (!s.with_current || current.len() == n)
                    && len + n <= s.expected;
                if !ok {
                    refuse(&mut hw.link, Refusal::BadChunk);
                    return;
                }
                for k in 0..n {
                    let i = if s.with_current { current[k] } else { 0.0 };
                    s.push(0, v[k], omega[k], i);
                }
                let next = BoardMessage::ChunkOk {
                    next: s.streamed() as u32,
                };
                hw.link.send(&next);
            }
            HostMessage::Identify { seed, pipeline } => {
                let len = self.store.streamed();
                if self.store.count != 1 || len != self.store.expected || len == 0 {
                    refuse(&mut hw.link, Refusal::BadChunk);
                    return;
                }
                // The host's settings of the same name, so that the answer is bit-identical.
                let cfg = pipeline_named(pipeline).config(seed);
                // Failures have been reported on the link.
                let _ = self.identify_and_report(&ProblemSpec::default(), &cfg, hw, false);
            }
            HostMessage::Commission { seed } => {
                // The result or the failure has been reported on the link.
                let _ = self.commission(seed, hw);
            }
            HostMessage::ReadParams => {
                let stored = Stored::report(hw.params.load());
                hw.link.send(&BoardMessage::Params(stored));
            }
            HostMessage::ClearParams => {
                let limits_only = Stored {
                    limits: self.limits,
                    report: None,
                };
                hw.params.save(&limits_only, &mut hw.watchdog);
                let cleared = BoardMessage::Cleared;
                hw.link.send(&cleared);
            }
            HostMessage::Configure(limits) => {
                if !limits.usable() {
                    refuse(&mut hw.link, Refusal::BadLimits);
                    return;
                }
                self.limits = limits;
                // The parameters stay: the motor does not change with the drive's limits.
                let report = Stored::report(hw.params.load()).ok();
                hw.params.save(&Stored { limits, report }, &mut hw.watchdog);
                hw.link.send(&BoardMessage::Limits(limits));
            }
            HostMessage::ReadLimits => {
                hw.link.send(&BoardMessage::Limits(self.limits));
            }
            HostMessage::ReadRecord { record, offset } => match self.record_part(record, offset) {
                Some(part) => hw.link.send(&BoardMessage::RecordData(part)),
                None => refuse(&mut hw.link, Refusal::NoRecord),
            },
            HostMessage::Abort => {
                let aborted = BoardMessage::Aborted;
                hw.link.send(&aborted);
            }
        }
    }

    /// Samples `offset..` (at most [`READ_CHUNK`]) of record `index`, if it is held and
    /// `offset` lies within it.
    fn record_part(&self, index: u8, offset: u32) -> Option<RecordPart> {
        let records = self.store.records();
        let r = records.get(index as usize)?;
        let (start, len) = (offset as usize, r.len());
        if start >= len {
            return None;
        }
        let span = start..(start + READ_CHUNK).min(len);
        let take = |x: &[f32]| heapless::Vec::from_slice(&x[span.clone()]).ok();
        Some(RecordPart {
            record: index,
            records: records.len() as u8,
            dt: r.dt,
            samples: len as u32,
            coast_from: r.coast_from.map(|k| k as u32),
            averaged: r.averaged,
            offset,
            v: take(r.v)?,
            omega: take(r.omega)?,
            current: r.current.map_or(Some(heapless::Vec::new()), take)?,
        })
    }

    /// Identify from the stored record, reporting progress and feeding the watchdog at every
    /// iteration; `Abort` from the host stops it. With `store`, the result is kept.
    fn identify_and_report<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
        &mut self,
        spec: &ProblemSpec,
        cfg: &IdentifyConfig,
        hw: &mut Hardware<L, D, P, W>,
        store: bool,
    ) -> Result<MotorReport, JobEnd> {
        let limits = self.limits;
        let records = self.store.records();
        let mut aborted = false;
        let (link, watchdog) = (&mut hw.link, &mut hw.watchdog);
        let result = identify_from(&records, spec, cfg, None, self.workspace, |p: &Progress| {
            watchdog.feed();
            link.send(&BoardMessage::Progress {
                stage: match p.stage {
                    Stage::Search => JobStage::Search,
                    Stage::Refine => JobStage::Refine,
                    Stage::Check => JobStage::Check,
                },
                iteration: p.iteration,
                total: p.iterations,
                evaluations: p.evaluations,
                best: p.best,
            });
            if abort_requested(link) {
                aborted = true;
                return ControlFlow::Break(());
            }
            ControlFlow::Continue(())
        });
        hw.watchdog.feed();
        // By reference: the identification is not moved into a second copy on this frame.
        let end = match &result {
            _ if aborted => JobEnd::Aborted,
            Ok(id) => {
                let store = store.then_some(&limits);
                return deliver(id, store, &mut hw.params, &mut hw.watchdog, &mut hw.link);
            }
            Err(crate::Error::InvalidConfig) => JobEnd::Refused(Refusal::PipelineTooLarge),
            Err(_) => JobEnd::Refused(Refusal::InvalidRecord),
        };
        fail(end, &mut hw.link)
    }

    /// Self-commissioning ([`crate::device::commissioning`]): the probe within the limits
    /// (a motor that cannot be commissioned within them is refused with its reason), the
    /// experiment designed from it (its plan sent), its slow and fast records read on tacho
    /// and current, identification of both in fixed memory with progress (the board
    /// pipeline, Coulomb friction free: [`commissioning_spec`]), store, report.
    pub fn commission<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
        &mut self,
        seed: u64,
        hw: &mut Hardware<L, D, P, W>,
    ) -> Result<MotorReport, JobEnd> {
        let recorded = run_experiment(
            self.store,
            &self.limits,
            self.averaged,
            &mut hw.link,
            &mut hw.drive,
            &mut hw.watchdog,
        );
        let plan = match recorded {
            Ok(plan) => plan,
            Err(end) => return fail(end, &mut hw.link),
        };
        self.identify_and_report(
            &commissioning_spec(&plan, &self.limits),
            // The board's own readings: its ADC's rounding counts in the deviations.
            &IdentifyConfig {
                adc_readings: true,
                ..IdentifyConfig::board(seed)
            },
            hw,
            true,
        )
    }
}

#[cfg(test)]
#[path = "service_tests.rs"]
mod tests;
