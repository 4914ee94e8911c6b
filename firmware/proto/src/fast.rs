//! Hand-written postcard for every message: the same bytes as `postcard` (serde) writes
//! and the same accept/reject decisions as it makes when reading, without serde's
//! per-field call chain. Equivalence is tested against postcard in `tests/roundtrip.rs`
//! (every message; arbitrary and mutated bodies).
//!
//! Why: in the host's closed loop (one Sensor and one Actuation frame each way per tick)
//! serde's per-field calls cost more than the CRC and COBS of the frame together; on the
//! device, postcard's and serde's code for [`Config`](crate::Config) and
//! [`Command`](crate::Command) cost flash for nothing the device needs. Each message
//! has its own function, so the device links only the ones it uses.
//!
//! The writer (`write`: `Out` and one `encode_*` per message) and the reader (`read`:
//! `In` and one decoder per message) follow the one list of postcard's rules below;
//! a field changed in one changes in the other.
//!
//! postcard's rules used here: an enum variant index is a varint `u32`; `bool` is one
//! byte, 0 or 1; `Option` a byte 0 (None) or 1 (Some) before the value; `u16`, `u32`,
//! are varints (at most 3 and 5 bytes, the last at most 0x03 and 0x0F; longer
//! zero-padded forms accepted); `i32` is zig-zag then varint `u32`; `u8` is one raw byte;
//! `fixint::le` is raw little-endian; struct fields follow in declaration order with no
//! framing.

mod read;
mod write;

pub(crate) use read::*;
pub(crate) use write::*;

/// Message variant indices (declaration order in [`Message`](crate::Message)).
pub(crate) const SENSOR: u8 = 0;
pub(crate) const ACTUATION: u8 = 1;
pub(crate) const CONFIG: u8 = 2;
pub(crate) const COMMAND: u8 = 3;
pub(crate) const STATUS: u8 = 4;
/// [`Command`](crate::Command) variants this version defines (indices
/// `0..COMMANDS`).
pub(crate) const COMMANDS: u32 = 5;
/// [`YawMode`](crate::YawMode) variants (the first field of a
/// [`Config`](crate::Config)), indices `0..YAW_MODES`.
pub(crate) const YAW_MODES: u32 = 3;

/// The variant index a body starts with (a Command's variant, a Config's mode): its
/// varint as `In::varint` reads it, any of its forms (a longer one than the encoder's
/// too); `None` if it is malformed (the message's decoder then refuses it).
pub(crate) fn leading_index(body: &[u8]) -> Option<u32> {
    match varint_of(body) {
        (_, 0) => None,
        (v, _) => Some(v),
    }
}
