//! motor-id drive-board firmware (QEMU netduinoplus2 build): answers the host over USART1 and
//! commissions the (simulated) motor on request; the application logic is
//! `motor_id_shared::service`, shared with the host tests.
#![no_std]
#![no_main]

mod link;
mod plant;
mod usart;

use cortex_m_rt::entry;
use motor_id_shared::params::ModelParams;
use motor_id_shared::protocol::MotorReport;
use motor_id_shared::service::{Limits, ParamStore, RecordStore, Service};
use panic_semihosting as _;

/// Longest record the board holds (2,000 samples of voltage, speed and current: 24 KB).
const MAX_SAMPLES: usize = 2000;

/// Parameters kept in RAM (QEMU has no persistent flash; the board keeps them in a flash
/// sector with a CRC).
#[derive(Default)]
struct RamStore(Option<MotorReport>);

impl ParamStore for RamStore {
    fn load(&mut self) -> Option<MotorReport> {
        self.0
    }
    fn save(&mut self, report: &MotorReport) {
        self.0 = Some(*report);
    }
    fn clear(&mut self) {
        self.0 = None;
    }
}

#[entry]
fn main() -> ! {
    let store: &'static mut RecordStore<MAX_SAMPLES> =
        cortex_m::singleton!(: RecordStore<MAX_SAMPLES> = RecordStore::new())
            .expect("main runs once");
    let limits = Limits {
        voltage: 50.0,
        current: 40.0,
        speed: 500.0,
    };
    let mut service = Service::new(store, limits);
    let mut link = link::SerialLink::new(usart::Usart1::new());
    // The seed paper's motor, sampled at 100 Hz over the 20 s of a commissioning record.
    let mut drive = plant::SimulatedPlant::new(&ModelParams::SEED_MOTOR, 0.01, 0.5, 0.02, 7)
        .expect("the seed motor simulates");
    let mut params = RamStore::default();
    loop {
        use motor_id_shared::service::Link;
        if let Some(msg) = link.poll() {
            service.handle(msg, &mut link, &mut drive, &mut params);
        }
    }
}
