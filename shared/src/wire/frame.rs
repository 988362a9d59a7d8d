//! Framing of [`crate::wire::protocol`] messages on a byte stream: postcard payload, CRC-32
//! (ISO-HDLC) appended, COBS-encoded, terminated by a zero byte. The decoder resynchronises
//! at every zero byte, so garbage, a dropped byte or a corrupted frame costs that frame only;
//! bad CRCs and oversize frames are reported, never a panic.

use serde::{de::DeserializeOwned, Serialize};

/// Largest encoded frame (delimiter included) either end sends or accepts.
pub const MAX_FRAME: usize = 256;

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);
/// Payload room before COBS overhead (one byte per 254, plus the delimiter).
const MAX_PAYLOAD: usize = MAX_FRAME - MAX_FRAME / 254 - 2;

/// Why a frame was not delivered.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The message does not fit in [`MAX_FRAME`].
    TooLarge,
    /// More than [`MAX_FRAME`] bytes without a delimiter; they were dropped.
    Oversize,
    /// Not valid COBS.
    Cobs,
    /// CRC mismatch (or too short to hold one).
    Crc,
    /// Valid frame, but not a message of the expected type.
    Decode,
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            FrameError::TooLarge => "message too large for a frame",
            FrameError::Oversize => "frame longer than the limit: dropped",
            FrameError::Cobs => "corrupted frame (COBS)",
            FrameError::Crc => "corrupted frame (CRC)",
            FrameError::Decode => "unknown message",
        })
    }
}

/// Encode `msg` into `out`; returns the frame (delimiter included).
pub fn encode<'o, T: Serialize>(
    msg: &T,
    out: &'o mut [u8; MAX_FRAME],
) -> Result<&'o [u8], FrameError> {
    let mut payload = [0u8; MAX_PAYLOAD];
    let used = postcard::to_slice_crc32(msg, &mut payload, CRC.digest())
        .map_err(|_| FrameError::TooLarge)?
        .len();
    let n = cobs::try_encode(&payload[..used], &mut out[..MAX_FRAME - 1])
        .map_err(|_| FrameError::TooLarge)?;
    out[n] = 0;
    Ok(&out[..n + 1])
}

/// Accumulates bytes and yields decoded messages, in fixed memory.
#[derive(Debug)]
pub struct Decoder {
    buf: [u8; MAX_FRAME],
    len: usize,
    overflow: bool,
}

impl Default for Decoder {
    fn default() -> Self {
        Decoder {
            buf: [0; MAX_FRAME],
            len: 0,
            overflow: false,
        }
    }
}

impl Decoder {
    /// A decoder with nothing buffered.
    pub fn new() -> Self {
        Self::default()
    }

    /// Feed one byte: `None` while a frame is incomplete (or on an empty frame), then the
    /// decoded message or why the frame was dropped.
    pub fn push<T: DeserializeOwned>(&mut self, byte: u8) -> Option<Result<T, FrameError>> {
        if byte != 0 {
            if self.len < MAX_FRAME {
                self.buf[self.len] = byte;
                self.len += 1;
            } else {
                self.overflow = true;
            }
            return None;
        }
        let (len, overflow) = (self.len, self.overflow);
        self.len = 0;
        self.overflow = false;
        if overflow {
            return Some(Err(FrameError::Oversize));
        }
        if len == 0 {
            return None;
        }
        let decoded = match cobs::decode_in_place(&mut self.buf[..len]) {
            Ok(n) => n,
            Err(_) => return Some(Err(FrameError::Cobs)),
        };
        if decoded < 4 {
            return Some(Err(FrameError::Crc));
        }
        let (body, tail) = self.buf[..decoded].split_at(decoded - 4);
        let expected = u32::from_le_bytes([tail[0], tail[1], tail[2], tail[3]]);
        if CRC.checksum(body) != expected {
            return Some(Err(FrameError::Crc));
        }
        // The whole body is the message: bytes left after it mean another message shape
        // (another protocol version), not a message to act on. A varint spelled longer than
        // needed is read as its value, as postcard reads it (docs/CONTRACTS.md).
        Some(match postcard::take_from_bytes(body) {
            Ok((msg, [])) => Ok(msg),
            _ => Err(FrameError::Decode),
        })
    }
}

#[cfg(test)]
#[path = "frame_fuzz.rs"]
mod fuzz;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::limits::Limits;
    use crate::wire::protocol::*;
    use proptest::prelude::*;
    use std::vec::Vec;

    pub(super) fn every_message() -> Vec<HostMessage> {
        let chunk = |x: f32| heapless::Vec::<f32, CHUNK>::from_slice(&[x; CHUNK]).unwrap();
        vec![
            HostMessage::Hello {
                version: PROTOCOL_VERSION,
            },
            HostMessage::IdentifyBegin {
                dt: 1e-3,
                samples: 2000,
                with_current: true,
                coast_from: None,
            },
            HostMessage::Identify {
                seed: 7,
                pipeline: PipelineName::Board,
            },
            HostMessage::RecordChunk {
                offset: 16,
                v: chunk(24.0),
                omega: chunk(-1.5),
                current: chunk(0.25),
            },
            HostMessage::RecordChunk {
                offset: 0,
                v: chunk(0.0),
                omega: chunk(0.0),
                current: heapless::Vec::new(),
            },
            HostMessage::Commission { seed: u64::MAX },
            HostMessage::ReadParams,
            HostMessage::ClearParams,
            HostMessage::Abort,
            HostMessage::Configure(LIMITS),
            HostMessage::ReadLimits,
            HostMessage::ReadRecord {
                record: 1,
                offset: 1992,
            },
            HostMessage::IdentifyBegin {
                dt: 1e-3,
                samples: 2000,
                with_current: true,
                coast_from: Some(1500),
            },
        ]
    }

    /// Limits other than the defaults.
    const LIMITS: Limits = Limits {
        voltage: 24.0,
        current: 10.0,
        speed: 300.0,
        budget: 30.0,
    };

    pub(super) fn every_reply() -> Vec<BoardMessage> {
        let values = [3.4, 0.057, 0.042, 0.0027, 0.16, 0.05];
        let std = [0.01, f32::NAN, 1e-4, 1e-5, 1e-3, 2e-3];
        let report = |n: usize| MotorReport {
            estimates: (0..n)
                .map(|k| Estimate {
                    param: k as u8,
                    value: values[k],
                    std: std[k],
                })
                .collect(),
            rmse_omega: 0.5,
            evaluations: 60,
            rank: 4,
        };
        vec![
            BoardMessage::Hello {
                version: PROTOCOL_VERSION,
                max_samples: 2000,
            },
            BoardMessage::Refused(Refusal::VersionMismatch { board: 1 }),
            BoardMessage::Refused(Refusal::RecordTooLong { max: 2000 }),
            BoardMessage::ChunkOk { next: 32 },
            BoardMessage::Progress {
                stage: JobStage::Refine,
                iteration: 3,
                total: 100,
                evaluations: 40,
                best: 0.51,
            },
            BoardMessage::Progress {
                stage: JobStage::Check,
                iteration: 7,
                total: 480,
                evaluations: 300,
                best: 0.49,
            },
            BoardMessage::Identified(report(6)),
            BoardMessage::Params(Ok(report(6))),
            BoardMessage::Params(Err(NotStored::Empty)),
            BoardMessage::Params(Err(NotStored::OtherLayout { found: 2 })),
            BoardMessage::Params(Err(NotStored::Corrupt)),
            BoardMessage::Identified(report(5)),
            BoardMessage::Cleared,
            BoardMessage::Aborted,
            BoardMessage::Limits(LIMITS),
            BoardMessage::RecordData(RecordPart {
                record: 0,
                records: 2,
                dt: 5e-3,
                samples: 1800,
                coast_from: Some(1350),
                averaged: 9,
                offset: 1792,
                v: heapless::Vec::from_slice(&[12.0; READ_CHUNK]).unwrap(),
                omega: heapless::Vec::from_slice(&[-300.5; READ_CHUNK]).unwrap(),
                current: heapless::Vec::from_slice(&[39.9; READ_CHUNK]).unwrap(),
            }),
            BoardMessage::Refused(Refusal::NoRecord),
        ]
    }

    fn roundtrip<T: Serialize + DeserializeOwned>(msg: &T) -> T {
        let mut out = [0u8; MAX_FRAME];
        let frame = encode(msg, &mut out).unwrap().to_vec();
        assert_eq!(
            frame.iter().filter(|b| **b == 0).count(),
            1,
            "one delimiter"
        );
        let mut d = Decoder::new();
        let mut got = None;
        for (k, b) in frame.iter().enumerate() {
            let r = d.push::<T>(*b);
            if k + 1 < frame.len() {
                assert!(r.is_none());
            } else {
                got = r;
            }
        }
        got.unwrap().unwrap()
    }

    #[test]
    fn every_message_round_trips() {
        for m in every_message() {
            assert_eq!(roundtrip(&m), m);
        }
        for m in every_reply() {
            // NaN != NaN: compare the encodings instead.
            let back = roundtrip(&m);
            let (mut a, mut b) = ([0u8; MAX_FRAME], [0u8; MAX_FRAME]);
            assert_eq!(encode(&back, &mut a).unwrap(), encode(&m, &mut b).unwrap());
        }
    }

    #[test]
    fn garbage_corruption_and_oversize_are_survived() {
        let msg = HostMessage::IdentifyBegin {
            dt: 1e-3,
            samples: 2000,
            with_current: false,
            coast_from: None,
        };
        let mut out = [0u8; MAX_FRAME];
        let frame = encode(&msg, &mut out).unwrap().to_vec();
        let mut d = Decoder::new();
        let mut results = Vec::new();
        let mut feed = |bytes: &[u8], d: &mut Decoder| {
            for b in bytes {
                if let Some(r) = d.push::<HostMessage>(*b) {
                    results.push(r);
                }
            }
        };
        // Garbage without a delimiter, then a good frame: garbage joins the frame and spoils it.
        feed(&[1, 2, 3], &mut d);
        feed(&frame, &mut d);
        // A corrupted frame.
        let mut bad = frame.clone();
        bad[3] ^= 0x40;
        feed(&bad, &mut d);
        // A frame with one byte dropped.
        let mut short = frame.clone();
        short.remove(2);
        feed(&short, &mut d);
        // An oversize run, then a good frame.
        feed(&[7u8; MAX_FRAME + 10], &mut d);
        feed(&[0], &mut d);
        feed(&frame, &mut d);
        assert_eq!(results.len(), 5, "{results:?}");
        assert!(results[0].is_err());
        assert!(results[1].is_err());
        assert!(results[2].is_err());
        assert_eq!(results[3], Err(FrameError::Oversize));
        assert_eq!(results[4], Ok(msg));
    }

    proptest! {
        /// Arbitrary bytes never panic the decoder, and a good frame after them is received.
        #[test]
        fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
            let mut d = Decoder::new();
            for b in &bytes {
                let _ = d.push::<BoardMessage>(*b);
            }
            let msg = BoardMessage::ChunkOk { next: 5 };
            let mut out = [0u8; MAX_FRAME];
            let frame = encode(&msg, &mut out).unwrap().to_vec();
            let mut last = None;
            for b in [0u8].iter().chain(frame.iter()) {
                if let Some(r) = d.push::<BoardMessage>(*b) {
                    last = Some(r);
                }
            }
            prop_assert_eq!(last, Some(Ok(msg)));
        }
    }

    #[test]
    fn a_message_with_bytes_after_it_is_not_taken() {
        // A valid frame whose body is a message and one byte more (as a message of another
        // shape, from another protocol version, may be read).
        let mut out = [0u8; MAX_FRAME];
        let frame = encode(&(HostMessage::ReadParams, 7u8), &mut out)
            .unwrap()
            .to_vec();
        let mut d = Decoder::new();
        let got: Vec<_> = frame
            .iter()
            .filter_map(|b| d.push::<HostMessage>(*b))
            .collect();
        assert_eq!(got, vec![Err(FrameError::Decode)]);
        // Without the extra byte it is taken.
        let frame = encode(&HostMessage::ReadParams, &mut out).unwrap().to_vec();
        let got: Vec<_> = frame
            .iter()
            .filter_map(|b| d.push::<HostMessage>(*b))
            .collect();
        assert_eq!(got, vec![Ok(HostMessage::ReadParams)]);
    }
}
