//! Tests of the service state machine (`device::service`), driven by the simulated plant.

use super::*;
use crate::device::commissioning::SAFETY_SAMPLES;
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
}

impl Link for TestLink {
    fn send(&mut self, msg: &BoardMessage) {
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

/// Parameters in RAM: the stored report and the saves. Like a flash sector, it erases
/// within the watchdog's stall (the one the service hands it: the hardware's).
#[derive(Default)]
struct RamParams(Option<MotorReport>, u32);

/// A flash sector's worst erase time [ms] (STM32F405, 128 KB at x8 parallelism).
const ERASE_MS: u32 = 4_000;

impl ParamStore for RamParams {
    fn load(&mut self) -> Result<MotorReport, NotStored> {
        self.0.clone().ok_or(NotStored::Empty)
    }
    fn save(&mut self, report: &MotorReport, watchdog: &mut dyn Watchdog) {
        watchdog.stall(ERASE_MS, &mut || {});
        self.0 = Some(report.clone());
        self.1 += 1;
    }
    fn clear(&mut self, watchdog: &mut dyn Watchdog) {
        watchdog.stall(ERASE_MS, &mut || {});
        self.0 = None;
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
    assert!(hw.watchdog.0 > (SAFETY_SAMPLES + SAMPLES) as u32 + progress_count(&hw.link.sent) - 8);
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
    assert_eq!(hw.params.0, None);
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

#[test]
fn a_chunk_that_would_end_past_u32_max_is_refused_not_taken_for_a_repeat() {
    // On the board (32-bit usize) offset + len of this chunk wrapped round to 0, the count
    // received: it was acknowledged as a repeat of the last chunk (or panicked in a debug
    // build) instead of refused. A 64-bit host cannot wrap: this guards the 32-bit case
    // when the tests run on a 32-bit target.
    let mut store = RecordStore::<SAMPLES>::new();
    let mut service = Service::new(&mut store, LIMITS);
    let mut hw = hardware(seed_plant());
    let one = heapless::Vec::from_slice(&[1.0]).unwrap();
    let requests = [
        HostMessage::Hello {
            version: PROTOCOL_VERSION,
        },
        HostMessage::IdentifyBegin {
            dt: 0.01,
            samples: 16,
            with_current: false,
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
