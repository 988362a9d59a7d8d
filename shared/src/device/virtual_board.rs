//! A drive board on the host (`std`): the board's own commissioning
//! ([`crate::device::service::Service::commission`], unchanged) against the simulated plant
//! of [`crate::device::plant`], with the board's record memory, parameters in RAM and no
//! watchdog. `motor-id commission --sim` and the commissioning benchmark run it, so that a
//! user tries a motor before flashing a board.

use crate::device::hardware::{Drive, Hardware, Link, NoWatchdog, ParamStore, Watchdog};
use crate::device::job::JobEnd;
use crate::device::record_store::RecordStore;
use crate::device::service::Service;
use crate::fit::workspace::FitWorkspace;
use crate::model::record::Record;
use crate::wire::limits::Limits;
use crate::wire::protocol::{BoardMessage, HostMessage, MotorReport, NotStored, Plan};
use crate::wire::stored::Stored;
use core::sync::atomic::{AtomicBool, Ordering};
use std::boxed::Box;
use std::vec::Vec;

/// The board's record memory (the firmware's `MAX_SAMPLES`).
pub const BOARD_SAMPLES: usize = 2000;

/// One record the board recorded, copied out of its memory.
#[derive(Clone, Debug, PartialEq)]
pub struct BoardRecord {
    /// Sample step [s].
    pub dt: f32,
    /// Voltage applied [V] (0 where the bridge is open).
    pub v: Vec<f32>,
    /// Speed read [rad/s].
    pub omega: Vec<f32>,
    /// Current read, the sensor's offset removed [A].
    pub current: Vec<f32>,
    /// First sample of the coast-down (bridge open to the end).
    pub coast_from: Option<usize>,
    /// Drive samples each reading is the mean of ([`Record::averaged`]).
    pub averaged: u32,
}

impl BoardRecord {
    /// The record as the fit reads it: speed and current, and its coast-down.
    pub fn as_record(&self) -> Record<'_> {
        Record {
            dt: self.dt,
            v: &self.v,
            omega: &self.omega,
            current: Some(&self.current),
            load: None,
            coast_from: self.coast_from,
            averaged: self.averaged,
        }
    }
}

/// How a commissioning on the virtual board went.
#[derive(Debug)]
pub struct Commissioning {
    /// The probe's plan, if the probe got that far.
    pub plan: Option<Plan>,
    /// The report stored, or how it ended.
    pub result: Result<MotorReport, JobEnd>,
    /// Time the experiment took on the drive (probe and records) [s].
    pub seconds: f32,
    /// The records it recorded (slow, then fast), complete or not.
    pub records: Vec<BoardRecord>,
}

/// A link that hands every message to a callback and reads an abort from a flag.
struct CallbackLink<'a> {
    on_message: &'a mut dyn FnMut(&BoardMessage),
    abort: Option<&'a AtomicBool>,
    plan: Option<Plan>,
}

impl Link for CallbackLink<'_> {
    fn send(&mut self, msg: &BoardMessage) {
        if let BoardMessage::Planned(plan) = msg {
            self.plan = Some(*plan);
        }
        (self.on_message)(msg);
    }
    fn poll(&mut self) -> Option<HostMessage> {
        let stop = self.abort.is_some_and(|a| a.load(Ordering::Relaxed));
        stop.then_some(HostMessage::Abort)
    }
}

/// Parameters in RAM.
#[derive(Default)]
struct RamParams(Option<Stored>);

impl ParamStore for RamParams {
    fn load(&mut self) -> Result<Stored, NotStored> {
        self.0.clone().ok_or(NotStored::Empty)
    }
    fn save(&mut self, stored: &Stored, _watchdog: &mut dyn Watchdog) {
        self.0 = Some(stored.clone());
    }
}

/// A drive that counts its samples.
struct Counted<D> {
    drive: D,
    samples: u32,
}

impl<D: Drive> Drive for Counted<D> {
    fn dt(&self) -> f32 {
        self.drive.dt()
    }
    fn step(&mut self, volts: f32) -> crate::device::hardware::Sample {
        self.samples += 1;
        self.drive.step(volts)
    }
    fn coast(&mut self) -> crate::device::hardware::Sample {
        self.samples += 1;
        self.drive.coast()
    }
    fn stop(&mut self) {
        self.drive.stop();
    }
}

/// Commission `plant` (the simulated plant of [`crate::device::plant`], or any other drive:
/// the tests' independent reference plant) within `limits` with identification seed `seed`,
/// as the board does: every message goes to `on_message` as it is sent; `abort` set stops
/// it (as the host's `Abort` does). With `averaged`, each record sample is the mean of the
/// drive's readings over its step ([`Service::with_averaged_records`]).
pub fn commission<D: Drive>(
    plant: D,
    limits: Limits,
    averaged: bool,
    seed: u64,
    abort: Option<&AtomicBool>,
    on_message: &mut dyn FnMut(&BoardMessage),
) -> Commissioning {
    let mut store: Box<RecordStore<BOARD_SAMPLES>> = Box::default();
    // The fit's simulators lent as the firmware lends its static (the same result as on
    // the fit's frames, `fit::workspace`).
    let workspace = Box::new(FitWorkspace::new());
    let mut hw = Hardware {
        link: CallbackLink {
            on_message,
            abort,
            plan: None,
        },
        drive: Counted {
            drive: plant,
            samples: 0,
        },
        params: RamParams::default(),
        watchdog: NoWatchdog,
    };
    let result = Service::new(&mut *store, limits)
        .with_workspace(&workspace)
        .with_averaged_records(averaged)
        .commission(seed, &mut hw);
    let seconds = hw.drive.samples as f32 * hw.drive.dt();
    let records = store
        .records()
        .iter()
        .map(|r| BoardRecord {
            dt: r.dt,
            v: r.v.to_vec(),
            omega: r.omega.to_vec(),
            current: r.current.map(|c| c.to_vec()).unwrap_or_default(),
            coast_from: r.coast_from,
            averaged: r.averaged,
        })
        .collect();
    Commissioning {
        plan: hw.link.plan,
        result,
        seconds,
        records,
    }
}
