//! The drive board's application, independent of any register: it answers the host's
//! [`crate::protocol`] requests over a [`Link`], identifies from a record the host streams in,
//! and commissions a motor through a [`Drive`] (bounded experiment, identification, store).
//! The board and QEMU builds implement the traits; tests drive it with a simulated plant.

use crate::identify::{identify, IdentifyConfig, Progress, Stage};
use crate::params::ParamId;
use crate::profile::{Experiment, Profile};
use crate::protocol::{
    BoardMessage, HostMessage, JobStage, MotorReport, Refusal, PROTOCOL_VERSION,
};
use crate::record::Record;
use crate::space::ProblemSpec;
use core::ops::ControlFlow;

/// The byte link to the host, message by message.
pub trait Link {
    /// Send one message.
    fn send(&mut self, msg: &BoardMessage);
    /// A message if one has arrived (never blocks).
    fn poll(&mut self) -> Option<HostMessage>;
}

/// One sample of the drive's sensors.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sample {
    /// Tacho speed [rad/s].
    pub omega: f32,
    /// Armature current [A].
    pub current: f32,
}

/// The power stage and its sensors, sampled at a fixed rate.
pub trait Drive {
    /// Sample period [s].
    fn dt(&self) -> f32;
    /// Read the sensors now, then apply `volts` until the next sample.
    fn step(&mut self, volts: f32) -> Sample;
    /// Remove drive (coast).
    fn stop(&mut self);
}

/// Non-volatile storage of the identified motor.
pub trait ParamStore {
    /// The stored motor, if valid.
    fn load(&mut self) -> Option<MotorReport>;
    /// Store `report`.
    fn save(&mut self, report: &MotorReport);
    /// Erase.
    fn clear(&mut self);
}

/// Limits of the commissioning experiment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// Largest armature voltage applied [V].
    pub voltage: f32,
    /// Trip above this |current| [A].
    pub current: f32,
    /// Trip above this |speed| [rad/s].
    pub speed: f32,
}

/// Buffers of one record, in fixed memory.
pub struct RecordStore<const N: usize> {
    dt: f32,
    len: usize,
    expected: usize,
    with_current: bool,
    v: [f32; N],
    omega: [f32; N],
    current: [f32; N],
}

impl<const N: usize> Default for RecordStore<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> RecordStore<N> {
    /// Empty buffers (const, for a `static`).
    pub const fn new() -> Self {
        RecordStore {
            dt: 0.0,
            len: 0,
            expected: 0,
            with_current: false,
            v: [0.0; N],
            omega: [0.0; N],
            current: [0.0; N],
        }
    }

    fn record(&self) -> Record<'_> {
        Record {
            dt: self.dt,
            v: &self.v[..self.len],
            omega: &self.omega[..self.len],
            current: self.with_current.then(|| &self.current[..self.len]),
            load: None,
        }
    }
}

/// The application state.
pub struct Service<'s, const N: usize> {
    store: &'s mut RecordStore<N>,
    session: bool,
    limits: Limits,
}

/// Report of an identification in the message form.
pub fn motor_report(id: &crate::identify::Identification) -> MotorReport {
    let mut params = [0.0f32; 5];
    let mut std = [f32::NAN; 5];
    for (k, p) in ParamId::MOTOR.iter().enumerate() {
        params[k] = id.params.get(*p);
        if let Some(c) = id.identifiability.params.iter().find(|c| c.id == *p) {
            std[k] = c.std.unwrap_or(f32::NAN);
        }
    }
    MotorReport {
        params,
        std,
        rmse_omega: id.cost.rmse_omega,
        evaluations: id.evaluations,
        rank: id.identifiability.rank as u8,
    }
}

impl<'s, const N: usize> Service<'s, N> {
    /// A service using `store` for records, within `limits` when commissioning.
    pub fn new(store: &'s mut RecordStore<N>, limits: Limits) -> Self {
        Service {
            store,
            session: false,
            limits,
        }
    }

    /// Handle one request.
    pub fn handle(
        &mut self,
        msg: HostMessage,
        link: &mut impl Link,
        drive: &mut impl Drive,
        params: &mut impl ParamStore,
    ) {
        if let HostMessage::Hello { version } = msg {
            if version == PROTOCOL_VERSION {
                self.session = true;
                link.send(&BoardMessage::Hello {
                    version: PROTOCOL_VERSION,
                    max_samples: N as u32,
                });
            } else {
                self.session = false;
                link.send(&BoardMessage::Refused(Refusal::VersionMismatch {
                    board: PROTOCOL_VERSION,
                }));
            }
            return;
        }
        if !self.session {
            link.send(&BoardMessage::Refused(Refusal::NoSession));
            return;
        }
        match msg {
            HostMessage::Hello { .. } => {}
            HostMessage::IdentifyBegin {
                dt,
                samples,
                with_current,
                ..
            } => {
                if samples as usize > N {
                    link.send(&BoardMessage::Refused(Refusal::RecordTooLong {
                        max: N as u32,
                    }));
                    return;
                }
                let s = &mut *self.store;
                s.dt = dt;
                s.len = 0;
                s.expected = samples as usize;
                s.with_current = with_current;
                link.send(&BoardMessage::ChunkOk { next: 0 });
            }
            HostMessage::RecordChunk {
                offset,
                v,
                omega,
                current,
            } => {
                let s = &mut *self.store;
                let n = v.len();
                // A repeat of the last chunk (its acknowledgement was lost) is acknowledged again.
                if n > 0 && offset as usize + n == s.len {
                    link.send(&BoardMessage::ChunkOk { next: s.len as u32 });
                    return;
                }
                let ok = offset as usize == s.len
                    && omega.len() == n
                    && (!s.with_current || current.len() == n)
                    && s.len + n <= s.expected;
                if !ok {
                    link.send(&BoardMessage::Refused(Refusal::BadChunk));
                    return;
                }
                for k in 0..n {
                    s.v[s.len + k] = v[k];
                    s.omega[s.len + k] = omega[k];
                    s.current[s.len + k] = if s.with_current { current[k] } else { 0.0 };
                }
                s.len += n;
                link.send(&BoardMessage::ChunkOk { next: s.len as u32 });
            }
            HostMessage::Identify { seed } => {
                if self.store.len != self.store.expected || self.store.len == 0 {
                    link.send(&BoardMessage::Refused(Refusal::BadChunk));
                    return;
                }
                // The host's default pipeline, so that the board's answer is bit-identical.
                let cfg = IdentifyConfig::default_pipeline(seed);
                self.identify_and_report(&cfg, link, None);
            }
            HostMessage::Commission { seed } => {
                self.commission(seed, link, drive, params);
            }
            HostMessage::ReadParams => link.send(&BoardMessage::Params(params.load())),
            HostMessage::ClearParams => {
                params.clear();
                link.send(&BoardMessage::Cleared);
            }
            HostMessage::Abort => link.send(&BoardMessage::Aborted),
        }
    }

    /// Identify from the stored record, reporting progress; `Abort` from the host stops it.
    /// Returns the report when it completed.
    fn identify_and_report(
        &mut self,
        cfg: &IdentifyConfig,
        link: &mut impl Link,
        params: Option<&mut dyn ParamStore>,
    ) -> Option<MotorReport> {
        let record = [self.store.record()];
        let mut aborted = false;
        let result = identify(&record, &ProblemSpec::default(), cfg, |p: &Progress| {
            link.send(&BoardMessage::Progress {
                stage: match p.stage {
                    Stage::Search => JobStage::Search,
                    Stage::Refine => JobStage::Refine,
                },
                iteration: p.iteration,
                evaluations: p.evaluations,
                best: p.best,
            });
            if matches!(link.poll(), Some(HostMessage::Abort)) {
                aborted = true;
                return ControlFlow::Break(());
            }
            ControlFlow::Continue(())
        });
        match result {
            _ if aborted => {
                link.send(&BoardMessage::Aborted);
                None
            }
            Ok(id) => {
                let report = motor_report(&id);
                if let Some(store) = params {
                    store.save(&report);
                }
                link.send(&BoardMessage::Identified(report));
                Some(report)
            }
            Err(_) => {
                link.send(&BoardMessage::Refused(Refusal::InvalidRecord));
                None
            }
        }
    }

    /// Self-commissioning: a bounded voltage-steps experiment with speed and current limits
    /// (any trip stops the drive and aborts), identification in fixed memory with progress,
    /// store, report.
    pub fn commission(
        &mut self,
        seed: u64,
        link: &mut impl Link,
        drive: &mut impl Drive,
        params: &mut impl ParamStore,
    ) -> Option<MotorReport> {
        let dt = drive.dt();
        let n = N;
        let experiment = Experiment {
            profile: Profile::Steps,
            voltage: self.limits.voltage,
            duration: dt * n as f32,
            load_torque: 0.0,
        };
        let s = &mut *self.store;
        s.dt = dt;
        s.with_current = true;
        s.len = 0;
        s.expected = n;
        for k in 0..n {
            let v = experiment.at(k as f32 * dt).v;
            let sample = drive.step(v);
            let trip = !(sample.current.abs() <= self.limits.current
                && sample.omega.abs() <= self.limits.speed);
            if trip {
                drive.stop();
                link.send(&BoardMessage::Refused(Refusal::Trip));
                return None;
            }
            s.v[k] = v;
            s.omega[k] = sample.omega;
            s.current[k] = sample.current;
            s.len = k + 1;
            if k % 256 == 0 {
                link.send(&BoardMessage::Progress {
                    stage: JobStage::Experiment,
                    iteration: k as u32,
                    evaluations: 0,
                    best: 0.0,
                });
                if matches!(link.poll(), Some(HostMessage::Abort)) {
                    drive.stop();
                    link.send(&BoardMessage::Aborted);
                    return None;
                }
            }
        }
        drive.stop();
        self.identify_and_report(&IdentifyConfig::board(seed), link, Some(params))
    }
}
