//! USART1 of the STM32F4 (0x4001_1000), polled. In QEMU (netduinoplus2) it needs no clock
//! or pin set-up; on a board the clock, GPIO alternate function and baud rate come first.

use crate::link::ByteSerial;
use core::ptr::{read_volatile, write_volatile};

const BASE: usize = 0x4001_1000;
const SR: *mut u32 = BASE as *mut u32;
const DR: *mut u32 = (BASE + 0x04) as *mut u32;
const CR1: *mut u32 = (BASE + 0x0C) as *mut u32;
const SR_RXNE: u32 = 1 << 5;
const SR_TXE: u32 = 1 << 7;
const CR1_UE: u32 = 1 << 13;
const CR1_TE: u32 = 1 << 3;
const CR1_RE: u32 = 1 << 2;

/// The polled USART1.
pub struct Usart1(());

impl Usart1 {
    /// Enable transmitter and receiver.
    pub fn new() -> Self {
        // SAFETY: USART1's registers are owned by this one instance (created once in main).
        unsafe { write_volatile(CR1, CR1_UE | CR1_TE | CR1_RE) };
        Usart1(())
    }
}

impl ByteSerial for Usart1 {
    fn write(&mut self, byte: u8) {
        // SAFETY: see `new`.
        unsafe {
            while read_volatile(SR) & SR_TXE == 0 {}
            write_volatile(DR, byte as u32);
        }
    }

    fn read(&mut self) -> Option<u8> {
        // SAFETY: see `new`.
        unsafe { (read_volatile(SR) & SR_RXNE != 0).then(|| read_volatile(DR) as u8) }
    }
}
