//! Records over a board link: a record CSV streamed to the board in chunks for it to
//! identify, and the records the board holds (its commissioning experiment's, or the one
//! streamed in) read back sample for sample.

use super::connection::{refused, Connection};
use crate::csvio::OwnedRecord;
use anyhow::{anyhow, bail, Result};
use motor_id_shared::device::virtual_board::BoardRecord;
use motor_id_shared::wire::protocol::{BoardMessage, HostMessage, RecordPart, Refusal, CHUNK};

/// Stream `rec` to the board (announcement, then every chunk acknowledged in order).
pub fn upload(c: &mut Connection, rec: &OwnedRecord, max_samples: u32) -> Result<()> {
    if rec.len() > max_samples as usize {
        bail!(
            "{}: {} samples, the board holds at most {max_samples}",
            rec.name(),
            rec.len()
        );
    }
    if rec.load.is_some() {
        bail!(
            "{}: the board identifies voltage-driven records only (no tl column)",
            rec.name()
        );
    }
    let begin = HostMessage::IdentifyBegin {
        dt: rec.dt,
        samples: rec.len() as u32,
        with_current: rec.current.is_some(),
        // The bridge column goes with it: the board fits a coast-down as the host does.
        coast_from: rec.coast_from.map(|k| k as u32),
    };
    c.request(&begin, |reply| match reply {
        BoardMessage::ChunkOk { next: 0 } => Some(Ok(())),
        other => refused(&other),
    })?;
    for start in (0..rec.len()).step_by(CHUNK) {
        let end = (start + CHUNK).min(rec.len());
        let take = |x: &[f32]| heapless::Vec::from_slice(&x[start..end]).expect("chunk fits");
        let chunk = HostMessage::RecordChunk {
            offset: start as u32,
            v: take(&rec.v),
            omega: take(&rec.omega),
            current: rec.current.as_deref().map_or_else(heapless::Vec::new, take),
        };
        c.request(&chunk, |reply| match reply {
            BoardMessage::ChunkOk { next } if next as usize == end => Some(Ok(())),
            other => refused(&other),
        })?;
    }
    Ok(())
}

/// Every record the board holds, read part by part; none when it holds none.
pub fn download(c: &mut Connection) -> Result<Vec<BoardRecord>> {
    let mut records = Vec::new();
    let mut index = 0u8;
    loop {
        let Some(first) = read_part(c, index, 0)? else {
            return Ok(records);
        };
        let (samples, records_held) = (first.samples as usize, first.records);
        if samples > super::MAX_BOARD_SAMPLES {
            bail!("the board announces a record of {samples} samples, more than any board holds");
        }
        let mut r = BoardRecord {
            dt: first.dt,
            v: Vec::with_capacity(samples),
            omega: Vec::with_capacity(samples),
            current: Vec::with_capacity(samples),
            coast_from: first.coast_from.map(|k| k as usize),
            averaged: first.averaged,
        };
        let mut part = first;
        loop {
            let consistent = part.record == index
                && part.offset as usize == r.v.len()
                && part.samples as usize == samples
                && part.averaged == r.averaged
                && r.averaged >= 1
                && !part.v.is_empty()
                && part.omega.len() == part.v.len()
                && (part.current.is_empty() || part.current.len() == part.v.len());
            if !consistent {
                bail!("the board sent an inconsistent part of record {index}");
            }
            r.v.extend(&part.v);
            r.omega.extend(&part.omega);
            r.current.extend(&part.current);
            if r.v.len() >= samples {
                break;
            }
            let at = r.v.len() as u32;
            part = read_part(c, index, at)?.ok_or_else(|| {
                anyhow!("the board stopped sending record {index} at sample {at}")
            })?;
        }
        if r.current.len() != r.v.len() {
            r.current.clear();
        }
        records.push(r);
        index += 1;
        if index >= records_held {
            return Ok(records);
        }
    }
}

/// Part of record `index` from `offset` on; `None` when the board holds no such record.
fn read_part(c: &mut Connection, index: u8, offset: u32) -> Result<Option<RecordPart>> {
    let ask = HostMessage::ReadRecord {
        record: index,
        offset,
    };
    c.request(&ask, |reply| match reply {
        BoardMessage::RecordData(part) if part.record == index && part.offset == offset => {
            Some(Ok(Some(part)))
        }
        BoardMessage::Refused(Refusal::NoRecord) => Some(Ok(None)),
        other => refused(&other).map(|r| r.map(|_| None)),
    })
}
