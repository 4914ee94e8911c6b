//! Worst-case frame sizes on the wire, delimiter included: the one definition every link
//! budget uses (pinned by `tests/sizes.rs`). A frame is `body + 8` bytes ([`frame_len`]);
//! worst widths: `i32`/`u32` varint 5, `u16` varint 3, fixed `u16` 2, `u32` 4, `u64` 8,
//! `u8`/`bool`/tags 1.

use crate::frame::CRC_LEN;

/// Worst-case varint widths (postcard): `u32`/`i32` 5 bytes, `u16` 3.
const V32: usize = 5;
const V16: usize = 3;

/// Bytes on the wire of a message with a `body`-byte body: COBS 1 + version 1 + type 1 +
/// body + CRC + delimiter 1 (below 254 raw bytes).
#[must_use]
pub const fn frame_len(body: usize) -> usize {
    1 + 1 + 1 + body + CRC_LEN + 1
}

/// Sensor, `Lateral::Velocity` or `Acceleration` (one lateral value): seq 2, t 2,
/// lateral tag 1 + 5, current 5, speed 5, demand 5, reference speed 5.
pub const SENSOR_ONE_LATERAL_MAX_FRAME: usize = frame_len(2 + 2 + 1 + V32 + V32 + V32 + V32 + V32);

/// Any Sensor (`Lateral::Both`: two lateral values): the host -> device budget per tick.
pub const SENSOR_MAX_FRAME: usize = SENSOR_ONE_LATERAL_MAX_FRAME + V32;

/// Actuation: seq echo 2, tick 2, exec 5, flags 3, torque 5, voltage 5.
pub const ACTUATION_MAX_FRAME: usize = frame_len(2 + 2 + V32 + V16 + V32 + V32);

/// Command: the variant index, 1 byte.
pub const COMMAND_MAX_FRAME: usize = frame_len(1);

/// Config with rates: mode 1, traction 1, enable 1, hold 3, wsp 1, monitor_safe 1,
/// Some 1, numeric 1, fingerprint 4, base rate 5, divisors 3 + 3, delay 1, nine
/// coefficients 9 x 5, `Ki`'s shift 1, two Q32 factors 2 x 8.
pub const CONFIG_MAX_FRAME: usize =
    frame_len(1 + 1 + 1 + V16 + 1 + 1 + 1 + 1 + 4 + V32 + 2 * V16 + 1 + 9 * V32 + 1 + 16);

/// Status: 30 counters x 5, refuse reason 1, reset cause 1, flags 3.
pub const STATUS_MAX_FRAME: usize = frame_len(30 * V32 + 1 + 1 + V16);
