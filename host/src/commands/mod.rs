//! The subcommands of `motor-id`, one module each: its arguments and what it runs. Commands
//! use the helpers beside this module (fitting, reports, plots, files), never each other.

pub mod board;
pub mod commission;
pub mod compare;
pub mod demo;
pub mod diagnose;
pub mod identify;
pub mod import_scope;
pub mod simulate;
pub mod tune;
pub mod validate;
