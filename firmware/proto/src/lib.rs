//! The wire protocol between the plant simulator (host) and the controller (device),
//! `no_std`, no allocation: the only definition of the format.
//!
//! # Frame
//!
//! ```text
//! wire  = COBS( raw | crc ) 0x00
//! raw   = VERSION (1 byte, = 3) | postcard(Message)     (the enum index is the type byte)
//! crc   = CRC-32C(raw), little-endian, 4 bytes
//! ```
//!
//! Numbers on the wire (postcard variant indices, declaration order, stated here so a
//! client needs no source):
//!
//! | type byte | message | direction | | enum | indices |
//! |---|---|---|---|---|---|
//! | 0 | [`Sensor`] | host -> device | | [`Lateral`] | 0 `Velocity`, 1 `Acceleration`, 2 `Both` |
//! | 1 | [`Actuation`] | device -> host | | [`YawMode`] | 0 `Passive`, 1 `Gain`, 2 `Lead` |
//! | 2 | [`Config`] | host -> device | | [`Command`] | 0 `ResetCounters`, 1 `RequestStatus`, 2 `ClearFaults` (3 `InjectStall`, 4 `InjectHardFault`: test builds) |
//! | 3 | [`Command`] | host -> device | | [`RefuseReason`] | [`plausible`] |
//! | 4 | [`Status`] | device -> host | | `reset_cause` | [`reset_cause`] |
//!
//! Version 3 (this one) added to version 2: the [`Rates`] of a design (`delay_ticks`,
//! the designed `kp`, `lead_k_hf`, `wsp_lead_k_hf` and `Ki`'s shift, which left the
//! fingerprint: a device accepts exactly its own designs, `wheelset_control::design`),
//! [`Flags::DRIVE_OSC`] (the drive check's alarm) and the Status's `drive_alarms` and
//! `first_drive_alarm_tick`. Version 2 added to version 1 the Sensor's `v_ref_mm_s` (the
//! wheel-slip protection's reference speed), 16-bit [`Flags`] (a varint: `WHEEL_SLIP`,
//! `HUNTING`, `ACTUATOR_FAULT`, `FAULT_LATCHED`), the Config's `wsp` and `monitor_safe`,
//! [`Command::ClearFaults`], and the Status's board, supervision and boot fields. A frame
//! of another version is refused as `rx_version`.
//!
//! [`Actuation`] `tick` counts the device's ticks from 1 (the first tick after start-up
//! sends 1; modulo 2^16). An undefined Command or YawMode index (any well-formed varint
//! above the defined ones) is refused by the device as an unknown request, not counted
//! as a decoding error; a malformed varint there is a decoding error (`rx_postcard`).
//!
//! - [`Message`]: [`Sensor`] (host -> device, every tick), [`Actuation`] (device -> host,
//!   every tick), [`Config`] and [`Command`] (host -> device), [`Status`] (device -> host,
//!   the counters). Physical quantities are integers with the LSBs of [`units`].
//! - Bounded: a frame is at most [`MAX_FRAME`] = 164 bytes on the wire. Nothing here
//!   panics on input; a rejected frame is a typed [`FrameError`] (Crc, Cobs, Version,
//!   Length, Postcard).
//!
//! # The codec
//!
//! Message bodies are `postcard` (the serde derives of the messages), the frame's COBS
//! the `cobs` crate's, its CRC the `crc` crate's ([`CRC`]): one encoder and one decoder,
//! the same code on the host and the device (`std` adds only error impls and the SI
//! conversions).
//!
//! | side | encodes | decodes |
//! |---|---|---|
//! | device | [`encode`]: an Actuation (each tick) or a Status into the caller's buffer | [`Decoder::next_request`]: the messages it takes as a [`Request`] |
//! | host | [`encode`], [`encode_vec`] (into a fixed-capacity vector) | [`Decoder::next_message`]: any [`Message`] |
//!
//! Both decoders take bytes in any chunking, resynchronise on 0x00 and return the bytes
//! after the frame they closed; they differ only in the messages they decode (the
//! device links the decoders of the messages it takes, not of those it sends).
//! [`frame_raw`] frames any raw bytes (`VERSION | body`) as [`encode`] does: a test's or
//! a client's own frames.
//!
//! # Sizes on the wire (delimiter included; measured by the `sizes` test)
//!
//! | frame | typical (`curve`, traction on) | worst case |
//! |---|---|---|
//! | Sensor, `y'` only | 26 | 38 (43 with `y'` and `y''`) |
//! | Actuation | 20 | 30 |
//! | both, one tick | 46 | 73 |
//! | Status (counters) | - | 153 |
//!
//! Typical: `y'` 2 mm/s, 115 A, 925.6 rad/s, 2460 N m demand, 83.3 m/s reference speed;
//! 200 N m, 3965 V, 600 cycles.
//! Fixed overhead per frame: COBS 1 + delimiter 1 + version 1 + type 1 + CRC 4 = 8 bytes;
//! fixed-width fields: the three 16-bit counters (seq, time, tick) 2 bytes each, because
//! they use their full range and a varint would take 3.
//!
//! The 4-byte CRC-32C is the largest fixed cost; [`CRC`] gives the measured reason 16
//! bits are not enough after COBS. On the full-duplex UART each direction carries one
//! frame per tick, so the budget that matters is per direction: the link-budget check
//! ([`link`]) holds each direction's worst case against the baud.
//!
//! # Error detection
//!
//! Every single and double bit flip of a frame is rejected in the tests (exhaustively over
//! all flip pairs of sample frames, and by a property test over random frames): flips in
//! COBS data bytes are caught by the CRC's Hamming distance; flips that disturb the COBS
//! structure scramble the payload and are caught with probability `1 - 2^-32`.
//! A cargo-fuzz target for the decoder lives in `firmware/proto/fuzz` (outside the
//! workspace; `cargo +nightly fuzz run decode`).

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
    /// A reset after a HardFault or a panic (the handler drove the safe outputs, then
    /// reset).
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
