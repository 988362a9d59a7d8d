//! Compile-time capacities of the fixed-memory identification (no allocator: every buffer
//! is sized here).
//!
//! Two sets. With the `full` feature (the host, and this crate's own tests): every effect
//! can be fitted (12 free parameters), the seed's population of 100 (paper-faithful mode),
//! a tacho delay line of 126 samples and a 256-point convergence trace. Without it (the
//! firmware): what a board identifies, the five motor parameters and Coulomb friction
//! (commissioning) with the default and board pipelines, in a few kilobytes of stack. The arithmetic does not depend on the capacities
//! (loops run over the parameters and members in use), so a problem that fits both gives the
//! same result bit for bit; one that does not fit is refused with a typed error
//! ([`crate::Error::TooManyParameters`], [`crate::Error::InvalidConfig`],
//! [`crate::Error::DelayTooLong`]).

/// Largest number of free parameters.
#[cfg(any(test, feature = "full"))]
pub const MAX_FREE: usize = 12;
/// Largest number of free parameters.
#[cfg(not(any(test, feature = "full")))]
pub const MAX_FREE: usize = 6;

/// Largest FFO population (`full`: the seed's 4 x 25; board: the default pipeline's 2 x 8).
#[cfg(any(test, feature = "full"))]
pub const MAX_POPULATION: usize = 100;
/// Largest FFO population (`full`: the seed's 4 x 25; board: the default pipeline's 2 x 8).
#[cfg(not(any(test, feature = "full")))]
pub const MAX_POPULATION: usize = 16;

/// Longest tacho delay the simulator can represent, in samples (none on a board).
#[cfg(any(test, feature = "full"))]
pub const MAX_DELAY_SAMPLES: usize = 126;
/// Longest tacho delay the simulator can represent, in samples (none on a board).
#[cfg(not(any(test, feature = "full")))]
pub const MAX_DELAY_SAMPLES: usize = 0;

/// Longest convergence trace kept (the seed's 200 iterations plus refinement; a board
/// reports progress as it goes and keeps none).
#[cfg(any(test, feature = "full"))]
pub const TRACE_CAPACITY: usize = 256;
/// Longest convergence trace kept (the seed's 200 iterations plus refinement; a board
/// reports progress as it goes and keeps none).
#[cfg(not(any(test, feature = "full")))]
pub const TRACE_CAPACITY: usize = 0;

/// Most refinements restarted from the next best FFO members after the first (the default
/// pipeline's 3; their starting points are kept while the population is dropped).
pub const MAX_RESTARTS: usize = 3;
