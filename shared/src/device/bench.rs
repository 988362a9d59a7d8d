//! The drive as commissioning's stages use it: every sample at the drive's own (fastest)
//! rate, the current sensor's offset subtracted, the limits checked at every sample (a
//! breach ends the job: a trip; a stage's guard below them opens the bridge first), the
//! watchdog fed, the time counted against the budget, progress sent and an abort heard
//! every tenth of a second.

use crate::device::hardware::{Bridge, Drive, Link, Sample, Watchdog};
use crate::device::job::{abort_requested, JobEnd};
use crate::wire::limits::Limits;
use crate::wire::protocol::{BoardMessage, JobStage, Refusal};

/// Seconds between two progress frames (and two looks for an abort).
const PROGRESS_SECONDS: f32 = 0.1;

/// Share of a limit at which a stage opens the bridge itself, before the trip.
pub const GUARD: f32 = 0.85;

/// The drive, watched.
pub struct Bench<'a, D, L, W> {
    drive: &'a mut D,
    link: &'a mut L,
    watchdog: &'a mut W,
    /// The limits commissioning works within.
    pub limits: Limits,
    /// Current sensor offset subtracted from every reading [A].
    pub current_offset: f32,
    /// Each record sample the mean of the drive's readings over its step, not the reading
    /// at its instant ([`crate::device::experiment::record`]).
    pub averaged: bool,
    dt: f32,
    samples: u32,
    progress_every: u32,
    stage: JobStage,
}

impl<'a, D: Drive, L: Link, W: Watchdog> Bench<'a, D, L, W> {
    /// The drive within `limits`, time counted from now.
    pub fn new(drive: &'a mut D, link: &'a mut L, watchdog: &'a mut W, limits: Limits) -> Self {
        let dt = drive.dt();
        let every = PROGRESS_SECONDS / dt;
        Bench {
            drive,
            link,
            watchdog,
            limits,
            current_offset: 0.0,
            averaged: false,
            dt,
            samples: 0,
            progress_every: if every >= 1.0 { every as u32 } else { 1 },
            stage: JobStage::Probe,
        }
    }

    /// The drive's sample period [s].
    pub fn dt(&self) -> f32 {
        self.dt
    }

    /// Time since commissioning began [s].
    pub fn seconds(&self) -> f32 {
        self.samples as f32 * self.dt
    }

    /// Time left of the budget [s] (negative past it).
    pub fn left(&self) -> f32 {
        self.limits.budget - self.seconds()
    }

    /// Report progress under `stage` from now on.
    pub fn enter(&mut self, stage: JobStage) {
        self.stage = stage;
    }

    /// The link, for messages between stages.
    pub fn link(&mut self) -> &mut L {
        self.link
    }

    /// Apply `bridge` for one sample and return the sample read at its start, the current's
    /// offset removed. A non-finite reading ends the job ([`Refusal::SensorFault`]); so does
    /// a current or speed beyond its limit ([`Refusal::Trip`]) and an abort (the caller,
    /// [`crate::device::commissioning::run_experiment`], stops the drive before anything
    /// else).
    pub fn apply(&mut self, bridge: Bridge) -> Result<Sample, JobEnd> {
        self.watchdog.feed();
        let raw = self.drive.apply(bridge);
        self.samples += 1;
        if !(raw.omega.is_finite() && raw.current.is_finite()) {
            return Err(JobEnd::Refused(Refusal::SensorFault));
        }
        let s = Sample {
            omega: raw.omega,
            current: raw.current - self.current_offset,
        };
        if s.current.abs() > self.limits.current || s.omega.abs() > self.limits.speed {
            return Err(JobEnd::Refused(Refusal::Trip));
        }
        if self.samples.is_multiple_of(self.progress_every) {
            let ms = |s: f32| (s * 1000.0) as u32;
            self.link.send(&BoardMessage::Progress {
                stage: self.stage,
                iteration: ms(self.seconds()),
                total: ms(self.limits.budget),
                evaluations: 0,
                best: 0.0,
            });
            if abort_requested(self.link) {
                return Err(JobEnd::Aborted);
            }
        }
        Ok(s)
    }

    /// Drive `volts` for one sample, as [`Bench::apply`]; `None` when the reading lies beyond
    /// the [`GUARD`] share of the current limit or `speed_share` of the speed limit: the
    /// bridge is then opened for a sample (no current flows) and the stage backs off.
    pub fn guarded(&mut self, bridge: Bridge, speed_share: f32) -> Result<Option<Sample>, JobEnd> {
        let s = self.apply(bridge)?;
        let beyond = s.current.abs() > GUARD * self.limits.current
            || s.omega.abs() > speed_share * self.limits.speed;
        if beyond {
            self.apply(Bridge::Open)?;
            return Ok(None);
        }
        Ok(Some(s))
    }
}
