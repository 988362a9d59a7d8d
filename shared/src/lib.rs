//! motor-id core: a fixed-step DC motor model (seed Eq. 1-5) with optional unmodelled
//! effects, the Farmland Fertility Optimizer in fixed memory (seed Eq. 8-16), least-squares
//! refinement, identification with an identifiability report, and the host/board messages.
//!
//! `no_std` without an allocator (builds for `thumbv7em-none-eabihf`); tests and the `std`
//! feature use the standard library. All arithmetic on signals is f32 with no fused
//! multiply-add, so the same data and seed give bit-identical results on host and board.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(missing_docs)]
// Matrix and per-dimension loops read as the equations they implement.
#![allow(clippy::needless_range_loop)]

pub mod capacity;
pub mod discretise;
pub mod effects;
pub mod error;
pub mod ffo;
pub mod frame;
pub mod identifiability;
pub mod identify;
pub mod initial;
pub mod linalg;
pub mod objective;
pub mod params;
pub mod plant;
pub mod profile;
pub mod protocol;
pub mod record;
pub mod refine;
pub mod rng;
pub mod service;
pub mod sim;
pub mod space;
pub mod stored;
pub mod synth;
#[cfg(test)]
pub(crate) mod testkit;

pub use error::Error;
pub use params::{ModelParams, ParamId};
pub use record::Record;
