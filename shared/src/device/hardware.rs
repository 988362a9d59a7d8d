//! The board as the application sees it: the traits that the board and QEMU builds
//! implement (link to the host, power stage with its sensors, parameter store, watchdog).
//! No register and no arithmetic here.

use crate::wire::protocol::{BoardMessage, HostMessage, NotStored};
use crate::wire::stored::Stored;

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
    /// Wait for the next sample, return it, then apply `volts` until the one after.
    fn step(&mut self, volts: f32) -> Sample;
    /// Wait for the next sample, return it, then keep every bridge switch off until the one
    /// after (open circuit: the motor coasts; the next [`Drive::step`] drives it again).
    fn coast(&mut self) -> Sample;
    /// [`Drive::step`] or [`Drive::coast`], as `bridge` says.
    fn apply(&mut self, bridge: Bridge) -> Sample {
        match bridge {
            Bridge::Drive(volts) => self.step(volts),
            Bridge::Open => self.coast(),
        }
    }
    /// Remove drive (all bridge switches off: the motor coasts).
    fn stop(&mut self);
}

/// Non-volatile storage of the commissioning limits and the identified motor.
pub trait ParamStore {
    /// What is stored, or why nothing is read (nothing stored, another layout, corrupted).
    fn load(&mut self) -> Result<Stored, NotStored>;
    /// Store `stored` in place of what was. An erase that stalls the processor runs within
    /// `watchdog`'s [`Watchdog::stall`].
    fn save(&mut self, stored: &Stored, watchdog: &mut dyn Watchdog);
}

/// The independent watchdog: it stays on during experiments and identification, which feed
/// it at every sample and every optimiser iteration.
pub trait Watchdog {
    /// Restart the watchdog's count-down.
    fn feed(&mut self);
    /// Run `op`, during which the processor may stall for up to `up_to_ms` milliseconds with
    /// no chance to feed (a flash sector erase stalls every fetch from flash: up to 4 s for
    /// a 128 KB sector of the STM32F405), the watchdog's window widened to cover it, then
    /// restored and the count-down restarted.
    fn stall(&mut self, up_to_ms: u32, op: &mut dyn FnMut());
}

/// For builds without a watchdog (QEMU does not model the IWDG).
pub struct NoWatchdog;

impl Watchdog for NoWatchdog {
    fn feed(&mut self) {}
    fn stall(&mut self, _up_to_ms: u32, op: &mut dyn FnMut()) {
        op();
    }
}

/// The board as the application sees it: link, drive, parameter store, watchdog.
pub struct Hardware<L, D, P, W> {
    /// Link to the host.
    pub link: L,
    /// Power stage and sensors.
    pub drive: D,
    /// Non-volatile parameters.
    pub params: P,
    /// Independent watchdog.
    pub watchdog: W,
}

/// What the bridge does over one sample of the commissioning experiment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bridge {
    /// Apply this armature voltage [V].
    Drive(f32),
    /// Every switch off: the motor coasts.
    Open,
}

impl Bridge {
    /// The voltage column of the record: the applied voltage, 0 where the bridge is open
    /// (not applied; the record's `coast_from` says so).
    pub fn recorded_volts(self) -> f32 {
        match self {
            Bridge::Drive(volts) => volts,
            Bridge::Open => 0.0,
        }
    }
}
