//! What the board keeps in non-volatile memory (a flash sector on the board, RAM in the QEMU
//! build): the commissioning limits the host set and the identified motor, in one record: a
//! magic word, a layout version, the postcard-encoded [`Stored`] and a CRC-32 over all of it.
//! Erased flash (all `0xFF`), a record of another layout version or a torn write reads back
//! as [`NotStored`] with its reason, never as wrong parameters or limits. The byte layout is
//! in `docs/CONTRACTS.md`.

use crate::capacity::MAX_ESTIMATES;
use crate::wire::limits::Limits;
use crate::wire::protocol::{MotorReport, NotStored};
use serde::{Deserialize, Serialize};

/// First word of a stored record ("MIDP" little-endian).
pub const MAGIC: u32 = u32::from_le_bytes(*b"MIDP");

/// Layout version of the stored record; bumped whenever [`Stored`] changes shape
/// (3: every parameter an estimate with its wire code; 4: the limits beside the report).
pub const STORE_VERSION: u16 = 4;

/// The contents of the parameter store: the limits commissioning works within and the motor
/// it identified, if any. One record, so that an erase of the sector never loses one of
/// them while the other is written.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Stored {
    /// Limits of commissioning (set by the host, [`Limits::DEFAULT`] until then).
    pub limits: Limits,
    /// The identified motor (`None`: not commissioned, or erased by the host).
    pub report: Option<MotorReport>,
}

impl Stored {
    /// The stored report, or why there is none (`Empty` when erased by the host).
    pub fn report(stored: Result<Stored, NotStored>) -> Result<MotorReport, NotStored> {
        stored.and_then(|s| s.report.ok_or(NotStored::Empty))
    }

    /// The stored limits, or the defaults when nothing this firmware reads is stored.
    pub fn limits(stored: &Result<Stored, NotStored>) -> Limits {
        stored.as_ref().map_or(Limits::DEFAULT, |s| s.limits)
    }
}

const HEADER: usize = 8;
const CRC_LEN: usize = 4;
/// Largest postcard encoding of a [`Stored`]: the limits (four `f32`, 16 bytes), the report's
/// option tag (one byte), the estimates' count (one byte), each estimate (code 1 + value 4 +
/// std 4 bytes), the RMSE (4), the evaluations (a varint of at most 5) and the rank (1).
const MAX_PAYLOAD: usize = 16 + 1 + 1 + 9 * MAX_ESTIMATES + 4 + 5 + 1;

/// Bytes a stored record occupies at most (header, payload, CRC), a multiple of 4 so that the
/// board programs it word by word.
pub const STORED_LEN: usize = (HEADER + MAX_PAYLOAD + CRC_LEN).div_ceil(4) * 4;

const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Encode `stored` as a stored record; bytes past its end are `0xFF` (erased flash).
pub fn encode(stored: &Stored) -> [u8; STORED_LEN] {
    let mut out = [0xFFu8; STORED_LEN];
    let used = postcard::to_slice(stored, &mut out[HEADER..HEADER + MAX_PAYLOAD])
        .map(|s| s.len())
        // At most MAX_PAYLOAD bytes (see there): it always fits.
        .unwrap_or(0);
    out[..4].copy_from_slice(&MAGIC.to_le_bytes());
    out[4..6].copy_from_slice(&STORE_VERSION.to_le_bytes());
    out[6..8].copy_from_slice(&(used as u16).to_le_bytes());
    let crc = CRC.checksum(&out[..HEADER + used]);
    out[HEADER + used..HEADER + used + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
    out
}

/// The contents of a stored record, or why there are none this layout version reads: erased
/// (or no magic word), another layout version, or torn or corrupted.
pub fn decode(bytes: &[u8]) -> Result<Stored, NotStored> {
    if bytes.len() < HEADER + CRC_LEN {
        return Err(NotStored::Empty);
    }
    let word =
        |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let half = |at: usize| u16::from_le_bytes([bytes[at], bytes[at + 1]]);
    if word(0) != MAGIC {
        return Err(NotStored::Empty);
    }
    let used = half(6) as usize;
    if HEADER + used + CRC_LEN > bytes.len()
        || CRC.checksum(&bytes[..HEADER + used]) != word(HEADER + used)
    {
        return Err(NotStored::Corrupt);
    }
    if half(4) != STORE_VERSION {
        return Err(NotStored::OtherLayout { found: half(4) });
    }
    postcard::from_bytes(&bytes[HEADER..HEADER + used]).map_err(|_| NotStored::Corrupt)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::protocol::Estimate;

    fn report(estimates: usize) -> MotorReport {
        let values = [3.412, 0.0573, 0.0424, 0.00267, 0.1604, 0.05];
        let std = [0.01, 1e-4, f32::NAN, 2e-5, 3e-4, f32::NAN];
        MotorReport {
            estimates: (0..estimates)
                .map(|k| Estimate {
                    param: k as u8,
                    value: values[k % 6] * (1 + k / 6) as f32,
                    std: std[k % 6],
                })
                .collect(),
            rmse_omega: 0.51,
            evaluations: u32::MAX,
            rank: 5,
        }
    }

    const LIMITS: Limits = Limits {
        voltage: 24.0,
        current: 10.0,
        speed: 300.0,
        budget: 30.0,
    };

    fn stored(estimates: usize) -> Stored {
        Stored {
            limits: LIMITS,
            report: Some(report(estimates)),
        }
    }

    fn bits(r: &MotorReport) -> std::vec::Vec<u32> {
        let mut out: std::vec::Vec<u32> = r
            .estimates
            .iter()
            .flat_map(|e| [e.param as u32, e.value.to_bits(), e.std.to_bits()])
            .collect();
        out.extend([r.rmse_omega.to_bits(), r.evaluations, r.rank as u32]);
        out
    }

    /// `bytes` with its version field set to `version` and the CRC made valid again.
    fn relabelled(mut bytes: [u8; STORED_LEN], version: u16) -> [u8; STORED_LEN] {
        bytes[4..6].copy_from_slice(&version.to_le_bytes());
        let used = HEADER + u16::from_le_bytes([bytes[6], bytes[7]]) as usize;
        let crc = CRC.checksum(&bytes[..used]);
        bytes[used..used + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
        bytes
    }

    #[test]
    fn round_trip_is_exact_up_to_a_full_report() {
        for n in [5, 6, MAX_ESTIMATES] {
            let r = report(n);
            let back = decode(&encode(&stored(n))).expect("valid record");
            assert_eq!(back.limits, LIMITS);
            assert_eq!(bits(&back.report.unwrap()), bits(&r), "{n} estimates");
        }
    }

    #[test]
    fn limits_without_a_report_read_back_and_the_report_says_why_it_is_missing() {
        let only_limits = Stored {
            limits: LIMITS,
            report: None,
        };
        let back = decode(&encode(&only_limits));
        assert_eq!(back, Ok(only_limits));
        assert_eq!(Stored::limits(&back), LIMITS);
        assert_eq!(Stored::report(back), Err(NotStored::Empty));
        // Nothing stored: the defaults.
        let erased = decode(&[0xFF; STORED_LEN]);
        assert_eq!(Stored::limits(&erased), Limits::DEFAULT);
    }

    #[test]
    fn erased_flash_holds_nothing() {
        assert_eq!(decode(&[0xFF; STORED_LEN]), Err(NotStored::Empty));
        assert_eq!(decode(&[0x00; STORED_LEN]), Err(NotStored::Empty));
        assert_eq!(decode(&[]), Err(NotStored::Empty));
    }

    #[test]
    fn every_flipped_bit_is_caught() {
        let good = encode(&stored(6));
        let used = HEADER + u16::from_le_bytes([good[6], good[7]]) as usize + CRC_LEN;
        for byte in 0..used {
            for bit in 0..8 {
                let mut bad = good;
                bad[byte] ^= 1 << bit;
                assert!(
                    decode(&bad).is_err(),
                    "flip of bit {bit} in byte {byte} accepted"
                );
            }
        }
    }

    #[test]
    fn another_layout_version_is_named_and_not_read() {
        let good = encode(&stored(6));
        for version in [STORE_VERSION - 1, STORE_VERSION + 1] {
            assert_eq!(
                decode(&relabelled(good, version)),
                Err(NotStored::OtherLayout { found: version })
            );
        }
    }

    #[test]
    fn a_torn_write_is_not_read() {
        let good = encode(&stored(6));
        let used = HEADER + u16::from_le_bytes([good[6], good[7]]) as usize + CRC_LEN;
        for cut in 0..used {
            let mut torn = [0xFF; STORED_LEN];
            torn[..cut].copy_from_slice(&good[..cut]);
            assert!(decode(&torn).is_err(), "write torn at {cut} accepted");
        }
    }
}
