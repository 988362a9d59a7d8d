//! The bytes of the messages that `docs/CONTRACTS.md` gives, protocol by protocol: what a
//! host or a board of another build must read and write (postcard: the variant's index as a
//! varint, then each field, f32 little-endian, integers as varints, an option as a 0/1 tag
//! before its value).

use super::*;
use crate::wire::limits::Limits;
use std::vec;

/// The limits of the contract's example (24 V, 10 A, 300 rad/s, 30 s).
const LIMITS: Limits = Limits {
    voltage: 24.0,
    current: 10.0,
    speed: 300.0,
    budget: 30.0,
};

#[test]
fn the_messages_of_protocols_9_to_12_have_the_bytes_docs_contracts_gives() {
    let mut out = [0u8; 64];
    let bytes = |m: &HostMessage, out: &mut [u8; 64]| postcard::to_slice(m, out).unwrap().to_vec();
    let limits = [
        0x00, 0x00, 0xC0, 0x41, 0x00, 0x00, 0x20, 0x41, 0x00, 0x00, 0x96, 0x43, 0x00, 0x00, 0xF0,
        0x41,
    ];
    let mut configure = vec![8];
    configure.extend(limits);
    assert_eq!(bytes(&HostMessage::Configure(LIMITS), &mut out), configure);
    assert_eq!(bytes(&HostMessage::ReadLimits, &mut out), [9]);
    let read = HostMessage::ReadRecord {
        record: 1,
        offset: 300,
    };
    assert_eq!(bytes(&read, &mut out), [10, 1, 0xAC, 0x02]);
    let begin = HostMessage::IdentifyBegin {
        dt: 1.0,
        samples: 5,
        with_current: true,
        coast_from: Some(3),
    };
    assert_eq!(
        bytes(&begin, &mut out),
        [1, 0x00, 0x00, 0x80, 0x3F, 5, 1, 1, 3]
    );
    let reply = postcard::to_slice(&BoardMessage::Limits(LIMITS), &mut out)
        .unwrap()
        .to_vec();
    let mut want = vec![9];
    want.extend(limits);
    assert_eq!(reply, want);
    // Protocol 10: refusal 14, `NoBackEmf`; the hello carries version 10.
    let refused = postcard::to_slice(&BoardMessage::Refused(Refusal::NoBackEmf), &mut out)
        .unwrap()
        .to_vec();
    assert_eq!(refused, [1, 14]);
    // Protocol 11: the plan's `back_emf_current` after `tau_m`; the hello carries 11.
    let plan = Plan {
        current_offset: 0.0,
        breakaway_volts: 0.0,
        ra: 0.0,
        tau_e: 0.0,
        kv: 0.0,
        tau_m: 0.0,
        back_emf_current: 2.0,
        volts: 0.0,
        fast_dt: 0.0,
        fast_samples: 1,
        slow_dt: 0.0,
        slow_samples: 2,
        probe_seconds: 0.0,
        planned_seconds: 0.0,
    };
    let planned = postcard::to_slice(&BoardMessage::Planned(plan), &mut out)
        .unwrap()
        .to_vec();
    let mut want = vec![8];
    want.extend([0u8; 24]);
    want.extend([0x00, 0x00, 0x00, 0x40]);
    want.extend([0u8; 8]);
    want.push(1);
    want.extend([0u8; 4]);
    want.push(2);
    want.extend([0u8; 8]);
    assert_eq!(planned, want);
    // Protocol 12: a record part's `averaged` after `coast_from`; the hello carries 12.
    let part = RecordPart {
        record: 1,
        records: 2,
        dt: 1.0,
        samples: 3,
        coast_from: None,
        averaged: 300,
        offset: 2,
        v: heapless::Vec::from_slice(&[1.0]).unwrap(),
        omega: heapless::Vec::from_slice(&[1.0]).unwrap(),
        current: heapless::Vec::new(),
    };
    let data = postcard::to_slice(&BoardMessage::RecordData(part), &mut out)
        .unwrap()
        .to_vec();
    let mut want = vec![10, 1, 2, 0x00, 0x00, 0x80, 0x3F, 3, 0, 0xAC, 0x02, 2];
    want.extend([1, 0x00, 0x00, 0x80, 0x3F, 1, 0x00, 0x00, 0x80, 0x3F, 0]);
    assert_eq!(data, want);
    assert_eq!(
        bytes(
            &HostMessage::Hello {
                version: PROTOCOL_VERSION
            },
            &mut out
        ),
        [0, 12]
    );
}
