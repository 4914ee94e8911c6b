//! Framing, `COBS( VERSION | postcard(Message) | CRC-32C LE ) 0x00`: the encoder and the checks.

use serde::de::DeserializeOwned;

use crate::message::Message;

/// Protocol version, the first byte of every decoded frame.
pub const VERSION: u8 = 3;

/// CRC length in bytes.
pub const CRC_LEN: usize = 4;

/// Largest `VERSION | postcard(Message)` (157), rounded up: [`MAX_FRAME`] a multiple of 4.
pub const MAX_RAW: usize = 158;

/// Largest COBS-encoded frame with its delimiter (one COBS overhead byte per 254).
pub const MAX_FRAME: usize = MAX_RAW + CRC_LEN + 1 + 1;

/// Shortest valid decoded frame: version, type, CRC.
pub const MIN_DECODED: usize = 1 + 1 + CRC_LEN;

/// The frame CRC: CRC-32C, little-endian. 32 bits: a flip in a COBS code byte scrambles
/// the payload, which an `n`-bit CRC passes with probability `2^-n` (the `flips` test).
pub static CRC: crc::Crc<u32, crc::Table<1>> =
    crc::Crc::<u32, crc::Table<1>>::new(&crc::CRC_32_ISCSI);

/// Message variant indices (declaration order in [`Message`]; the type byte).
pub(crate) const SENSOR: u32 = 0;
pub(crate) const ACTUATION: u32 = 1;
pub(crate) const CONFIG: u32 = 2;
pub(crate) const COMMAND: u32 = 3;
pub(crate) const STATUS: u32 = 4;
/// [`crate::Command`] variants this version defines (indices `0..COMMANDS`).
pub(crate) const COMMANDS: u32 = 5;
/// [`crate::YawMode`] variants (a [`crate::Config`]'s first field), indices `0..YAW_MODES`.
pub(crate) const YAW_MODES: u32 = 3;

/// Why a frame was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum FrameError {
    /// The CRC does not match.
    Crc,
    /// The bytes between two delimiters are not valid COBS.
    Cobs,
    /// A valid frame of another protocol version.
    Version,
    /// Too short, longer than [`MAX_FRAME`], or bytes left after the message.
    Length,
    /// The CRC matched but postcard could not decode a [`Message`].
    Postcard,
}

impl FrameError {
    /// Every kind, in the order of [`Self::index`] and of the Status's `rx_*` counters.
    pub const KINDS: [FrameError; 5] = [
        Self::Crc,
        Self::Cobs,
        Self::Version,
        Self::Length,
        Self::Postcard,
    ];

    /// The kind's place in [`Self::KINDS`].
    #[must_use]
    pub const fn index(self) -> usize {
        self as usize
    }
}

impl core::fmt::Display for FrameError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str(match self {
            Self::Crc => "frame rejected: CRC mismatch",
            Self::Cobs => "frame rejected: invalid COBS encoding",
            Self::Version => "frame rejected: unknown protocol version",
            Self::Length => "frame rejected: bad length",
            Self::Postcard => "frame rejected: message does not decode",
        })
    }
}

#[cfg(feature = "std")]
impl std::error::Error for FrameError {}

/// Why a message could not be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum EncodeError {
    /// The output buffer is shorter than the frame (use [`MAX_FRAME`]).
    BufferTooSmall,
}

impl core::fmt::Display for EncodeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("output buffer too small for the frame (MAX_FRAME bytes always fit)")
    }
}

#[cfg(feature = "std")]
impl std::error::Error for EncodeError {}

/// `msg` as one wire frame, delimiter included, into `out`; its length.
pub fn encode(msg: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
    let area = out.len().min(1 + MAX_RAW);
    let n = encode_raw(
        msg,
        out.get_mut(1..area).ok_or(EncodeError::BufferTooSmall)?,
    )?;
    seal(out, n)
}

/// The first half of [`encode`]: `VERSION | postcard(msg)` into `out`; its length.
pub fn encode_raw(msg: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
    let (version, body) = out.split_first_mut().ok_or(EncodeError::BufferTooSmall)?;
    *version = VERSION;
    let n = postcard::to_slice(msg, body)
        .map_err(|_| EncodeError::BufferTooSmall)?
        .len();
    Ok(1 + n)
}

/// [`encode`] of raw bytes (`VERSION | body`, at most [`MAX_RAW`]) into `out`; its length.
pub fn frame_raw(raw: &[u8], out: &mut [u8]) -> Result<usize, EncodeError> {
    let too_small = EncodeError::BufferTooSmall;
    if raw.len() > MAX_RAW {
        return Err(too_small);
    }
    out.get_mut(1..=raw.len())
        .ok_or(too_small)?
        .copy_from_slice(raw);
    seal(out, raw.len())
}

/// The frame around the raw bytes `out[1..=n]` (CRC, COBS in place, delimiter); its length.
fn seal(out: &mut [u8], n: usize) -> Result<usize, EncodeError> {
    let too_small = EncodeError::BufferTooSmall;
    let with_crc = n + CRC_LEN;
    let frame = out.get_mut(..with_crc + 2).ok_or(too_small)?;
    let crc = CRC.checksum(frame.get(1..=n).ok_or(too_small)?);
    frame
        .get_mut(n + 1..=with_crc)
        .ok_or(too_small)?
        .copy_from_slice(&crc.to_le_bytes());
    let mut cobs = cobs::EncoderState::default();
    for k in 1..=with_crc {
        let b = *frame.get(k).ok_or(too_small)?;
        match cobs.push(b) {
            cobs::PushResult::AddSingle(_) => {}
            cobs::PushResult::ModifyFromStartAndSkip((at, code)) => {
                *frame.get_mut(at).ok_or(too_small)? = code;
            }
            // A block of 254 bytes: longer than any frame.
            cobs::PushResult::ModifyFromStartAndPushAndSkip(_) => return Err(too_small),
        }
    }
    let (at, code) = cobs.finalize();
    *frame.get_mut(at).ok_or(too_small)? = code;
    *frame.get_mut(with_crc + 1).ok_or(too_small)? = 0;
    Ok(with_crc + 2)
}

/// The host's [`encode`] into a fixed-capacity vector (no allocation).
///
/// ```
/// use wheelset_proto::{encode_vec, Command, Message};
/// let frame = encode_vec(&Message::Command(Command::RequestStatus)).unwrap();
/// assert_eq!(frame.last(), Some(&0));
/// assert!(!frame[..frame.len() - 1].contains(&0));
/// ```
pub fn encode_vec(msg: &Message) -> Result<heapless::Vec<u8, MAX_FRAME>, EncodeError> {
    let mut buf = [0u8; MAX_FRAME];
    let n = encode(msg, &mut buf)?;
    heapless::Vec::from_slice(buf.get(..n).ok_or(EncodeError::BufferTooSmall)?)
        .map_err(|_| EncodeError::BufferTooSmall)
}

/// Checks a COBS-decoded frame's length, CRC and version; the message bytes (type first).
pub(crate) fn check(frame: &[u8]) -> Result<&[u8], FrameError> {
    let n = frame.len();
    if n < MIN_DECODED {
        return Err(FrameError::Length);
    }
    let (raw, crc) = frame.split_at(n - CRC_LEN);
    if crc != CRC.checksum(raw).to_le_bytes() {
        return Err(FrameError::Crc);
    }
    match raw.split_first() {
        Some((&VERSION, msg)) => Ok(msg),
        _ => Err(FrameError::Version),
    }
}

/// One `T` from all of `bytes`: postcard's decision, then no bytes left over (the host's
/// reading of a checked frame's message bytes, `T` = [`Message`]).
pub(crate) fn whole<T: DeserializeOwned>(bytes: &[u8]) -> Result<T, FrameError> {
    match postcard::take_from_bytes::<T>(bytes) {
        Ok((v, [])) => Ok(v),
        Ok(_) => Err(FrameError::Length),
        Err(_) => Err(FrameError::Postcard),
    }
}

/// What the device takes from a frame; Actuation and Status are known by type byte only.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request {
    /// [`Message::Sensor`].
    Sensor(crate::Sensor),
    /// [`Message::Config`].
    Config(crate::Config),
    /// [`Message::Command`].
    Command(crate::Command),
    /// A valid frame of a type the device sends, not takes; its body is not checked.
    Unexpected,
    /// A Command or Config `mode` index this version does not define (an unknown request).
    Unknown,
}

/// The device's reading of a checked frame: only the decoders of what it takes are linked.
pub(crate) fn request(msg: &[u8]) -> Result<Request, FrameError> {
    let (ty, body) = postcard::take_from_bytes::<u32>(msg).map_err(|_| FrameError::Postcard)?;
    // postcard writes an enum as its variant index (a varint), then the variant.
    let undefined =
        |defined: u32| postcard::take_from_bytes::<u32>(body).is_ok_and(|(i, _)| i >= defined);
    match ty {
        SENSOR => whole(body).map(Request::Sensor),
        CONFIG if undefined(YAW_MODES) => Ok(Request::Unknown),
        CONFIG => whole(body).map(Request::Config),
        COMMAND if undefined(COMMANDS) => Ok(Request::Unknown),
        COMMAND => whole(body).map(Request::Command),
        ACTUATION | STATUS => Ok(Request::Unexpected),
        _ => Err(FrameError::Postcard),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::FrameError;

    #[test]
    fn each_reject_kind_indexes_its_place() {
        for (i, k) in FrameError::KINDS.into_iter().enumerate() {
            assert_eq!(k.index(), i, "{k:?}");
        }
    }

    use super::*;
    use crate::{Actuation, Command, Config, Flags, Sensor, Status, YawMode};

    /// The variant indices stated above are postcard's (the first byte of each body).
    #[test]
    fn indices_are_postcards() {
        let config = Config {
            mode: YawMode::Lead,
            traction: true,
            enable: true,
            hold_ticks: 10,
            wsp: true,
            monitor_safe: false,
            rates: None,
        };
        let status = Status {
            flags: Flags(0),
            ..Status::default()
        };
        let first = |m: &Message| u32::from(postcard::to_slice(m, &mut [0u8; MAX_RAW]).unwrap()[0]);
        assert_eq!(first(&Message::Sensor(Sensor::ZERO)), SENSOR);
        let act = Actuation {
            seq_echo: 0,
            tick: 0,
            exec: 0,
            flags: Flags(0),
            t_psi_dnm: 0,
            u_a_cv: 0,
        };
        assert_eq!(first(&Message::Actuation(act)), ACTUATION);
        assert_eq!(first(&Message::Config(config)), CONFIG);
        assert_eq!(first(&Message::Command(Command::ResetCounters)), COMMAND);
        assert_eq!(first(&Message::Status(status)), STATUS);
        let index = |c: Command| postcard::to_slice(&c, &mut [0u8; 4]).unwrap()[0];
        assert_eq!(u32::from(index(Command::InjectHardFault)) + 1, COMMANDS);
        let mode = |m: YawMode| postcard::to_slice(&m, &mut [0u8; 4]).unwrap()[0];
        assert_eq!(u32::from(mode(YawMode::Lead)) + 1, YAW_MODES);
    }

    #[test]
    fn crc_is_crc32c() {
        assert_eq!(CRC.checksum(b"123456789"), 0xE306_9283);
    }
}
