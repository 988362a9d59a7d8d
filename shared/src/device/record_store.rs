//! The record a board identifies from, in fixed memory: streamed in by the host or
//! recorded by the commissioning experiment.

use crate::model::record::Record;

/// Buffers of one record, in fixed memory.
pub struct RecordStore<const N: usize> {
    pub(super) dt: f32,
    /// Samples received or recorded so far.
    pub(super) len: usize,
    /// Samples announced.
    pub(super) expected: usize,
    pub(super) with_current: bool,
    /// First sample of the coast-down (commissioning records only).
    pub(super) coast_from: Option<usize>,
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
        RecordStore {
            dt: 0.0,
            len: 0,
            expected: 0,
            with_current: false,
            coast_from: None,
            v: [0.0; N],
            omega: [0.0; N],
            current: [0.0; N],
        }
    }

    /// The record held (the samples received so far).
    pub(super) fn record(&self) -> Record<'_> {
        Record {
            dt: self.dt,
            v: &self.v[..self.len],
            omega: &self.omega[..self.len],
            current: self.with_current.then(|| &self.current[..self.len]),
            load: None,
            coast_from: self.coast_from,
        }
    }
}
