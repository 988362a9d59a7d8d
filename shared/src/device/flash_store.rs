//! Parameters in non-volatile memory: the record of [`crate::wire::stored`] (magic, layout
//! version, CRC) in one flash sector of the board, or in RAM for QEMU; the sector's bytes
//! are the board layer's ([`ParamFlash`]), the record and the erase's watchdog window are
//! kept here.

use crate::device::hardware::{ParamStore, Watchdog};
use crate::wire::protocol::NotStored;
use crate::wire::stored::{self, Stored, STORED_LEN};

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
    fn load(&mut self) -> Result<Stored, NotStored> {
        stored::decode(&self.0.read())
    }

    fn save(&mut self, contents: &Stored, watchdog: &mut dyn Watchdog) {
        let bytes = stored::encode(contents);
        watchdog.stall(F::ERASE_MAX_MS, &mut || self.0.erase());
        self.0.program(&bytes);
        if self.0.read() != bytes {
            #[cfg(feature = "defmt")]
            defmt::error!("parameter sector did not read back what was written");
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::limits::Limits;
    use crate::wire::protocol::{Estimate, MotorReport};
    use core::cell::Cell;
    use std::rc::Rc;
    use std::vec::Vec;

    /// The window of the watchdog stall under way, `None` outside any: shared by the
    /// watchdog, which sets it, and the sector, which reads it at each erase.
    type StallOn = Rc<Cell<Option<u32>>>;

    /// A sector that records the stall each erase ran within.
    struct Sector {
        bytes: Option<[u8; STORED_LEN]>,
        stall: StallOn,
        erases: Vec<Option<u32>>,
    }

    impl ParamFlash for Sector {
        const ERASE_MAX_MS: u32 = 4_000;
        fn read(&mut self) -> [u8; STORED_LEN] {
            self.bytes.unwrap_or([0xFF; STORED_LEN])
        }
        fn erase(&mut self) {
            self.erases.push(self.stall.get());
            self.bytes = None;
        }
        fn program(&mut self, bytes: &[u8; STORED_LEN]) {
            self.bytes = Some(*bytes);
        }
    }

    /// A watchdog that marks its stalls.
    struct Dog(StallOn);

    impl Watchdog for Dog {
        fn feed(&mut self) {}
        fn stall(&mut self, up_to_ms: u32, op: &mut dyn FnMut()) {
            self.0.set(Some(up_to_ms));
            op();
            self.0.set(None);
        }
    }

    #[test]
    fn the_sector_is_erased_within_a_stall_of_its_longest_erase_and_reads_back() {
        let stall = StallOn::default();
        let mut store = FlashStore(Sector {
            bytes: None,
            stall: stall.clone(),
            erases: Vec::new(),
        });
        let mut dog = Dog(stall);
        let report = MotorReport {
            estimates: heapless::Vec::from_slice(&[Estimate {
                param: 0,
                value: 3.4,
                std: 0.01,
            }])
            .unwrap(),
            rmse_omega: 0.5,
            evaluations: 24,
            rank: 1,
        };
        let with_report = Stored {
            limits: Limits::DEFAULT,
            report: Some(report),
        };
        store.save(&with_report, &mut dog);
        assert_eq!(store.load(), Ok(with_report));
        let cleared = Stored {
            limits: Limits::DEFAULT,
            report: None,
        };
        store.save(&cleared, &mut dog);
        assert_eq!(store.load(), Ok(cleared));
        assert_eq!(store.0.erases, [Some(4_000), Some(4_000)]);
    }
}
