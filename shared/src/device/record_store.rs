//! The records a board identifies from, in fixed memory: one streamed in by the host, or the
//! commissioning experiment's two (slow and fast) one after the other in the same buffers.

use crate::model::record::Record;

/// Records held at most.
pub const SEGMENTS: usize = 2;

/// Where one record lies in the buffers.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct Segment {
    /// First sample.
    pub start: usize,
    /// Samples held so far.
    pub len: usize,
    /// Sample step [s].
    pub dt: f32,
    /// First sample of the coast-down, counted from the record's start.
    pub coast_from: Option<usize>,
    /// Drive samples each reading is the mean of ([`Record::averaged`]).
    pub averaged: u32,
}

/// Buffers of up to [`SEGMENTS`] records, `N` samples in all, in fixed memory.
pub struct RecordStore<const N: usize> {
    pub(super) segments: [Segment; SEGMENTS],
    /// Records in use.
    pub(super) count: usize,
    /// Samples announced of a streamed record.
    pub(super) expected: usize,
    pub(super) with_current: bool,
    pub(super) v: [f32; N],
    pub(super) omega: [f32; N],
    pub(super) current: [f32; N],
}

impl<const N: usize> Default for RecordStore<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> RecordStore<N> {
    /// Empty buffers (const, for a `static`).
    pub const fn new() -> Self {
        const EMPTY: Segment = Segment {
            start: 0,
            len: 0,
            dt: 0.0,
            coast_from: None,
            // 0 reads as 1 (a reading at each instant) and keeps the buffers in `.bss`.
            averaged: 0,
        };
        RecordStore {
            segments: [EMPTY; SEGMENTS],
            count: 0,
            expected: 0,
            with_current: false,
            v: [0.0; N],
            omega: [0.0; N],
            current: [0.0; N],
        }
    }

    /// Forget what is held; the next record starts at sample 0.
    pub(super) fn clear(&mut self, with_current: bool) {
        self.count = 0;
        self.expected = 0;
        self.with_current = with_current;
    }

    /// Open a new record of step `dt` (its coast-down from `coast_from`, each reading the
    /// mean of `averaged` drive samples) after the last one; its index.
    pub(super) fn open(&mut self, dt: f32, coast_from: Option<usize>, averaged: u32) -> usize {
        let start = match self.count {
            0 => 0,
            c => self.segments[c - 1].start + self.segments[c - 1].len,
        };
        let index = self.count.min(SEGMENTS - 1);
        self.segments[index] = Segment {
            start,
            len: 0,
            dt,
            coast_from,
            averaged,
        };
        self.count = index + 1;
        index
    }

    /// Samples free after the last record.
    pub(super) fn free(&self) -> usize {
        match self.count {
            0 => N,
            c => N - (self.segments[c - 1].start + self.segments[c - 1].len),
        }
    }

    /// Append a sample to record `index` (the last one opened); false when full.
    pub(super) fn push(&mut self, index: usize, v: f32, omega: f32, current: f32) -> bool {
        let seg = &mut self.segments[index];
        let at = seg.start + seg.len;
        if at >= N {
            return false;
        }
        (self.v[at], self.omega[at], self.current[at]) = (v, omega, current);
        seg.len += 1;
        true
    }

    /// Samples received of a streamed record (the first).
    /// Subtract `delta` from every current reading held (an offset of the current sensor
    /// found after the records were taken).
    pub(super) fn shift_current(&mut self, delta: f32) {
        let end = match self.count {
            0 => 0,
            c => self.segments[c - 1].start + self.segments[c - 1].len,
        };
        for c in &mut self.current[..end] {
            *c -= delta;
        }
    }

    pub(super) fn streamed(&self) -> usize {
        match self.count {
            0 => 0,
            _ => self.segments[0].len,
        }
    }

    /// The records held.
    pub(super) fn records(&self) -> heapless::Vec<Record<'_>, SEGMENTS> {
        self.segments[..self.count]
            .iter()
            .map(|seg| {
                let span = seg.start..seg.start + seg.len;
                Record {
                    dt: seg.dt,
                    v: &self.v[span.clone()],
                    omega: &self.omega[span.clone()],
                    current: self.with_current.then(|| &self.current[span]),
                    load: None,
                    coast_from: seg.coast_from,
                    averaged: seg.averaged,
                }
            })
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn two_records_share_the_buffers_one_after_the_other() {
        let mut store = RecordStore::<8>::new();
        store.clear(true);
        let a = store.open(0.1, Some(3), 1);
        for k in 0..5 {
            assert!(store.push(a, k as f32, 1.0, 2.0));
        }
        assert_eq!(store.free(), 3);
        let b = store.open(0.01, None, 1);
        for k in 0..3 {
            assert!(store.push(b, -(k as f32), 0.0, 0.0));
        }
        assert!(!store.push(b, 9.0, 9.0, 9.0), "full");
        let records = store.records();
        assert_eq!(records.len(), 2);
        assert_eq!(records[0].v, &[0.0, 1.0, 2.0, 3.0, 4.0]);
        assert_eq!(records[0].coast_from, Some(3));
        assert_eq!(records[0].dt, 0.1);
        assert_eq!(records[1].v, &[0.0, -1.0, -2.0]);
        assert_eq!(records[1].dt, 0.01);
        assert_eq!(records[1].coast_from, None);
        assert!(records[1].current.is_some());
    }
}
