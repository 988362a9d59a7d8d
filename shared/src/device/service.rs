//! The drive board's application state machine, independent of any register: at power-up
//! it commissions a motor it has no valid parameters for (safety checks, bounded experiment,
//! identification, store) or goes straight into service; in service it answers the host's
//! [`crate::wire::protocol`] requests over a [`Link`], identifies from a record the host
//! streams in, and commissions again on request. The board and QEMU builds implement the
//! traits of [`crate::device::hardware`]; the tests below drive it with the simulated plant
//! of [`crate::device::plant`].

use crate::device::commissioning::{commissioning_spec, run_experiment, safety_checks, Limits};
use crate::device::hardware::{Drive, Hardware, Link, ParamStore, Watchdog};
use crate::device::job::{abort_requested, fail, JobEnd};
use crate::device::record_store::RecordStore;
use crate::device::report::motor_report;
use crate::fit::identify::{identify, IdentifyConfig, Pipeline, Progress, Stage};
use crate::fit::space::ProblemSpec;
use crate::wire::protocol::{
    BoardMessage, HostMessage, JobStage, MotorReport, NotStored, PipelineName, Refusal,
    PROTOCOL_VERSION,
};
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

/// The application state.
pub struct Service<'s, const N: usize> {
    store: &'s mut RecordStore<N>,
    session: bool,
    limits: Limits,
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

    /// Power-up: into service with valid stored parameters, otherwise self-commissioning
    /// (its progress and result go out on the link for whoever listens).
    pub fn boot<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
        &mut self,
        hw: &mut Hardware<L, D, P, W>,
    ) -> Boot {
        hw.watchdog.feed();
        let found = match hw.params.load() {
            Ok(stored) => return Boot::InService(stored),
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
                hw.link.send(&BoardMessage::Hello {
                    version: PROTOCOL_VERSION,
                    max_samples: N as u32,
                });
            } else {
                self.session = false;
                hw.link
                    .send(&BoardMessage::Refused(Refusal::VersionMismatch {
                        board: PROTOCOL_VERSION,
                    }));
            }
            return;
        }
        if !self.session {
            hw.link.send(&BoardMessage::Refused(Refusal::NoSession));
            return;
        }
        match msg {
            HostMessage::Hello { .. } => {}
            HostMessage::IdentifyBegin {
                dt,
                samples,
                with_current,
            } => {
                if samples as usize > N {
                    hw.link.send(&BoardMessage::Refused(Refusal::RecordTooLong {
                        max: N as u32,
                    }));
                    return;
                }
                let s = &mut *self.store;
                s.dt = dt;
                s.len = 0;
                s.expected = samples as usize;
                s.with_current = with_current;
                s.coast_from = None;
                hw.link.send(&BoardMessage::ChunkOk { next: 0 });
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
                    hw.link.send(&BoardMessage::ChunkOk { next: s.len as u32 });
                    return;
                }
                let ok = offset as usize == s.len
                    && omega.len() == n
                    && (!s.with_current || current.len() == n)
                    && s.len + n <= s.expected;
                if !ok {
                    hw.link.send(&BoardMessage::Refused(Refusal::BadChunk));
                    return;
                }
                for k in 0..n {
                    s.v[s.len + k] = v[k];
                    s.omega[s.len + k] = omega[k];
                    s.current[s.len + k] = if s.with_current { current[k] } else { 0.0 };
                }
                s.len += n;
                hw.link.send(&BoardMessage::ChunkOk { next: s.len as u32 });
            }
            HostMessage::Identify { seed, pipeline } => {
                if self.store.len != self.store.expected || self.store.len == 0 {
                    hw.link.send(&BoardMessage::Refused(Refusal::BadChunk));
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
                let stored = hw.params.load();
                hw.link.send(&BoardMessage::Params(stored));
            }
            HostMessage::ClearParams => {
                hw.params.clear();
                hw.link.send(&BoardMessage::Cleared);
            }
            HostMessage::Abort => hw.link.send(&BoardMessage::Aborted),
        }
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
        let record = [self.store.record()];
        let mut aborted = false;
        let (link, watchdog) = (&mut hw.link, &mut hw.watchdog);
        let result = identify(&record, spec, cfg, |p: &Progress| {
            watchdog.feed();
            link.send(&BoardMessage::Progress {
                stage: match p.stage {
                    Stage::Search => JobStage::Search,
                    Stage::Refine => JobStage::Refine,
                },
                iteration: p.iteration,
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
        let end = match result {
            _ if aborted => JobEnd::Aborted,
            // The board's own problems always fit its report (see `motor_report`).
            Ok(id) => match motor_report(&id) {
                Some(report) => {
                    if store {
                        hw.params.save(&report);
                    }
                    hw.link.send(&BoardMessage::Identified(report.clone()));
                    return Ok(report);
                }
                None => JobEnd::Refused(Refusal::InvalidRecord),
            },
            Err(crate::Error::InvalidConfig) => JobEnd::Refused(Refusal::PipelineTooLarge),
            Err(_) => JobEnd::Refused(Refusal::InvalidRecord),
        };
        fail(end, &mut hw.link)
    }

    /// Self-commissioning: safety checks, then a bounded experiment over the record's
    /// length (see [`commissioning_input`]: seed Section 6 speed changes, then a coast-down
    /// for friction; a trip of the current or speed limit stops the drive and aborts), read
    /// on tacho and current, identification in fixed memory with progress (the board
    /// pipeline, Coulomb friction free: [`commissioning_spec`]), store, report.
    pub fn commission<L: Link, D: Drive, P: ParamStore, W: Watchdog>(
        &mut self,
        seed: u64,
        hw: &mut Hardware<L, D, P, W>,
    ) -> Result<MotorReport, JobEnd> {
        if let Err(r) = safety_checks(&self.limits, &mut hw.drive, &mut hw.watchdog) {
            hw.drive.stop();
            return fail(JobEnd::Refused(r), &mut hw.link);
        }
        run_experiment(
            self.store,
            &self.limits,
            &mut hw.link,
            &mut hw.drive,
            &mut hw.watchdog,
        )?;
        self.identify_and_report(
            &commissioning_spec(),
            &IdentifyConfig::board(seed),
            hw,
            true,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::device::commissioning::SAFETY_SAMPLES;
    use crate::device::plant::{SimulatedPlant, DEMO_FRICTION};
    use crate::model::params::ModelParams;
    use crate::param_id::ParamId;
    use std::collections::VecDeque;

    /// A link whose incoming requests are queued, each released after `after` polls.
    #[derive(Default)]
    struct TestLink {
        incoming: VecDeque<(u32, HostMessage)>,
        polls: u32,
        sent: Vec<BoardMessage>,
    }

    impl Link for TestLink {
        fn send(&mut self, msg: &BoardMessage) {
            self.sent.push(msg.clone());
        }
        fn poll(&mut self) -> Option<HostMessage> {
            self.polls += 1;
            match self.incoming.front() {
                Some((after, _)) if self.polls > *after => self.incoming.pop_front().map(|m| m.1),
                _ => None,
            }
        }
    }

    #[derive(Default)]
    struct RamParams(Option<MotorReport>, u32);

    impl ParamStore for RamParams {
        fn load(&mut self) -> Result<MotorReport, NotStored> {
            self.0.clone().ok_or(NotStored::Empty)
        }
        fn save(&mut self, report: &MotorReport) {
            self.0 = Some(report.clone());
            self.1 += 1;
        }
        fn clear(&mut self) {
            self.0 = None;
        }
    }

    #[derive(Default)]
    struct CountingWatchdog(u32);

    impl Watchdog for CountingWatchdog {
        fn feed(&mut self) {
            self.0 += 1;
        }
    }

    const LIMITS: Limits = Limits {
        voltage: 50.0,
        current: 40.0,
        speed: 500.0,
    };
    const SAMPLES: usize = 2000;

    type TestHardware = Hardware<TestLink, SimulatedPlant, RamParams, CountingWatchdog>;

    fn hardware(plant: SimulatedPlant) -> TestHardware {
        Hardware {
            link: TestLink::default(),
            drive: plant,
            params: RamParams::default(),
            watchdog: CountingWatchdog::default(),
        }
    }

    /// The seed's motor with Coulomb friction `tc`, sampled at 100 Hz with sensor noise.
    fn plant_with_friction(tc: f32) -> SimulatedPlant {
        let p = ModelParams::SEED_MOTOR.with(ParamId::Tc, tc);
        SimulatedPlant::new(&p, 0.01, 0.5, 0.02, 7).unwrap()
    }

    fn seed_plant() -> SimulatedPlant {
        plant_with_friction(DEMO_FRICTION)
    }

    /// Motor parameter `k` (Ra, La, J, B, Kv) of a report.
    fn motor_value(report: &MotorReport, k: usize) -> f32 {
        let e = report.get(ParamId::MOTOR[k].index() as u8);
        e.expect("every report holds the five motor parameters")
            .value
    }

    /// The Coulomb friction a commissioning report holds.
    fn friction_of(report: &MotorReport) -> crate::wire::protocol::Estimate {
        let tc = report.get(ParamId::Tc.index() as u8);
        tc.expect("commissioning identifies friction")
    }

    fn progress_count(sent: &[BoardMessage]) -> u32 {
        sent.iter()
            .filter(|m| matches!(m, BoardMessage::Progress { .. }))
            .count() as u32
    }

    #[test]
    fn first_power_up_commissions_then_boots_into_service() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut hw = hardware(seed_plant());
        let Boot::Commissioned { report, found } = service.boot(&mut hw) else {
            panic!("expected commissioning, got {:?}", hw.link.sent.last());
        };
        assert_eq!(found, NotStored::Empty);
        let truth = [3.412, 0.0573, 0.0424, 0.00267, 0.1604];
        for (k, want) in truth.into_iter().enumerate() {
            let got = motor_value(&report, k);
            assert!((got / want - 1.0).abs() < 0.03, "{got} vs {want}");
        }
        let friction = friction_of(&report);
        assert!(
            (friction.value / DEMO_FRICTION - 1.0).abs() < 0.03,
            "tc {friction:?}"
        );
        assert!(friction.std < 0.1 * DEMO_FRICTION, "tc {friction:?}");
        assert_eq!(report.rank, 6, "speed, current and coast-down pin all six");
        assert_eq!(hw.params.0, Some(report.clone()));
        assert_eq!(hw.drive.stopped, 1, "drive removed after the experiment");
        assert_eq!(
            hw.link.sent.last(),
            Some(&BoardMessage::Identified(report.clone()))
        );
        // Every sample and every progress report fed the watchdog.
        assert!(
            hw.watchdog.0 > (SAFETY_SAMPLES + SAMPLES) as u32 + progress_count(&hw.link.sent) - 8
        );
        // The next power-up finds the parameters and runs no experiment.
        let mut service = Service::new(&mut store, LIMITS);
        hw.link.sent.clear();
        assert_eq!(service.boot(&mut hw), Boot::InService(report));
        assert!(hw.link.sent.is_empty());
        assert_eq!(hw.params.1, 1, "stored once");
    }

    #[test]
    fn a_motor_without_coulomb_friction_commissions_with_none() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut hw = hardware(plant_with_friction(0.0));
        let report = service.commission(1, &mut hw).expect("commissioned");
        let friction = friction_of(&report);
        // Within three standard deviations of none, and under 1 % of the stall torque.
        assert!(friction.value <= 3.0 * friction.std, "tc {friction:?}");
        assert!(
            friction.value < 0.01 * 0.1604 * 50.0 / 3.412,
            "tc {friction:?}"
        );
        assert!(
            (motor_value(&report, 3) / 0.00267 - 1.0).abs() < 0.03,
            "{report:?}"
        );
    }

    #[test]
    fn a_current_sensor_offset_fails_the_safety_check_before_any_voltage() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut plant = seed_plant();
        plant.offset.current = 2.0;
        let mut hw = hardware(plant);
        let end = JobEnd::Refused(Refusal::SensorFault);
        assert_eq!(
            service.boot(&mut hw),
            Boot::NotCommissioned {
                end,
                found: NotStored::Empty
            }
        );
        assert_eq!(hw.params.0, None);
        assert_eq!(hw.drive.stopped, 1);
        assert_eq!(
            hw.link.sent,
            vec![BoardMessage::Refused(Refusal::SensorFault)]
        );
    }

    #[test]
    fn a_motor_that_never_comes_to_rest_is_not_driven() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut plant = seed_plant();
        plant.offset.omega = 50.0;
        let mut hw = hardware(plant);
        let end = JobEnd::Refused(Refusal::NotAtRest);
        assert_eq!(
            service.boot(&mut hw),
            Boot::NotCommissioned {
                end,
                found: NotStored::Empty
            }
        );
        assert_eq!(hw.params.0, None);
    }

    #[test]
    fn commissioning_again_waits_for_the_motor_to_stop_turning() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut hw = hardware(seed_plant());
        let first = service.commission(2, &mut hw).expect("first commissioning");
        // The experiment ends at a quarter of the voltage: the motor still turns.
        let second = service
            .commission(2, &mut hw)
            .expect("second commissioning");
        for k in 0..5 {
            let (a, b) = (motor_value(&first, k), motor_value(&second, k));
            assert!((a / b - 1.0).abs() < 0.03, "{a} vs {b}");
        }
    }

    #[test]
    fn a_current_trip_stops_the_drive_and_stores_nothing() {
        let mut store = RecordStore::<SAMPLES>::new();
        // The seed motor draws 50 V / 3.412 Ohm = 14.7 A at the step: a 5 A limit trips.
        let limits = Limits {
            current: 5.0,
            ..LIMITS
        };
        let mut service = Service::new(&mut store, limits);
        let mut hw = hardware(seed_plant());
        let end = JobEnd::Refused(Refusal::Trip);
        assert_eq!(
            service.boot(&mut hw),
            Boot::NotCommissioned {
                end,
                found: NotStored::Empty
            }
        );
        assert_eq!(hw.params.0, None);
        assert_eq!(hw.drive.stopped, 1);
        assert_eq!(
            hw.link.sent.last(),
            Some(&BoardMessage::Refused(Refusal::Trip))
        );
    }

    #[test]
    fn abort_during_identification_stores_nothing_and_requests_meanwhile_are_busy() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut hw = hardware(seed_plant());
        // Polls 1..=8 fall in the experiment (every 256 samples), later ones in the fit: the
        // hello comes at the fit's first poll, the abort at its second.
        let hello = HostMessage::Hello {
            version: PROTOCOL_VERSION,
        };
        hw.link.incoming.push_back((8, hello));
        hw.link.incoming.push_back((9, HostMessage::Abort));
        assert_eq!(
            service.boot(&mut hw),
            Boot::NotCommissioned {
                end: JobEnd::Aborted,
                found: NotStored::Empty
            }
        );
        assert_eq!(hw.params.0, None);
        assert!(hw.link.sent.contains(&BoardMessage::Refused(Refusal::Busy)));
        assert_eq!(hw.link.sent.last(), Some(&BoardMessage::Aborted));
        assert!(hw.link.sent.iter().any(|m| matches!(
            m,
            BoardMessage::Progress {
                stage: JobStage::Search | JobStage::Refine,
                ..
            }
        )));
    }

    #[test]
    fn requests_need_a_session_of_the_same_version() {
        let mut store = RecordStore::<SAMPLES>::new();
        let mut service = Service::new(&mut store, LIMITS);
        let mut hw = hardware(seed_plant());
        service.handle(HostMessage::ReadParams, &mut hw);
        let hello = |version| HostMessage::Hello { version };
        service.handle(hello(PROTOCOL_VERSION + 1), &mut hw);
        service.handle(HostMessage::ReadParams, &mut hw);
        service.handle(hello(PROTOCOL_VERSION), &mut hw);
        service.handle(HostMessage::ReadParams, &mut hw);
        assert_eq!(
            hw.link.sent,
            vec![
                BoardMessage::Refused(Refusal::NoSession),
                BoardMessage::Refused(Refusal::VersionMismatch {
                    board: PROTOCOL_VERSION
                }),
                BoardMessage::Refused(Refusal::NoSession),
                BoardMessage::Hello {
                    version: PROTOCOL_VERSION,
                    max_samples: SAMPLES as u32
                },
                BoardMessage::Params(Err(NotStored::Empty)),
            ]
        );
    }
}
