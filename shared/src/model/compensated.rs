//! A compensated (two-sum) f32 accumulator: the simulator's state, so that slow modes at
//! high sample rates do not stall on f32 rounding (see [`crate::model::sim`]).

/// Compensated f32 accumulator: `hi + lo` carries about twice the precision of one f32.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct Compensated {
    pub(crate) hi: f32,
    pub(crate) lo: f32,
}

impl Compensated {
    pub(crate) fn new(v: f32) -> Self {
        Compensated { hi: v, lo: 0.0 }
    }
    /// Knuth's two-sum; exact because Rust never fuses or reassociates f32 operations.
    pub(crate) fn add(&mut self, d: f32) {
        let y = d + self.lo;
        let s = self.hi + y;
        let bp = s - self.hi;
        let err = (self.hi - (s - bp)) + (y - bp);
        self.hi = s;
        self.lo = err;
    }
    pub(crate) fn set(&mut self, v: f32) {
        self.hi = v;
        self.lo = 0.0;
    }
}
