//! The motor model: the five parameters of paper Eq. 1-5 and the catalogue of effects, the
//! exact zero-order-hold discretisation, the fixed-step simulator, the measured record, the
//! excitation profiles and synthetic records.
//!
//! Owns the physics. Depends on nothing in this crate but [`crate::error`],
//! [`crate::capacity`] and [`crate::rng`]; it may not use the fit, the wire format or the
//! board application.

pub(crate) mod compensated;
pub mod discretise;
pub mod effects;
pub mod noise;
pub mod params;
pub mod profile;
pub mod record;
pub mod rounding;
pub mod sim;
pub mod step_mean;
pub mod synth;
pub(crate) mod trig;
