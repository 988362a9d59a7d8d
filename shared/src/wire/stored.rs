//! The identified motor as the board keeps it in non-volatile memory (a flash sector on the
//! board, RAM in the QEMU build): a magic word, a layout version, the postcard-encoded
//! [`MotorReport`] and a CRC-32 over all of it. Erased flash (all `0xFF`), a record of another
//! layout version or a torn write reads back as "nothing stored", never as wrong parameters.

use crate::wire::protocol::MotorReport;

/// First word of a stored record ("MIDP" little-endian).
pub const MAGIC: u32 = u32::from_le_bytes(*b"MIDP");

/// Layout version of the stored record; bumped whenever [`MotorReport`] changes shape.
pub const STORE_VERSION: u16 = 2;

/// Bytes a stored record occupies at most (header, payload, CRC), a multiple of 4 so that the
/// board programs it word by word.
pub const STORED_LEN: usize = 96;

const HEADER: usize = 8;
const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// Encode `report` as a stored record; bytes past its end are `0xFF` (erased flash).
pub fn encode(report: &MotorReport) -> [u8; STORED_LEN] {
    let mut out = [0xFFu8; STORED_LEN];
    let payload_room = STORED_LEN - HEADER - 4;
    let used = postcard::to_slice(report, &mut out[HEADER..HEADER + payload_room])
        .map(|s| s.len())
        // A MotorReport is at most 5*4*2 + 9 + 4 + 5 + 1 bytes: it always fits.
        .unwrap_or(0);
    out[..4].copy_from_slice(&MAGIC.to_le_bytes());
    out[4..6].copy_from_slice(&STORE_VERSION.to_le_bytes());
    out[6..8].copy_from_slice(&(used as u16).to_le_bytes());
    let crc = CRC.checksum(&out[..HEADER + used]);
    out[HEADER + used..HEADER + used + 4].copy_from_slice(&crc.to_le_bytes());
    out
}

/// The report in a stored record, or `None` when the bytes hold no valid record of this
/// layout version (erased, torn, corrupted or older).
pub fn decode(bytes: &[u8]) -> Option<MotorReport> {
    if bytes.len() < HEADER + 4 {
        return None;
    }
    let word =
        |at: usize| u32::from_le_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
    let half = |at: usize| u16::from_le_bytes([bytes[at], bytes[at + 1]]);
    if word(0) != MAGIC || half(4) != STORE_VERSION {
        return None;
    }
    let used = half(6) as usize;
    if HEADER + used + 4 > bytes.len() {
        return None;
    }
    if CRC.checksum(&bytes[..HEADER + used]) != word(HEADER + used) {
        return None;
    }
    postcard::from_bytes(&bytes[HEADER..HEADER + used]).ok()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::wire::protocol::Estimate;

    fn report() -> MotorReport {
        MotorReport {
            params: [3.412, 0.0573, 0.0424, 0.00267, 0.1604],
            std: [0.01, 1e-4, f32::NAN, 2e-5, 3e-4],
            friction: Some(Estimate {
                value: 0.05,
                std: f32::NAN,
            }),
            rmse_omega: 0.51,
            evaluations: 64,
            rank: 5,
        }
    }

    fn same(a: &MotorReport, b: &MotorReport) -> bool {
        let bits = |x: &[f32; 5]| x.map(f32::to_bits);
        bits(&a.params) == bits(&b.params)
            && bits(&a.std) == bits(&b.std)
            && a.friction.map(|f| [f.value.to_bits(), f.std.to_bits()])
                == b.friction.map(|f| [f.value.to_bits(), f.std.to_bits()])
            && a.rmse_omega.to_bits() == b.rmse_omega.to_bits()
            && a.evaluations == b.evaluations
            && a.rank == b.rank
    }

    #[test]
    fn round_trip_is_exact() {
        let without_friction = MotorReport {
            friction: None,
            ..report()
        };
        for r in [report(), without_friction] {
            let bytes = encode(&r);
            assert!(same(&decode(&bytes).expect("valid record"), &r));
        }
    }

    #[test]
    fn erased_flash_holds_nothing() {
        assert_eq!(decode(&[0xFF; STORED_LEN]), None);
        assert_eq!(decode(&[0x00; STORED_LEN]), None);
        assert_eq!(decode(&[]), None);
    }

    #[test]
    fn every_flipped_bit_is_caught() {
        let good = encode(&report());
        let used = HEADER + u16::from_le_bytes([good[6], good[7]]) as usize + 4;
        for byte in 0..used {
            for bit in 0..8 {
                let mut bad = good;
                bad[byte] ^= 1 << bit;
                assert_eq!(
                    decode(&bad),
                    None,
                    "flip of bit {bit} in byte {byte} accepted"
                );
            }
        }
    }

    #[test]
    fn another_layout_version_is_not_read() {
        let mut bytes = encode(&report());
        bytes[4..6].copy_from_slice(&(STORE_VERSION + 1).to_le_bytes());
        assert_eq!(decode(&bytes), None);
    }

    #[test]
    fn a_torn_write_is_not_read() {
        let good = encode(&report());
        let used = HEADER + u16::from_le_bytes([good[6], good[7]]) as usize + 4;
        for cut in 0..used {
            let mut torn = [0xFF; STORED_LEN];
            torn[..cut].copy_from_slice(&good[..cut]);
            assert_eq!(decode(&torn), None, "write torn at {cut} accepted");
        }
    }
}
