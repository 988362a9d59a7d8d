//! Flash sector 11 of the STM32F405 (0x080E_0000, 128 KB) as the parameter sector.

use motor_id_shared::device::flash_store::ParamFlash;
use motor_id_shared::wire::stored::STORED_LEN;
use stm32f4xx_hal::flash::FlashExt;
use stm32f4xx_hal::pac::FLASH;

/// Sector number.
const SECTOR: u8 = 11;
/// Offset of the sector from the start of flash.
const OFFSET: usize = 0x000E_0000;
/// Address of the sector.
const ADDRESS: usize = 0x0800_0000 + OFFSET;

/// The parameter sector.
pub struct Sector11(FLASH);

impl Sector11 {
    /// Own the flash interface.
    pub fn new(flash: FLASH) -> Self {
        Sector11(flash)
    }
}

impl ParamFlash for Sector11 {
    /// 128 KB sector erase at x8 parallelism (the HAL's `PSIZE`): typically 2 s, at most
    /// 4 s (STM32F405 datasheet, Flash memory programming characteristics).
    const ERASE_MAX_MS: u32 = 4_000;
    fn read(&mut self) -> [u8; STORED_LEN] {
        let mut out = [0u8; STORED_LEN];
        for (k, b) in out.iter_mut().enumerate() {
            // SAFETY: the sector lies in the memory-mapped flash, outside the program (memory.x).
            *b = unsafe { core::ptr::read_volatile((ADDRESS + k) as *const u8) };
        }
        out
    }

    fn erase(&mut self) {
        // A failed erase reads back as invalid: nothing stored, commission at next power-up.
        if self.0.unlocked().erase(SECTOR).is_err() {
            defmt::error!("erase of the parameter sector failed");
        }
    }

    fn program(&mut self, bytes: &[u8; STORED_LEN]) {
        if self.0.unlocked().program(OFFSET, bytes.iter()).is_err() {
            defmt::error!("programming the parameter sector failed");
        }
    }
}
