//! Compile-time capacities of the fixed-memory identification (no allocator: every buffer
//! is sized here).
//!
//! Two sets, chosen by [`FULL`]. With the `full` feature (the host, and this crate's own
//! tests): every effect can be fitted, the paper's population of 100 (paper-faithful mode),
//! a tacho delay line and a convergence trace. Without it (the firmware): what a board
//! identifies, the five motor parameters and Coulomb friction (commissioning) with the
//! default and board pipelines, in a few kilobytes of stack. The arithmetic does not depend
//! on the capacities (loops run over the parameters and members in use), so a problem that
//! fits both gives the same result bit for bit; one that does not fit is refused with a
//! typed error ([`crate::Error::TooManyParameters`], [`crate::Error::InvalidConfig`],
//! [`crate::Error::DelayTooLong`]).

use crate::param_id::PARAM_COUNT;

/// The host's capacities (`full` feature, and this crate's tests) rather than the board's.
pub const FULL: bool = cfg!(any(test, feature = "full"));

/// Parameters a parameter set ([`crate::ModelParams`]) and a problem
/// ([`crate::fit::space::ProblemSpec`]) hold, from the first in [`crate::ParamId`] order
/// (host: all; board: the five motor parameters and `tc`, which is all a board fits: both
/// are copied into many frames of an identification, and each parameter more costs its
/// stack). A parameter a build does not hold reads as its default (off).
pub const MODEL_PARAMS: usize = if FULL { PARAM_COUNT } else { 6 };

/// Largest number of free parameters (host: every parameter of the model; board: the five
/// motor parameters and `tc`).
pub const MAX_FREE: usize = if FULL { PARAM_COUNT } else { 6 };

/// Effect parameters a simulator holds, from the first (`tc`) on in [`crate::ParamId`]
/// order (host: every effect's; board: Coulomb friction's `tc`, which commissioning fits;
/// a simulator is copied a dozen times into every Jacobian, so a board keeps it small).
pub const SIM_EFFECT_PARAMS: usize = if FULL { PARAM_COUNT - 5 } else { 1 };

/// Largest FFO population (host: the paper's 4 x 25; board: the default pipeline's 2 x 8).
pub const MAX_POPULATION: usize = if FULL { 100 } else { 16 };

/// Longest tacho delay the simulator can represent, in samples (none on a board).
pub const MAX_DELAY_SAMPLES: usize = if FULL { 126 } else { 0 };

/// Longest convergence trace kept (host: the paper's 200 iterations plus refinement; a board
/// reports progress as it goes and keeps none).
pub const TRACE_CAPACITY: usize = if FULL { 256 } else { 0 };

/// Most parameter estimates in a board's report (host: every parameter of the model, the
/// five motor parameters and every effect's; board: the five and `tc`). The wire's frame
/// must hold a report of that many (`wire::frame` tests it).
pub const MAX_ESTIMATES: usize = if FULL { PARAM_COUNT } else { 6 };

/// Most refinements restarted from the next best FFO members after the first (the default
/// pipeline's 3; their starting points are kept while the population is dropped).
pub const MAX_RESTARTS: usize = 3;
