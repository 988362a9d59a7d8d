//! Parameters in non-volatile memory: the record of `motor_id_shared::wire::stored` (magic,
//! layout version, CRC) in one flash sector of the board, or in RAM for QEMU.

use motor_id_shared::device::hardware::{ParamStore, Watchdog};
use motor_id_shared::wire::protocol::{MotorReport, NotStored};
use motor_id_shared::wire::stored::{self, STORED_LEN};

/// The bytes of a parameter sector.
pub trait ParamFlash {
    /// Read the record area.
    fn read(&mut self) -> [u8; STORED_LEN];
    /// Longest erase [ms]: the processor stalls that long (every fetch from flash waits),
    /// so the erase runs within the watchdog's [`Watchdog::stall`].
    const ERASE_MAX_MS: u32;
    /// Erase the sector (all bytes `0xFF`).
    fn erase(&mut self);
    /// Program the erased record area with `bytes`.
    fn program(&mut self, bytes: &[u8; STORED_LEN]);
}

/// [`ParamStore`] on a [`ParamFlash`].
pub struct FlashStore<F>(pub F);

impl<F: ParamFlash> ParamStore for FlashStore<F> {
    fn load(&mut self) -> Result<MotorReport, NotStored> {
        stored::decode(&self.0.read())
    }

    fn save(&mut self, report: &MotorReport, watchdog: &mut dyn Watchdog) {
        let bytes = stored::encode(report);
        watchdog.stall(F::ERASE_MAX_MS, &mut || self.0.erase());
        self.0.program(&bytes);
        if self.0.read() != bytes {
            defmt::error!("parameter sector did not read back what was written");
        }
    }

    fn clear(&mut self, watchdog: &mut dyn Watchdog) {
        watchdog.stall(F::ERASE_MAX_MS, &mut || self.0.erase());
    }
}
