//! The wire protocol between the plant simulator (host) and the controller (device),
//! `no_std`, no allocation: the only definition of the format (`docs/wire.md`).
//!
//! ```text
//! wire  = COBS( raw | crc ) 0x00
//! raw   = VERSION (1 byte, = 3) | postcard(Message)     (the enum index is the type byte)
//! crc   = CRC-32C(raw), little-endian, 4 bytes
//! ```
//!
//! Postcard variant indices (declaration order), stated so a client needs no source:
//!
//! | type byte | message | direction | | enum | indices |
//! |---|---|---|---|---|---|
//! | 0 | [`Sensor`] | host -> device | | [`Lateral`] | 0 `Velocity`, 1 `Acceleration`, 2 `Both` |
//! | 1 | [`Actuation`] | device -> host | | [`YawMode`] | 0 `Passive`, 1 `Gain`, 2 `Lead` |
//! | 2 | [`Config`] | host -> device | | [`Command`] | 0 `ResetCounters`, 1 `RequestStatus`, 2 `ClearFaults` (3 `InjectStall`, 4 `InjectHardFault`: test builds) |
//! | 3 | [`Command`] | host -> device | | [`RefuseReason`] | [`plausible`] |
//! | 4 | [`Status`] | device -> host | | `reset_cause` | [`reset_cause`] |
//!
//! Physical quantities are integers with the LSBs of [`units`]; frames are at most
//! [`MAX_FRAME`] bytes; nothing panics on input. One codec for host and device:
//! [`encode`], and [`Decoder`] (bytes in any chunking, resynchronising on 0x00).

#![cfg_attr(not(feature = "std"), no_std)]
#![deny(missing_docs)]

mod decoder;
mod frame;
pub mod link;
mod message;
mod pieces;
pub mod plausible;
#[cfg(feature = "std")]
mod si;
mod sizes;
pub mod units;

/// [`Status::reset_cause`] codes: why the board last started.
pub mod reset_cause {
    /// Not known or not measured (the in-process device; a board without the register).
    pub const UNKNOWN: u8 = 0;
    /// Power-on (or brown-out) reset.
    pub const POWER_ON: u8 = 1;
    /// The reset pin (or the debugger).
    pub const PIN: u8 = 2;
    /// The independent hardware watchdog expired: a stalled control tick or receive path.
    pub const WATCHDOG: u8 = 3;
    /// A software reset request (`SYSRESETREQ`).
    pub const SOFTWARE: u8 = 4;
    /// A reset after a HardFault or a panic (the handler drove the safe outputs, then reset).
    pub const FAULT: u8 = 5;
}

pub use decoder::Decoder;
pub use frame::{
    encode, encode_raw, encode_vec, frame_raw, EncodeError, FrameError, Request, CRC, CRC_LEN,
    MAX_FRAME, MAX_RAW, MIN_DECODED, VERSION,
};
pub use message::{
    Actuation, Command, Config, Flags, Lateral, Message, Rates, Sensor, Status, YawMode,
};
pub use pieces::{Closed, Pieces};
pub use plausible::RefuseReason;
#[cfg(feature = "std")]
pub use si::{t_us_of, ActuationSi, LateralSensing, Quantized, SensorSi};

pub use sizes::{
    frame_len, ACTUATION_MAX_FRAME, COMMAND_MAX_FRAME, CONFIG_MAX_FRAME, SENSOR_MAX_FRAME,
    SENSOR_ONE_LATERAL_MAX_FRAME, STATUS_MAX_FRAME,
};
