//! The host link: frames of `motor_id_shared::wire::frame` over any byte-wise serial port.

use motor_id_shared::device::hardware::Link;
use motor_id_shared::wire::frame::{encode, Decoder, MAX_FRAME};
use motor_id_shared::wire::protocol::{BoardMessage, HostMessage};

/// A serial port, byte by byte.
pub trait ByteSerial {
    /// Send one byte, waiting for room.
    fn write(&mut self, byte: u8);
    /// A received byte, if any (never blocks).
    fn read(&mut self) -> Option<u8>;
}

/// Framed messages over a serial port.
pub struct SerialLink<S> {
    serial: S,
    decoder: Decoder,
}

impl<S: ByteSerial> SerialLink<S> {
    /// Link over `serial`.
    pub fn new(serial: S) -> Self {
        SerialLink {
            serial,
            decoder: Decoder::new(),
        }
    }
}

impl<S: ByteSerial> Link for SerialLink<S> {
    fn send(&mut self, msg: &BoardMessage) {
        let mut out = [0u8; MAX_FRAME];
        match encode(msg, &mut out) {
            Ok(frame) => frame.iter().for_each(|b| self.serial.write(*b)),
            Err(e) => defmt::error!("reply not sent: {}", e),
        }
    }

    fn poll(&mut self) -> Option<HostMessage> {
        while let Some(b) = self.serial.read() {
            match self.decoder.push(b) {
                Some(Ok(msg)) => return Some(msg),
                // Corrupted frames are dropped: the host times out and repeats its request.
                Some(Err(e)) => defmt::debug!("frame dropped: {}", e),
                None => {}
            }
        }
        None
    }
}
