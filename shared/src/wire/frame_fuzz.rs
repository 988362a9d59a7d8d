//! Fuzz target `frame` (the harness is described in the `motor-id-fuzz` crate, the seeds are
//! in `fuzz/corpus/frame/`): the [`Decoder`] of both ends, the board's (host requests) and
//! the host's (board replies). It checks that
//!
//! - on any byte stream it never panics, yields nothing but at a delimiter, drops exactly
//!   the runs longer than [`MAX_FRAME`], decodes each frame as a fresh decoder would (what
//!   came before does not leak into it), and takes a message only from the bytes that
//!   [`encode`] makes of it or from a spelling of them with a longer varint (postcard reads
//!   one as its value), never from the message with bytes after it;
//! - on frames with a valid CRC around any body (where the message parser itself is
//!   fuzzed), the same, and the parser is all that refuses such a frame;
//! - frames interleaved with garbage (random bytes, corrupted, truncated and oversize
//!   frames) are each recovered when a delimiter precedes them, and nothing else is taken;
//! - every message encodes into one frame and decodes back to itself.

use super::tests::{every_message, every_reply};
use super::*;
use crate::wire::arbitrary::{board_message, host_message};
use crate::wire::protocol::{BoardMessage, HostMessage};
use core::fmt::Debug;
use motor_id_fuzz::{check, corpus, corpus_dir, mutated};
use proptest::collection::vec;
use proptest::prelude::*;
use proptest::sample::Index;
use std::string::String;
use std::vec::Vec;

/// Cases per property in the default run (each case is a few hundred bytes).
const CASES: u32 = 1000;

/// A board's capacity for the generated requests' counts and offsets.
const CAPACITY: u32 = 2000;

/// The frame of `msg`, delimiter included.
fn frame_of<T: Serialize>(msg: &T) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    encode(msg, &mut out)
        .expect("every message fits a frame")
        .to_vec()
}

/// The frame of an arbitrary `body`: its CRC appended, COBS, the delimiter.
fn frame_of_body(body: &[u8]) -> Vec<u8> {
    let mut payload = body.to_vec();
    payload.extend_from_slice(&CRC.checksum(body).to_le_bytes());
    let mut out = vec![0u8; payload.len() + payload.len() / 254 + 2];
    let n = cobs::encode(&payload, &mut out);
    out.truncate(n);
    out.push(0);
    out
}

/// The postcard bodies of the frames in `stream` (COBS undone, CRC removed).
fn bodies(stream: &[u8]) -> Vec<Vec<u8>> {
    stream
        .split(|b| *b == 0)
        .filter_map(|frame| {
            let mut out = vec![0u8; frame.len()];
            let n = cobs::decode(frame, &mut out).ok()?;
            out.truncate(n.checked_sub(4)?);
            Some(out)
        })
        .collect()
}

/// One decoder result with the bytes of its frame (delimiter included).
struct Decoded<T> {
    frame: Vec<u8>,
    result: Result<T, FrameError>,
}

/// Feed `bytes` to a fresh decoder and check its contract on the way: a result only at a
/// delimiter, one for every non-empty frame, `Oversize` exactly for the runs longer than
/// [`MAX_FRAME`], the same result as a fresh decoder gives for that frame alone, and a
/// message only from the bytes that encode it.
fn decode_checked<T>(bytes: &[u8]) -> Result<Vec<Decoded<T>>, TestCaseError>
where
    T: DeserializeOwned + Serialize + Debug,
{
    decode_stream(bytes, true)
}

fn decode_stream<T>(bytes: &[u8], check_fresh: bool) -> Result<Vec<Decoded<T>>, TestCaseError>
where
    T: DeserializeOwned + Serialize + Debug,
{
    let mut d = Decoder::new();
    let mut out = Vec::new();
    let mut frame = Vec::new();
    for &b in bytes {
        frame.push(b);
        let got = d.push::<T>(b);
        if b != 0 {
            prop_assert!(got.is_none(), "a result before the delimiter: {got:?}");
            continue;
        }
        let content = frame.len() - 1;
        let Some(result) = got else {
            prop_assert_eq!(content, 0, "a non-empty frame without a result");
            frame.clear();
            continue;
        };
        prop_assert!(content > 0, "a result for an empty frame: {result:?}");
        prop_assert_eq!(
            content > MAX_FRAME,
            matches!(result, Err(FrameError::Oversize)),
            "{} bytes gave {:?}",
            content,
            result
        );
        if let Ok(msg) = &result {
            let canonical = frame_of(msg);
            if canonical != frame {
                // Postcard reads a varint spelled longer than needed as its value: the only
                // other body a message is taken from. Never the message and bytes after it.
                let (body, want) = (&bodies(&frame)[0], &bodies(&canonical)[0]);
                prop_assert!(
                    body.len() > want.len() && !body.starts_with(want),
                    "taken {msg:?} from {frame:?}, which encodes as {canonical:?}"
                );
            }
        }
        if check_fresh {
            let alone = decode_stream::<T>(&frame, false)?;
            prop_assert_eq!(alone.len(), 1);
            // Debug, not ==: a NaN in a message is equal to itself here.
            prop_assert_eq!(
                format!("{:?}", alone[0].result),
                format!("{result:?}"),
                "the frame alone decodes otherwise"
            );
        }
        out.push(Decoded {
            frame: core::mem::take(&mut frame),
            result,
        });
    }
    Ok(out)
}

/// The seed corpus: frame streams of host requests (`host-*`) and board replies (`board-*`).
fn seeds() -> Vec<motor_id_fuzz::Seed> {
    corpus("frame")
}

#[test]
fn replays_the_seed_corpus() {
    for seed in seeds() {
        let results: Vec<String> = if seed.name.starts_with("host-") {
            let got = decode_checked::<HostMessage>(&seed.bytes).unwrap();
            got.iter().map(|d| format!("{:?}", d.result)).collect()
        } else {
            assert!(
                seed.name.starts_with("board-"),
                "{}: host- or board-",
                seed.name
            );
            let got = decode_checked::<BoardMessage>(&seed.bytes).unwrap();
            got.iter().map(|d| format!("{:?}", d.result)).collect()
        };
        assert!(!results.is_empty(), "{}: no frame", seed.name);
        for r in &results {
            assert!(r.starts_with("Ok("), "{}: {r}", seed.name);
        }
    }
}

#[test]
fn arbitrary_bytes_are_decoded_by_the_contract() {
    let all: Vec<Vec<u8>> = seeds().into_iter().map(|s| s.bytes).collect();
    let input = prop_oneof![vec(any::<u8>(), 0..1024), mutated(all, 8)];
    check("frame", CASES, &input, |bytes| {
        decode_checked::<HostMessage>(&bytes)?;
        decode_checked::<BoardMessage>(&bytes)?;
        Ok(())
    });
}

#[test]
fn any_body_with_a_valid_crc_is_parsed_by_the_contract() {
    let all: Vec<Vec<u8>> = seeds().iter().flat_map(|s| bodies(&s.bytes)).collect();
    let body = prop_oneof![vec(any::<u8>(), 0..300), mutated(all, 4)];
    check("frame", CASES, &body, |body| {
        let frame = frame_of_body(&body);
        for results in [
            decode_checked::<HostMessage>(&frame)?
                .into_iter()
                .map(|d| d.result.map(|_| ()))
                .collect::<Vec<_>>(),
            decode_checked::<BoardMessage>(&frame)?
                .into_iter()
                .map(|d| d.result.map(|_| ()))
                .collect(),
        ] {
            // Valid COBS and CRC: the message parser is all that can refuse it.
            prop_assert_eq!(results.len(), 1);
            let want = if frame.len() - 1 > MAX_FRAME {
                FrameError::Oversize
            } else {
                FrameError::Decode
            };
            prop_assert!(
                results[0] == Ok(()) || results[0] == Err(want),
                "{results:?}"
            );
        }
        Ok(())
    });
}

/// What goes on the wire between two frames.
#[derive(Clone, Debug)]
enum Garbage {
    /// Random bytes (a delimiter among them or not).
    Random(Vec<u8>),
    /// A frame with one byte changed (its delimiter perhaps).
    Corrupted(HostMessage, Index, u8),
    /// A frame cut short by at least one byte before its delimiter (one cut at its
    /// delimiter only is a whole frame once a later delimiter arrives: not garbage).
    Truncated(HostMessage, Index),
    /// A run of non-zero bytes longer than a frame.
    Oversize(Vec<u8>),
}

impl Garbage {
    fn bytes(&self) -> Vec<u8> {
        match self {
            Garbage::Random(b) | Garbage::Oversize(b) => b.clone(),
            Garbage::Corrupted(msg, at, mask) => {
                let mut f = frame_of(msg);
                let k = at.index(f.len());
                f[k] ^= mask;
                f
            }
            Garbage::Truncated(msg, at) => {
                let mut f = frame_of(msg);
                f.truncate(at.index(f.len() - 1));
                f
            }
        }
    }
}

fn garbage() -> impl Strategy<Value = Garbage> {
    prop_oneof![
        vec(any::<u8>(), 1..64).prop_map(Garbage::Random),
        (host_message(CAPACITY), any::<Index>(), 1..=255u8)
            .prop_map(|(m, at, mask)| Garbage::Corrupted(m, at, mask)),
        (host_message(CAPACITY), any::<Index>()).prop_map(|(m, at)| Garbage::Truncated(m, at)),
        vec(1..=255u8, MAX_FRAME + 1..2 * MAX_FRAME).prop_map(Garbage::Oversize),
    ]
}

#[test]
fn frames_among_garbage_are_recovered_after_a_delimiter() {
    let item = prop_oneof![host_message(CAPACITY).prop_map(Ok), garbage().prop_map(Err),];
    check("frame", CASES, &vec(item, 0..12), |items| {
        let mut stream: Vec<u8> = Vec::new();
        let mut expected = Vec::new();
        for item in &items {
            let bytes = match item {
                Ok(msg) => {
                    let frame = frame_of(msg);
                    if stream.last().is_none_or(|b| *b == 0) {
                        expected.push(frame.clone());
                    }
                    frame
                }
                Err(g) => g.bytes(),
            };
            stream.extend_from_slice(&bytes);
        }
        let taken: Vec<Vec<u8>> = decode_checked::<HostMessage>(&stream)?
            .into_iter()
            .filter(|d| d.result.is_ok())
            .map(|d| d.frame)
            .collect();
        prop_assert_eq!(taken, expected);
        Ok(())
    });
}

/// The case the fuzzer shrank to when `Truncated` could cut the delimiter alone: the frame
/// and a delimiter that arrives later, in another write, are one whole frame.
#[test]
fn a_frame_whose_delimiter_comes_later_is_taken() {
    let msg = HostMessage::Identify {
        seed: 0,
        pipeline: crate::wire::protocol::PipelineName::Default,
    };
    let mut stream = frame_of(&msg);
    stream.pop();
    stream.push(0);
    let mut decoder = Decoder::new();
    let taken: Vec<HostMessage> = stream
        .iter()
        .filter_map(|b| decoder.push::<HostMessage>(*b))
        .filter_map(Result::ok)
        .collect();
    assert_eq!(taken, vec![msg]);
}

#[test]
fn every_message_encodes_into_one_frame_and_back() {
    let msg = prop_oneof![
        host_message(CAPACITY).prop_map(|m| frame_of(&m)),
        board_message().prop_map(|m| frame_of(&m)),
    ];
    check("frame", CASES, &msg, |frame| {
        prop_assert!(frame.len() <= MAX_FRAME);
        prop_assert_eq!(frame.iter().filter(|b| **b == 0).count(), 1);
        // decode_checked takes a message only when it re-encodes to this frame.
        let host = decode_checked::<HostMessage>(&frame)?;
        let board = decode_checked::<BoardMessage>(&frame)?;
        prop_assert!(host[0].result.is_ok() || board[0].result.is_ok());
        Ok(())
    });
}

/// Write the seed corpus of `frame`: every request and every reply of the round-trip tests,
/// one frame per file, and a whole upload in one stream. Run by hand when the protocol
/// changes: `cargo test -p motor-id-shared --features std,full write_frame_corpus -- --ignored`.
#[test]
#[ignore = "writes fuzz/corpus/frame"]
fn write_frame_corpus() {
    let dir = corpus_dir("frame");
    std::fs::create_dir_all(&dir).unwrap();
    let name = |m: &dyn Debug| {
        let text = format!("{m:?}");
        let word: String = text.chars().take_while(|c| c.is_alphanumeric()).collect();
        word.to_lowercase()
    };
    for (k, m) in every_message().iter().enumerate() {
        std::fs::write(dir.join(format!("host-{k}-{}.bin", name(m))), frame_of(m)).unwrap();
    }
    for (k, m) in every_reply().iter().enumerate() {
        std::fs::write(dir.join(format!("board-{k}-{}.bin", name(m))), frame_of(m)).unwrap();
    }
    let stream: Vec<u8> = every_message().iter().flat_map(frame_of).collect();
    std::fs::write(dir.join("host-all.bin"), stream).unwrap();
}

#[test]
fn an_overlong_varint_is_read_as_its_value_and_bytes_after_a_message_are_not() {
    // Hello { version: 6 } is [0, 6]; [0, 0x86, 0x00] spells the 6 in two bytes.
    let overlong = frame_of_body(&[0, 0x86, 0x00]);
    let got = decode_checked::<HostMessage>(&overlong).unwrap();
    let hello = HostMessage::Hello { version: 6 };
    assert_eq!(got[0].result, Ok(hello));
    let trailing = frame_of_body(&[0, 6, 0]);
    let got = decode_checked::<HostMessage>(&trailing).unwrap();
    assert_eq!(got[0].result, Err(FrameError::Decode));
}
