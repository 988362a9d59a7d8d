//! Tests of the service state machine (`device::service`), driven by the simulated plant.

use super::*;
use crate::device::plant::{SimulatedPlant, DEMO_FRICTION};
use crate::model::params::ModelParams;
use crate::param_id::ParamId;
use std::collections::VecDeque;

#[path = "service_fuzz.rs"]
mod fuzz;

/// A link whose incoming requests are queued, each released after `after` polls; it keeps
/// what it released and what was sent.
#[derive(Default)]
struct TestLink {
    incoming: VecDeque<(u32, HostMessage)>,
    polls: u32,
    received: Vec<HostMessage>,
    sent: Vec<BoardMessage>,
    /// Polls made when the first progress of a fit (not of the experiment) was sent.
    polls_at_fit: Option<u32>,
}

impl Link for TestLink {
    fn send(&mut self, msg: &BoardMessage) {
        if let BoardMessage::Progress { stage, .. } = msg {
            if !matches!(stage, JobStage::Probe | JobStage::Experiment) {
                self.polls_at_fit.get_or_insert(self.polls);
            }
        }
        self.sent.push(msg.clone());
    }
    fn poll(&mut self) -> Option<HostMessage> {
        self.polls += 1;
        match self.incoming.front() {
            Some((after, _)) if self.polls > *after => {
                let (_, msg) = self.incoming.pop_front()?;
                self.received.push(msg.clone());
                Some(msg)
            }
            _ => None,
        }
    }
}

/// Parameters in RAM: what is stored and the saves. Like a flash sector, it erases within
/// the watchdog's stall (the one the service hands it: the hardware's).
#[derive(Default)]
struct RamParams(Option<Stored>, u32);

impl RamParams {
    /// The stored report.
    fn report(&self) -> Option<MotorReport> {
        self.0.as_ref().and_then(|s| s.report.clone())
    }
}

/// A flash sector's worst erase time [ms] (STM32F405, 128 KB at x8 parallelism).
const ERASE_MS: u32 = 4_000;

impl ParamStore for RamParams {
    fn load(&mut self) -> Result<Stored, NotStored> {
        self.0.clone().ok_or(NotStored::Empty)
    }
    fn save(&mut self, stored: &Stored, watchdog: &mut dyn Watchdog) {
        watchdog.stall(ERASE_MS, &mut || {});
        self.0 = Some(stored.clone());
        self.1 += 1;
    }
}

/// A watchdog that counts its feeds and its stalls.
#[derive(Default)]
struct CountingWatchdog(u32, u32);

impl Watchdog for CountingWatchdog {
    fn feed(&mut self) {
        self.0 += 1;
    }
    fn stall(&mut self, _up_to_ms: u32, op: &mut dyn FnMut()) {
        self.1 += 1;
        op();
        self.0 += 1;
    }
}

const LIMITS: Limits = Limits::DEFAULT;
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

/// The drive's sample period in these tests [s] (1 kHz).
const DT: f32 = 1e-3;

/// The paper's motor with Coulomb friction `tc`, sampled at [`DT`] with sensor noise.
fn plant_with_friction(tc: f32) -> SimulatedPlant {
    let p = ModelParams::PAPER_MOTOR.with(ParamId::Tc, tc);
    SimulatedPlant::new(&p, DT, 0.5, 0.02, 7).unwrap()
}

fn paper_plant() -> SimulatedPlant {
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

#[test]
fn first_power_up_commissions_then_boots_into_service() {
    let mut store = RecordStore::<SAMPLES>::new();
    let mut service = Service::new(&mut store, LIMITS);
    let mut hw = hardware(paper_plant());
    let Boot::Commissioned { report, found } = service.boot(&mut hw) else {
        panic!("expected commissioning, got {:?}", hw.link.sent.last());
    };
    assert_eq!(found, NotStored::Empty);
    assert_paper_motor(&report);
    let friction = friction_of(&report);
    assert!(friction.std < 0.1 * DEMO_FRICTION, "tc {friction:?}");
    assert_eq!(report.rank, 6, "speed, current and coast-down pin all six");
    assert_eq!(hw.params.report(), Some(report.clone()));
    assert_eq!(hw.drive.stopped, 1, "drive removed after the experiment");
    assert_eq!(
        hw.link.sent.last(),
        Some(&BoardMessage::Identified(report.clone()))
    );
    // Every sample and every progress report fed the watchdog.
    let fit_reports = hw
        .link
        .sent
        .iter()
        .filter(|m| {
            matches!(m, BoardMessage::Progress { stage, .. }
                if !matches!(stage, JobStage::Probe | JobStage::Experiment))
        })
        .count() as u32;
    assert!(hw.watchdog.0 >= hw.drive.samples + fit_reports);
    // The whole experiment within its budget.
    assert!(hw.drive.samples as f32 * DT <= LIMITS.budget);
    // The next power-up finds the parameters and runs no experiment.
    let mut service = Service::new(&mut store, LIMITS);
    hw.link.sent.clear();
    assert_eq!(service.boot(&mut hw), Boot::InService(report));
    assert!(hw.link.sent.is_empty());
    assert_eq!(hw.params.1, 1, "stored once");
    // The store erased within the hardware's watchdog stall; so does a clear.
    assert_eq!(hw.watchdog.1, 1);
    service.handle(
        HostMessage::Hello {
            version: PROTOCOL_VERSION,
        },
        &mut hw,
    );
    service.handle(HostMessage::ClearParams, &mut hw);
    assert_eq!(hw.params.report(), None);
    assert_eq!(hw.watchdog.1, 2);
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

/// Power-up finds nothing stored and commissioning is refused for `why`: nothing stored, the
/// refusal the last message sent.
fn assert_refused_at_boot<D: Drive>(
    service: &mut Service<'_, SAMPLES>,
    hw: &mut Hardware<TestLink, D, RamParams, CountingWatchdog>,
    why: Refusal,
) {
    let end = JobEnd::Refused(why);
    let found = NotStored::Empty;
    assert_eq!(service.boot(hw), Boot::NotCommissioned { end, found });
    assert_eq!(hw.params.report(), None);
    assert_eq!(hw.link.sent.last(), Some(&BoardMessage::Refused(why)));
}

/// The plan a commissioning sent.
fn plan_of(sent: &[BoardMessage]) -> crate::wire::protocol::Plan {
    let plan = sent.iter().find_map(|m| match m {
        BoardMessage::Planned(p) => Some(*p),
        _ => None,
    });
    plan.expect("the probe sent its plan")
}

/// Assert the paper's motor's five parameters and friction within 3 %.
fn assert_paper_motor(report: &MotorReport) {
    let truth = [3.412, 0.0573, 0.0424, 0.00267, 0.1604];
    for (k, want) in truth.into_iter().enumerate() {
        let got = motor_value(report, k);
        assert!((got / want - 1.0).abs() < 0.03, "{k}: {got} vs {want}");
    }
    let tc = friction_of(report).value;
    assert!((tc / DEMO_FRICTION - 1.0).abs() < 0.03, "tc {tc}");
}

#[test]
fn a_current_sensor_offset_is_measured_and_removed_and_a_gross_one_refused() {
    let mut store = RecordStore::<SAMPLES>::new();
    let mut service = Service::new(&mut store, LIMITS);
    let mut plant = paper_plant();
    plant.offset.current = 2.0;
    let mut hw = hardware(plant);
    let report = service.commission(1, &mut hw).expect("commissioned");
    let offset = plan_of(&hw.link.sent).current_offset;
    assert!((offset - 2.0).abs() < 0.01, "offset {offset}");
    assert_paper_motor(&report);
    // An offset of 12.5 % of the limit is a fault, found before any voltage is applied.
    let mut plant = paper_plant();
    plant.offset.current = 5.0;
    let mut hw = hardware(plant);
    assert_refused_at_boot(&mut service, &mut hw, Refusal::SensorFault);
    assert_eq!(hw.drive.stopped, 1);
    assert!(!hw
        .link
        .sent
        .iter()
        .any(|m| matches!(m, BoardMessage::Planned(_))));
}

/// A drive that remembers the largest current it read, and from sample `fault_at` on reads
/// `fault` amps more (a shorted winding, a broken sensor).
struct Watched {
    plant: SimulatedPlant,
    largest: f32,
    fault_at: u32,
    fault: f32,
}

impl Drive for Watched {
    fn dt(&self) -> f32 {
        self.plant.dt()
    }
    fn step(&mut self, volts: f32) -> crate::device::hardware::Sample {
        self.read(|p| p.step(volts))
    }
    fn coast(&mut self) -> crate::device::hardware::Sample {
        self.read(|p| p.coast())
    }
    fn stop(&mut self) {
        self.plant.stop();
    }
}

impl Watched {
    fn new(plant: SimulatedPlant) -> Self {
        Watched {
            plant,
            largest: 0.0,
            fault_at: u32::MAX,
            fault: 0.0,
        }
    }
    fn read(
        &mut self,
        f: impl FnOnce(&mut SimulatedPlant) -> crate::device::hardware::Sample,
    ) -> crate::device::hardware::Sample {
        let mut s = f(&mut self.plant);
        if self.plant.samples >= self.fault_at {
            s.current += self.fault;
        }
        self.largest = self.largest.max(s.current.abs());
        s
    }
}

fn watched_hardware(drive: Watched) -> Hardware<TestLink, Watched, RamParams, CountingWatchdog> {
    Hardware {
        link: TestLink::default(),
        drive,
        params: RamParams::default(),
        watchdog: CountingWatchdog::default(),
    }
}

/// The default limits with 5 A allowed.
const FIVE_AMPS: Limits = Limits {
    current: 5.0,
    ..LIMITS
};

#[test]
fn a_tight_current_limit_is_kept_and_the_motor_still_commissioned() {
    // The paper's motor draws 50 V / 3.412 Ohm = 14.7 A from rest at 50 V: with 5 A allowed the
    // probe finds Ra first and the experiment stays under the limit.
    let mut store = RecordStore::<SAMPLES>::new();
    let mut service = Service::new(&mut store, FIVE_AMPS);
    let mut hw = watched_hardware(Watched::new(paper_plant()));
    let report = service.commission(1, &mut hw).expect("commissioned");
    assert_paper_motor(&report);
    assert!(hw.drive.largest < 0.9 * 5.0, "{} A", hw.drive.largest);
    assert!(plan_of(&hw.link.sent).volts < 0.7 * 5.0 * 3.412 * 1.1);
}

/// Open a session.
fn say_hello<D: Drive>(
    service: &mut Service<'_, SAMPLES>,
    hw: &mut Hardware<TestLink, D, RamParams, CountingWatchdog>,
) {
    let hello = HostMessage::Hello {
        version: PROTOCOL_VERSION,
    };
    service.handle(hello, hw);
}

#[test]
fn limits_set_by_the_host_are_stored_kept_over_power_up_and_clear_and_obeyed() {
    // Coulomb friction of 1 N m needs 1 / 0.1604 = 6.2 A to turn the shaft: the default
    // 40 A turn it, 5 A cannot.
    let mut store = RecordStore::<SAMPLES>::new();
    let mut hw = watched_hardware(Watched::new(plant_with_friction(1.0)));
    let mut service = Service::new(&mut store, LIMITS);
    say_hello(&mut service, &mut hw);
    service.handle(HostMessage::Configure(FIVE_AMPS), &mut hw);
    assert_eq!(hw.link.sent.last(), Some(&BoardMessage::Limits(FIVE_AMPS)));
    // Unusable limits are refused and change nothing.
    let too_short = Limits {
        budget: 1.0,
        ..FIVE_AMPS
    };
    service.handle(HostMessage::Configure(too_short), &mut hw);
    let refused = BoardMessage::Refused(Refusal::BadLimits);
    assert_eq!(hw.link.sent.last(), Some(&refused));
    // Erasing the parameters keeps the limits.
    service.handle(HostMessage::ClearParams, &mut hw);
    assert_eq!(hw.params.0.as_ref().map(|s| s.limits), Some(FIVE_AMPS));
    // Power cycle: the stored limits hold, and power-up commissioning works within them:
    // the shaft does not turn within 5 A, refused before any trip.
    let mut service = Service::new(&mut store, LIMITS);
    assert_refused_at_boot(&mut service, &mut hw, Refusal::NoMotion);
    assert!(hw.drive.largest < 5.0, "{} A", hw.drive.largest);
    assert_eq!(hw.drive.plant.stopped, 1);
    say_hello(&mut service, &mut hw);
    service.handle(HostMessage::ReadLimits, &mut hw);
    assert_eq!(hw.link.sent.last(), Some(&BoardMessage::Limits(FIVE_AMPS)));
}

/// Every part of record `index` the board sends, read from `offset` 0 on.
fn read_record<D: Drive>(
    service: &mut Service<'_, SAMPLES>,
    hw: &mut Hardware<TestLink, D, RamParams, CountingWatchdog>,
    index: u8,
) -> Vec<crate::wire::protocol::RecordPart> {
    let mut parts = Vec::new();
    let mut offset = 0;
    loop {
        service.handle(
            HostMessage::ReadRecord {
                record: index,
                offset,
            },
            hw,
        );
        match hw.link.sent.last() {
            Some(BoardMessage::RecordData(part)) => {
                offset += part.v.len() as u32;
                let done = offset >= part.samples;
                parts.push(part.clone());
                if done {
                    return parts;
                }
            }
            other => panic!("record {index} at {offset}: {other:?}"),
        }
    }
}

#[test]
fn the_records_of_a_commissioning_are_read_back_exactly_as_fitted() {
    let mut store = RecordStore::<SAMPLES>::new();
    let mut hw = hardware(paper_plant());
    let mut service = Service::new(&mut store, LIMITS);
    say_hello(&mut service, &mut hw);
    let nothing = BoardMessage::Refused(Refusal::NoRecord);
    service.handle(
        HostMessage::ReadRecord {
            record: 0,
            offset: 0,
        },
        &mut hw,
    );
    assert_eq!(hw.link.sent.last(), Some(&nothing), "nothing recorded yet");
    service.commission(1, &mut hw).expect("commissioned");
    let read: Vec<_> = (0..2)
        .map(|k| read_record(&mut service, &mut hw, k))
        .collect();
    for (index, offset) in [(2, 0), (0, read[0][0].samples)] {
        service.handle(
            HostMessage::ReadRecord {
                record: index,
                offset,
            },
            &mut hw,
        );
        assert_eq!(hw.link.sent.last(), Some(&nothing), "{index} at {offset}");
    }
    let records = store.records();
    assert_eq!(records.len(), 2);
    for (parts, r) in read.iter().zip(&records) {
        let column = |f: fn(&crate::wire::protocol::RecordPart) -> &[f32]| -> Vec<f32> {
            parts.iter().flat_map(|p| f(p).to_vec()).collect()
        };
        assert!(parts.iter().all(|p| p.records == 2 && p.dt == r.dt));
        assert_eq!(parts[0].coast_from, r.coast_from.map(|k| k as u32));
        assert_eq!(column(|p| &p.v), r.v);
        assert_eq!(column(|p| &p.omega), r.omega);
        assert_eq!(Some(column(|p| &p.current).as_slice()), r.current);
    }
    assert!(read[0][0].coast_from.is_some() && read[1][0].coast_from.is_none());
}

#[test]
fn a_current_trip_stops_the_drive_and_stores_nothing() {
    // A fault that reads 100 A one second in: the bench trips at once.
    let mut store = RecordStore::<SAMPLES>::new();
    let mut service = Service::new(&mut store, LIMITS);
    let mut drive = Watched::new(paper_plant());
    drive.fault_at = FAULT_AT;
    drive.fault = 100.0;
    let mut hw = watched_hardware(drive);
    assert_refused_at_boot(&mut service, &mut hw, Refusal::Trip);
    assert_eq!(hw.drive.plant.stopped, 1);
    assert_eq!(hw.drive.plant.samples, FAULT_AT, "stopped at the trip");
}

/// The sample at which [`a_current_trip_stops_the_drive_and_stores_nothing`]'s fault shows
/// (one second in).
const FAULT_AT: u32 = (1.0 / DT) as u32;

#[test]
fn a_motor_that_never_comes_to_rest_is_not_driven() {
    let mut store = RecordStore::<SAMPLES>::new();
    let mut service = Service::new(&mut store, LIMITS);
    let mut plant = paper_plant();
    plant.offset.omega = 50.0;
    let mut hw = hardware(plant);
    assert_refused_at_boot(&mut service, &mut hw, Refusal::NotAtRest);
}

#[test]
fn commissioning_again_waits_for_the_motor_to_stop_turning() {
    let mut store = RecordStore::<SAMPLES>::new();
    let mut service = Service::new(&mut store, LIMITS);
    let mut hw = hardware(paper_plant());
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
fn abort_during_identification_stores_nothing_and_requests_meanwhile_are_busy() {
    let mut store = RecordStore::<SAMPLES>::new();
    let mut service = Service::new(&mut store, LIMITS);
    // A first run counts the polls of the experiment (the plant is seeded: the same run).
    let mut hw = hardware(paper_plant());
    let _ = service.commission(BOOT_SEED, &mut hw);
    let fit = hw.link.polls_at_fit.expect("the fit reported");
    // The hello comes at the fit's first poll, the abort at its second.
    let mut hw = hardware(paper_plant());
    let hello = HostMessage::Hello {
        version: PROTOCOL_VERSION,
    };
    hw.link.incoming.push_back((fit, hello));
    hw.link.incoming.push_back((fit + 1, HostMessage::Abort));
    assert_eq!(
        service.boot(&mut hw),
        Boot::NotCommissioned {
            end: JobEnd::Aborted,
            found: NotStored::Empty
        }
    );
    assert_eq!(hw.params.report(), None);
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
    let mut hw = hardware(paper_plant());
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

#[test]
fn a_chunk_that_would_end_past_u32_max_is_refused_not_taken_for_a_repeat() {
    // On the board (32-bit usize) offset + len of this chunk wrapped round to 0, the count
    // received: it was acknowledged as a repeat of the last chunk (or panicked in a debug
    // build) instead of refused. A 64-bit host cannot wrap: this guards the 32-bit case
    // when the tests run on a 32-bit target.
    let mut store = RecordStore::<SAMPLES>::new();
    let mut service = Service::new(&mut store, LIMITS);
    let mut hw = hardware(paper_plant());
    let one = heapless::Vec::from_slice(&[1.0]).unwrap();
    let requests = [
        HostMessage::Hello {
            version: PROTOCOL_VERSION,
        },
        HostMessage::IdentifyBegin {
            dt: 0.01,
            samples: 16,
            with_current: false,
            coast_from: None,
        },
        HostMessage::RecordChunk {
            offset: u32::MAX,
            v: one.clone(),
            omega: one,
            current: heapless::Vec::new(),
        },
    ];
    for r in requests {
        service.handle(r, &mut hw);
    }
    assert_eq!(
        hw.link.sent.last(),
        Some(&BoardMessage::Refused(Refusal::BadChunk))
    );
}
