//! Worst-case frame sizes, delimiter included (pinned by `tests/sizes.rs`): `body + 8`
//! bytes, with `i32`/`u32` varints 5 bytes, `u16` varints 3.

use crate::frame::CRC_LEN;

/// Worst-case varint widths (postcard): `u32`/`i32` 5 bytes, `u16` 3.
const V32: usize = 5;
const V16: usize = 3;

/// Bytes on the wire of a `body`-byte body: COBS, version, type, CRC, delimiter.
#[must_use]
pub const fn frame_len(body: usize) -> usize {
    1 + 1 + 1 + body + CRC_LEN + 1
}

/// Sensor with one lateral value: seq 2, t 2, lateral 1 + 5, four `i32`s.
pub const SENSOR_ONE_LATERAL_MAX_FRAME: usize = frame_len(2 + 2 + 1 + V32 + V32 + V32 + V32 + V32);

/// Any Sensor (`Lateral::Both`: two lateral values): the host -> device budget per tick.
pub const SENSOR_MAX_FRAME: usize = SENSOR_ONE_LATERAL_MAX_FRAME + V32;

/// Actuation: seq echo 2, tick 2, exec 5, flags 3, torque 5, voltage 5.
pub const ACTUATION_MAX_FRAME: usize = frame_len(2 + 2 + V32 + V16 + V32 + V32);

/// Command: the variant index, 1 byte.
pub const COMMAND_MAX_FRAME: usize = frame_len(1);

/// Config with rates: 7 flags and tags, hold 3, numeric 1, fingerprint 4, rate 5,
/// divisors 3 + 3, delay 1, nine coefficients 9 x 5, shift 1, two Q32 factors 2 x 8.
pub const CONFIG_MAX_FRAME: usize =
    frame_len(1 + 1 + 1 + V16 + 1 + 1 + 1 + 1 + 4 + V32 + 2 * V16 + 1 + 9 * V32 + 1 + 16);

/// Status: 30 counters x 5, refuse reason 1, reset cause 1, flags 3.
pub const STATUS_MAX_FRAME: usize = frame_len(30 * V32 + 1 + 1 + V16);
