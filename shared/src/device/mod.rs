//! The drive board's application, independent of any register: the hardware traits the
//! board and QEMU builds implement, the service state machine that answers the host, the
//! commissioning (the watched drive, the probe, the experiment designed from it and
//! its records), the conversion of a fit into the wire report, the stored
//! parameters on a flash sector, and a simulated plant behind the drive traits.
//!
//! Uses [`crate::fit`], [`crate::model`] and [`crate::wire`]; nothing below it uses it.

pub mod bench;
pub mod commissioning;
pub mod design;
pub mod experiment;
pub mod flash_store;
pub mod hardware;
pub mod job;
pub mod offset;
pub mod plant;
pub mod probe;
pub mod record_store;
pub mod report;
pub mod rest;
pub mod service;
pub mod trace;
pub mod unpinned;
#[cfg(any(test, feature = "std"))]
pub mod virtual_board;
