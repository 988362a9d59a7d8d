//! The host link over USART1: frames of [`motor_id_shared::frame`].

use crate::usart::Usart1;
use motor_id_shared::frame::{encode, Decoder, MAX_FRAME};
use motor_id_shared::protocol::{BoardMessage, HostMessage};
use motor_id_shared::service::Link;

/// Framed messages over the USART.
pub struct SerialLink {
    usart: Usart1,
    decoder: Decoder,
}

impl SerialLink {
    /// Link over `usart`.
    pub fn new(usart: Usart1) -> Self {
        SerialLink {
            usart,
            decoder: Decoder::new(),
        }
    }
}

impl Link for SerialLink {
    fn send(&mut self, msg: &BoardMessage) {
        let mut out = [0u8; MAX_FRAME];
        if let Ok(frame) = encode(msg, &mut out) {
            for b in frame {
                self.usart.write(*b);
            }
        }
    }

    fn poll(&mut self) -> Option<HostMessage> {
        while let Some(b) = self.usart.read() {
            // Corrupted frames are dropped: the host times out and repeats its request.
            if let Some(Ok(msg)) = self.decoder.push(b) {
                return Some(msg);
            }
        }
        None
    }
}
