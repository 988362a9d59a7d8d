//! The QEMU netduinoplus2 board layer: USART1 (no clock or pin set-up: QEMU needs none, and
//! its RCC would make a HAL's clock set-up spin), a motor simulated behind the
//! [`Drive`](motor_id_shared::device::hardware::Drive) trait that the board's PWM and ADC implement
//! (the paper's with Coulomb friction, which commissioning identifies, unless QEMU's
//! command line gives another: [`plant_args::plant_motor`]),
//! parameters in RAM (QEMU keeps no flash writes), no watchdog (QEMU has no IWDG), defmt
//! over semihosting, and a meter of instructions and stack for the footprint report.

mod meter;
mod plant_args;
mod usart;

use crate::app::{State, StatusLed};
use crate::link::SerialLink;
use defmt_semihosting as _;
use motor_id_shared::device::flash_store::{FlashStore, ParamFlash};
use motor_id_shared::device::hardware::{Hardware, NoWatchdog};
use motor_id_shared::device::plant::{demo_motor, SimulatedPlant};
use motor_id_shared::wire::stored::STORED_LEN;
use panic_semihosting as _;

/// Sample period of the simulated drive: 2 kHz, 34 samples per La/Ra of the paper's motor
/// (commissioning averages them into its records' steps).
const DT: f32 = 5e-4;
/// Sensor noise of the simulated tacho [rad/s] and current sensor [A].
const NOISE: (f32, f32) = (0.5, 0.02);
/// Seed of the sensor noise.
const NOISE_SEED: u64 = 7;

/// The parameter "sector" in RAM: erased at every start, as a new board's flash is.
pub struct RamFlash([u8; STORED_LEN]);

impl ParamFlash for RamFlash {
    const ERASE_MAX_MS: u32 = 0;
    fn read(&mut self) -> [u8; STORED_LEN] {
        self.0
    }
    fn erase(&mut self) {
        self.0 = [0xFF; STORED_LEN];
    }
    fn program(&mut self, bytes: &[u8; STORED_LEN]) {
        // Flash programming only clears bits.
        for (cell, b) in self.0.iter_mut().zip(bytes) {
            *cell &= *b;
        }
    }
}

/// No LED on the emulated board: the state goes to the log.
pub struct LogLed;

impl StatusLed for LogLed {
    fn show(&mut self, state: State) {
        defmt::info!("status LED: {}", state);
    }
}

/// The emulated board's hardware.
pub type QemuHardware = Hardware<
    meter::MeteredLink<SerialLink<usart::Usart1>>,
    meter::MeteredDrive<SimulatedPlant>,
    FlashStore<RamFlash>,
    NoWatchdog,
>;

/// Bring up the emulated board.
pub fn init() -> (QemuHardware, LogLed) {
    let core = cortex_m::Peripherals::take().expect("init runs once");
    meter::start(core.SYST);
    let link = meter::MeteredLink::new(SerialLink::new(usart::Usart1::new()));
    let motor = plant_args::plant_motor(demo_motor());
    let drive = SimulatedPlant::new(&motor, DT, NOISE.0, NOISE.1, NOISE_SEED)
        .expect("the plant's motor was validated");
    let hw = Hardware {
        link,
        drive: meter::MeteredDrive(drive),
        params: FlashStore(RamFlash([0xFF; STORED_LEN])),
        watchdog: NoWatchdog,
    };
    (hw, LogLed)
}
