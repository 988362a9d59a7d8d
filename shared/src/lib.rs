//! motor-id core: a fixed-step DC motor model (paper Eq. 1-5) with optional unmodelled
//! effects, the Farmland Fertility Optimizer in fixed memory (paper Eq. 8-16), least-squares
//! refinement, identification with an identifiability report, and the host/board messages.
//! The paper: H. Abdel-Maksoud, *DC Motor Parameters Identification Using Farmland Fertility
//! Optimizer*; equation numbers ("paper Eq. N") refer to it.
//!
//! `no_std` without an allocator (builds for `thumbv7em-none-eabihf`); tests and the `std`
//! feature use the standard library. All arithmetic on signals is f32 with no fused
//! multiply-add, so the same data and seed give bit-identical results on host and board.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(missing_docs)]
// Matrix and per-dimension loops read as the equations they implement.
#![allow(clippy::needless_range_loop)]

pub mod capacity;
pub mod catalogue;
pub mod device;
pub mod error;
pub mod fit;
pub mod model;
pub mod param_id;
pub mod rng;
#[cfg(test)]
pub(crate) mod testkit;
pub mod wire;

pub use error::Error;
pub use model::params::ModelParams;
pub use model::record::Record;
pub use param_id::ParamId;
