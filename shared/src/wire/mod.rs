//! The wire format between a host and a drive board, and the board's stored-parameter
//! record: the messages, their framing (postcard, CRC-32, COBS), the commissioning limits the
//! host sets and the flash layout that keeps them with the parameters.
//!
//! An interface-control leaf: it depends on no algorithm and no model type (the pipeline
//! names and parameter codes it carries are its own types), so both ends read it without
//! pulling in the fit. See `docs/CONTRACTS.md` for every field and version.

#[cfg(test)]
pub(crate) mod arbitrary;
pub mod frame;
pub mod limits;
pub mod protocol;
pub mod stored;
