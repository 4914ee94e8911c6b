//! Framing: `COBS( VERSION | postcard(Message) | CRC-32C LE ) 0x00`.
//!
//! The CRC covers the version byte and the postcard bytes. Decoding checks, in order:
//! COBS structure, length, CRC, version, postcard, no trailing bytes; the first failure is
//! the [`FrameError`].

use crate::message::{Actuation, Command, Config, Message, Sensor, Status};

mod checksum;
mod cobs;

#[cfg(feature = "std")]
pub use checksum::HostCrc;
pub use checksum::{crc32c, CRC};
pub(crate) use checksum::{crc_byte, crc_byte_const, crc_ready, CRC_RESIDUE};
#[cfg(any(test, feature = "test-support"))]
pub(crate) use cobs::cobs_decode_nonzero;
#[cfg(any(test, feature = "test-support"))]
use cobs::cobs_decode_nonzero_to;
pub use cobs::{cobs_decode_in_place, cobs_encode};

/// Protocol version, the first byte of every decoded frame.
pub const VERSION: u8 = 3;

/// CRC length in bytes.
pub const CRC_LEN: usize = 4;

/// Largest `VERSION | postcard(Message)` (the [`crate::Status`] with every counter at
/// `u32::MAX` and every flag set: 1 + 1 + 30 * 5 + 1 + 1 + 3 = 157), rounded up so that
/// [`MAX_FRAME`] is a multiple of 4 (an odd size made the compiler clear the buffers
/// byte-wise: 208 B more flash, measured with `cargo fw`).
pub const MAX_RAW: usize = 158;

/// Largest COBS-encoded frame including the 0x00 delimiter:
/// `MAX_RAW + CRC_LEN` bytes need one COBS overhead byte per 254 (here 1).
pub const MAX_FRAME: usize = MAX_RAW + CRC_LEN + 1 + 1;

/// Shortest valid decoded frame: version, type, CRC.
pub const MIN_DECODED: usize = 1 + 1 + CRC_LEN;

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

/// Encodes `msg` as one wire frame, delimiter included, into `out`; returns its length.
///
/// Built in place: `VERSION | body | CRC` is written at `out[1..]`, one byte to the right
/// of its COBS encoding, so the encoding only writes the code bytes (at `out[0]` and at
/// each 0x00 of the raw frame): non-zero bytes are already where COBS puts them. The
/// output is identical to [`cobs_encode`] of the raw frame (tested against postcard +
/// the `cobs` crate).
pub fn encode(msg: &Message, out: &mut [u8]) -> Result<usize, EncodeError> {
    // postcard's bytes without serde (same bytes, see `fast`).
    encode_with(out, |body_area| crate::fast::encode_body(msg, body_area))
}

/// A message the device sends: what [`encode_reply`] takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Reply<'a> {
    /// [`Message::Actuation`], every tick.
    Actuation(&'a Actuation),
    /// [`Message::Status`], on request.
    Status(&'a Status),
}

/// The device's encoder: one frame of `reply`, delimiter included, into `out`; returns
/// its length. The same bytes as [`encode_vec`] of the message (tested), and
/// [`EncodeError::BufferTooSmall`] for every buffer shorter than the frame. Inlined, so
/// a call with a known variant links only that message's encoder (the device never
/// links the encoders of the messages it takes).
#[inline(always)]
pub fn encode_reply(reply: Reply<'_>, out: &mut [u8]) -> Result<usize, EncodeError> {
    match reply {
        Reply::Actuation(a) => encode_actuation(a, out),
        Reply::Status(s) => encode_status(s, out),
    }
}

/// The device's encoder for [`Message::Actuation`]: the frame of [`encode`] (tested, and
/// the same [`EncodeError::BufferTooSmall`] for every buffer shorter than the frame),
/// without the encoders of the messages the device never sends.
///
/// One pass (`OnePass`) when `out` holds the longest Actuation frame: each byte of
/// `VERSION | body | CRC` goes into the CRC register and into its COBS place as it is
/// produced, no second pass over the frame (`finish_frame`). Shorter buffers take the
/// general path (`encode_with`), whose length decisions are the reference. It trades
/// flash (the Actuation's fields written inline; `finish_frame` stays, for the Status)
/// for the device's per-tick instructions (`cargo xtask fw-bench`, `cargo fw`).
pub(crate) fn encode_actuation(a: &Actuation, out: &mut [u8]) -> Result<usize, EncodeError> {
    match out.first_chunk_mut::<ONE_PASS_CAP>() {
        Some(buf) => Ok(OnePass::<ONE_PASS_CAP>::actuation(a, buf)),
        None => encode_with(out, |body_area| crate::fast::encode_actuation(a, body_area)),
    }
}

/// The buffer of the device's one-pass Actuation writer (a `const` outside the `impl`:
/// array lengths in its signatures cannot name `Self`): a power of two, so that an index
/// is kept in bounds by a mask (one instruction) rather than a compare and branch per
/// byte. It is at least the longest Actuation frame (code byte, version, body of 1 + 2 +
/// 2 + 5 + 3 + 5 + 5 bytes, CRC, delimiter = 30 B), so the mask never changes an index.
const ONE_PASS_CAP: usize = 32;

/// The buffer of the host's one-pass Sensor writer ([`encode_sensor`]): a power of two
/// (indices masked, as in the device's Actuation writer), at least the longest Sensor
/// frame (code byte, version, body of 1 + 2 + 2 + 1 + 2 x 5 + 4 x 5 bytes, CRC,
/// delimiter = 43 B).
pub const SENSOR_FRAME_CAP: usize = 64;

/// The host's encoder for the Sensor frame it sends every period: the bytes of the
/// general encoder's frame of `Message::Sensor(*s)` (tested) written into `out` in one pass
/// (COBS and the CRC applied to each byte as it is produced, as the device's Actuation
/// encoder does); returns the frame's length. Every Sensor frame fits `out`.
pub fn encode_sensor(s: &Sensor, out: &mut [u8; SENSOR_FRAME_CAP]) -> usize {
    OnePass::<SENSOR_FRAME_CAP>::sensor(s, out)
}

/// A frame written in one pass: COBS and the CRC-32C applied to each raw byte as it is
/// produced. Raw byte `k` of `VERSION | body | CRC` lands at `buf[k + 1]` (COBS moves
/// nothing but writes a code byte for each 0x00): a 0x00 becomes a code-byte slot whose
/// value is written when the next 0x00 (or the frame's end) is reached, the distance
/// between the two (no per-block counter).
struct OnePass<'a, const CAP: usize> {
    buf: &'a mut [u8; CAP],
    /// Where the next raw byte goes.
    pos: usize,
    /// The slot of the open block's code byte.
    code_at: usize,
    /// The CRC register over the raw bytes so far (from `!0`, no final XOR).
    reg: u32,
}

impl<const CAP: usize> OnePass<'_, CAP> {
    /// The index mask; `CAP` is a power of two ([`ONE_PASS_CAP`]).
    const MASK: usize = {
        assert!(CAP.is_power_of_two());
        CAP - 1
    };

    /// A raw byte outside the CRC (the CRC's own bytes): stored, or a 0x00 closing the
    /// open block.
    #[inline(always)]
    fn put(&mut self, b: u8) {
        if b == 0 {
            self.buf[self.code_at & Self::MASK] = (self.pos - self.code_at) as u8;
            self.code_at = self.pos;
        } else {
            self.buf[self.pos & Self::MASK] = b;
        }
        self.pos += 1;
    }

    /// Any raw byte of the CRC'd part.
    #[inline(always)]
    fn byte(&mut self, b: u8) {
        self.reg = crc_byte(self.reg, b);
        self.put(b);
    }

    #[inline(always)]
    fn u16_le(&mut self, v: u16) {
        let [a, b] = v.to_le_bytes();
        self.byte(a);
        self.byte(b);
    }

    /// postcard's varint: every byte but the last has its top bit set (never 0x00).
    /// Inlined at each of the four fields: out of line (the writer's state through
    /// memory) the whole tick measured 1 665 instead of 1 568 instructions mean (`cargo
    /// xtask fw-bench`, M4 fixed point) for 120 B less flash.
    #[inline(always)]
    fn varint(&mut self, mut v: u32) {
        while v >= 0x80 {
            self.byte((v as u8) | 0x80);
            v >>= 7;
        }
        self.byte(v as u8);
    }

    #[inline(always)]
    fn i32(&mut self, v: i32) {
        self.varint(((v << 1) ^ (v >> 31)) as u32);
    }

    /// The CRC, the last code byte and the delimiter; returns the frame's length.
    #[inline(always)]
    fn finish(mut self) -> usize {
        // Unrolled: at opt-level `z` a `for` over the array stays two calls per byte
        // (`array::IntoIter::next`).
        let [c0, c1, c2, c3] = (!self.reg).to_le_bytes();
        self.put(c0);
        self.put(c1);
        self.put(c2);
        self.put(c3);
        self.buf[self.code_at & Self::MASK] = (self.pos - self.code_at) as u8;
        self.buf[self.pos & Self::MASK] = 0;
        self.pos + 1
    }
}

/// The Sensor frame's body through the shared layout ([`crate::fast::write_sensor`]):
/// every byte goes into the CRC and the COBS blocks as it comes.
impl<const CAP: usize> crate::fast::Bytes for OnePass<'_, CAP> {
    #[inline(always)]
    fn byte(&mut self, b: u8) -> Option<()> {
        OnePass::byte(self, b);
        Some(())
    }
}

impl OnePass<'_, ONE_PASS_CAP> {
    /// The frame of `encode(&Message::Actuation(*a), _)` in `buf`; its length.
    #[inline(never)]
    fn actuation(a: &Actuation, buf: &mut [u8; ONE_PASS_CAP]) -> usize {
        const { assert!(VERSION != 0 && crate::fast::ACTUATION != 0) };
        // The register after the version and type bytes, a constant.
        const PREFIX: u32 = crc_byte_const(crc_byte_const(!0, VERSION), crate::fast::ACTUATION);
        crc_ready();
        let mut w = OnePass {
            buf,
            pos: 1,
            code_at: 0,
            reg: PREFIX,
        };
        let Actuation {
            seq_echo,
            tick,
            exec,
            flags,
            t_psi_dnm,
            u_a_cv,
        } = *a;
        w.put(VERSION);
        w.put(crate::fast::ACTUATION);
        w.u16_le(seq_echo);
        w.u16_le(tick);
        w.varint(exec);
        w.varint(u32::from(flags.0));
        w.i32(t_psi_dnm);
        w.i32(u_a_cv);
        w.finish()
    }
}

impl OnePass<'_, SENSOR_FRAME_CAP> {
    /// The frame of `encode(&Message::Sensor(*s), _)` in `buf`; its length.
    #[inline(always)]
    fn sensor(s: &Sensor, buf: &mut [u8; SENSOR_FRAME_CAP]) -> usize {
        const { assert!(VERSION != 0) };
        // The register after the version byte (the type byte, 0, closes a COBS block).
        const PREFIX: u32 = crc_byte_const(!0, VERSION);
        crc_ready();
        let mut w = OnePass {
            buf,
            pos: 1,
            code_at: 0,
            reg: PREFIX,
        };
        w.put(VERSION);
        // The one-pass writer has room for every Sensor body: it never reports full.
        let _ = crate::fast::write_sensor(s, &mut w);
        w.finish()
    }
}

/// The device's encoder for [`Message::Status`]: the frame of [`encode`] (tested),
/// without the serialisers of the other messages.
pub(crate) fn encode_status(s: &Status, out: &mut [u8]) -> Result<usize, EncodeError> {
    encode_with(out, |body_area| crate::fast::encode_status(s, body_area))
}

/// The frame around a body: `write_body` writes the postcard body of the message (type
/// byte first) into the slice it gets and returns its length (`None`: it does not fit).
#[inline(always)]
fn encode_with(
    out: &mut [u8],
    write_body: impl FnOnce(&mut [u8]) -> Option<usize>,
) -> Result<usize, EncodeError> {
    let too_small = EncodeError::BufferTooSmall;
    // Raw byte k lives at out[k + 1]; the body is raw[1..MAX_RAW].
    let body_end = out.len().min(MAX_RAW + 1);
    let body_area = out.get_mut(2..body_end).ok_or(too_small)?;
    let body = write_body(body_area).ok_or(too_small)?;
    *out.get_mut(1).ok_or(too_small)? = VERSION;
    finish_frame(out, 1 + body)
}

/// The frame around the raw bytes `out[1..=n]` (version and body): their CRC after
/// them ([`crc32c`], the target's CRC), the COBS code bytes, the delimiter; returns the
/// frame's length. One copy for every message's encoder (the device's Actuation frames
/// take [`OnePass`] instead).
#[inline(never)]
fn finish_frame(out: &mut [u8], n: usize) -> Result<usize, EncodeError> {
    let too_small = EncodeError::BufferTooSmall;
    let with_crc = n + CRC_LEN;
    // The frame: code byte, raw bytes out[1..=n], CRC, delimiter.
    let frame = out.get_mut(..with_crc + 2).ok_or(too_small)?;
    let crc = crc32c(frame.get(1..=n).ok_or(too_small)?);
    frame
        .get_mut(n + 1..=with_crc)
        .ok_or(too_small)?
        .copy_from_slice(&crc.to_le_bytes());
    // The COBS code bytes over raw bytes and CRC (with_crc <= MAX_RAW + CRC_LEN < 254:
    // no 0xFF blocks, no overflow of `code`). (A plain `while` loop: at opt-level z the
    // range and array iterators stay calls.)
    let (mut code_idx, mut code) = (0usize, 1u8);
    let mut i = 1;
    while let Some(&b) = frame.get(i).filter(|_| i <= with_crc) {
        if b == 0 {
            if let Some(c) = frame.get_mut(code_idx) {
                *c = code;
            }
            code_idx = i;
            code = 1;
        } else {
            code += 1;
        }
        i += 1;
    }
    *frame.get_mut(code_idx).ok_or(too_small)? = code;
    *frame.get_mut(with_crc + 1).ok_or(too_small)? = 0;
    Ok(with_crc + 2)
}

/// The host's encoder: `msg` as one wire frame, delimiter included, in a fixed-capacity
/// vector (no allocation; every message fits [`MAX_FRAME`], tested). A Sensor frame is
/// [`encode_sensor`]'s, so the host builds every Sensor frame one way.
///
/// ```
/// use wheelset_proto::{encode_vec, Command, Message};
/// let frame = encode_vec(&Message::Command(Command::RequestStatus)).unwrap();
/// assert_eq!(frame.last(), Some(&0));
/// assert!(!frame[..frame.len() - 1].contains(&0));
/// ```
pub fn encode_vec(msg: &Message) -> Result<heapless::Vec<u8, MAX_FRAME>, EncodeError> {
    let vec =
        |frame: &[u8]| heapless::Vec::from_slice(frame).map_err(|_| EncodeError::BufferTooSmall);
    if let Message::Sensor(s) = msg {
        let mut buf = [0u8; SENSOR_FRAME_CAP];
        let n = encode_sensor(s, &mut buf);
        return vec(buf.get(..n).ok_or(EncodeError::BufferTooSmall)?);
    }
    let mut buf = [0u8; MAX_FRAME];
    let n = encode(msg, &mut buf)?;
    vec(buf.get(..n).ok_or(EncodeError::BufferTooSmall)?)
}

#[cfg(any(test, feature = "test-support"))]
/// Decodes one frame: the COBS bytes between two delimiters (no 0x00), decoded in place.
/// Never panics, whatever the bytes.
pub fn decode_frame(encoded: &mut [u8]) -> Result<Message, FrameError> {
    if encoded.len() + 1 > MAX_FRAME {
        return Err(FrameError::Length);
    }
    if encoded.contains(&0) {
        return Err(FrameError::Cobs);
    }
    decode_nonzero_frame(encoded)
}

#[cfg(any(test, feature = "test-support"))]
/// [`decode_frame`] of bytes known to hold no 0x00 (the [`crate::Decoder`]'s buffer).
pub fn decode_nonzero_frame(encoded: &mut [u8]) -> Result<Message, FrameError> {
    let msg = open_nonzero(encoded)?;
    // postcard's decisions without serde (see `fast`).
    crate::fast::decode_body(msg).map_err(FrameError::from)
}

#[cfg(any(test, feature = "test-support"))]
/// COBS-decodes in place (bytes known to hold no 0x00) and checks length, CRC and
/// version; returns the message bytes (type byte first).
#[inline(always)]
fn open_nonzero(encoded: &mut [u8]) -> Result<&[u8], FrameError> {
    if encoded.len() + 1 > MAX_FRAME {
        return Err(FrameError::Length);
    }
    let n = cobs_decode_nonzero(encoded).ok_or(FrameError::Cobs)?;
    check(encoded.get(..n).ok_or(FrameError::Cobs)?)
}

#[cfg(any(test, feature = "test-support"))]
/// Checks a COBS-decoded frame's length, CRC and version; returns the message bytes.
#[inline(always)]
fn check(frame: &[u8]) -> Result<&[u8], FrameError> {
    check_reg(frame, None)
}

/// [`check`], with the CRC register `reg` already run over all of `frame` (the
/// streaming decoder's), or `None` to compute the CRC here.
#[inline(always)]
fn check_reg(frame: &[u8], reg: Option<u32>) -> Result<&[u8], FrameError> {
    let n = frame.len();
    if n < MIN_DECODED {
        return Err(FrameError::Length);
    }
    let (body, crc) = frame.split_at(n - CRC_LEN);
    let ok = match reg {
        Some(reg) => reg == CRC_RESIDUE,
        None => {
            let mut crc_bytes = [0u8; CRC_LEN];
            crc_bytes.copy_from_slice(crc);
            crc32c(body) == u32::from_le_bytes(crc_bytes)
        }
    };
    if !ok {
        return Err(FrameError::Crc);
    }
    let (version, msg) = body.split_first().ok_or(FrameError::Length)?;
    if *version != VERSION {
        return Err(FrameError::Version);
    }
    Ok(msg)
}

impl From<crate::fast::BodyError> for FrameError {
    fn from(e: crate::fast::BodyError) -> Self {
        match e {
            crate::fast::BodyError::Trailing => FrameError::Length,
            crate::fast::BodyError::Postcard => FrameError::Postcard,
        }
    }
}

/// What the device takes from a frame: the host -> device messages. Frames of the
/// device -> host types ([`Message::Actuation`], [`Message::Status`]) are recognised by
/// their type byte and not decoded further ([`Request::Unexpected`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Request {
    /// [`Message::Sensor`].
    Sensor(Sensor),
    /// [`Message::Config`].
    Config(Config),
    /// [`Message::Command`].
    Command(Command),
    /// A frame with a valid CRC and version whose type is one the device sends, not
    /// takes (Actuation, Status); its body is not checked.
    Unexpected,
    /// A Command whose variant index, or a Config whose `mode` index, this version does
    /// not define (the body's leading varint, in any of its forms, at or above the
    /// defined count; the rest is not checked; a malformed varint is a decoding error):
    /// the device refuses it as an unknown request (`CMD_REFUSED`,
    /// [`crate::RefuseReason::UnknownRequest`]), not as a decoding error.
    Unknown,
}

#[cfg(any(test, feature = "test-support"))]
/// The device's decoder: [`decode_frame`] for the messages the device takes (the same
/// result, tested), [`Request::Unexpected`] for the others, without the decoders of the
/// messages the device never takes. Never panics, whatever the bytes.
pub fn decode_request(encoded: &mut [u8]) -> Result<Request, FrameError> {
    if encoded.len() + 1 > MAX_FRAME {
        return Err(FrameError::Length);
    }
    if encoded.contains(&0) {
        return Err(FrameError::Cobs);
    }
    decode_nonzero_request(encoded)
}

#[cfg(any(test, feature = "test-support"))]
/// [`decode_request`] of bytes known to hold no 0x00 (the [`crate::Decoder`]'s buffer).
/// (`encoded` is left as it was: the frame is decoded into a buffer of its own.)
pub fn decode_nonzero_request(encoded: &mut [u8]) -> Result<Request, FrameError> {
    if encoded.len() + 1 > MAX_FRAME {
        return Err(FrameError::Length);
    }
    let mut raw = [0u8; MAX_FRAME];
    let n = cobs_decode_nonzero_to(encoded, &mut raw).ok_or(FrameError::Cobs)?;
    request_from_raw(raw.get(..n).ok_or(FrameError::Cobs)?, None)
}

/// [`decode_nonzero_frame`] of a frame already COBS-decoded (the [`crate::Decoder`]
/// decodes COBS as the bytes arrive): length, CRC, version, then the message. Inlined
/// into the host's decoder ([`crate::Decoder::next_message`], `std`), the message
/// decoder with it: the message is built where the caller's result lives, not returned
/// through two calls and their copies.
#[cfg_attr(feature = "std", inline(always))]
pub(crate) fn message_from_raw(raw: &[u8], reg: Option<u32>) -> Result<Message, FrameError> {
    crate::fast::decode_body(check_reg(raw, reg)?).map_err(FrameError::from)
}

/// [`request_from_raw`], a Sensor frame written into `sensor` (`Ok(None)`) instead of
/// returned in a [`Request`]; the same decisions (one copy of the Sensor decoder and of
/// the others: [`request_body`]).
#[inline(always)]
pub(crate) fn sensor_or_request_from_raw(
    raw: &[u8],
    reg: Option<u32>,
    sensor: &mut Sensor,
) -> Result<Option<Request>, FrameError> {
    let msg = check_reg(raw, reg)?;
    let (ty, body) = crate::fast::message_type(msg).ok_or(FrameError::Postcard)?;
    if ty == crate::fast::SENSOR {
        *sensor = crate::fast::finish(body, crate::fast::sensor_inline)?;
        return Ok(None);
    }
    request_body(ty, body).map(Some)
}

#[cfg(any(test, feature = "test-support"))]
/// [`decode_nonzero_request`] of a frame already COBS-decoded: length, CRC, version,
/// then the request.
pub(crate) fn request_from_raw(raw: &[u8], reg: Option<u32>) -> Result<Request, FrameError> {
    let msg = check_reg(raw, reg)?;
    let (ty, body) = crate::fast::message_type(msg).ok_or(FrameError::Postcard)?;
    if ty == crate::fast::SENSOR {
        return Ok(Request::Sensor(crate::fast::finish(
            body,
            crate::fast::sensor,
        )?));
    }
    request_body(ty, body)
}

/// The request of a message of type `ty` other than Sensor, `body` the bytes after its
/// type (a Sensor's variant index has no undefined values: it is never
/// [`Request::Unknown`], so it is decoded before this).
#[inline(always)]
fn request_body(ty: u8, body: &[u8]) -> Result<Request, FrameError> {
    // postcard writes an enum as its variant index (a varint), then the variant.
    use crate::fast::{
        finish, leading_index, ACTUATION, COMMAND, COMMANDS, CONFIG, STATUS, YAW_MODES,
    };
    let defined = match ty {
        COMMAND => Some(COMMANDS),
        CONFIG => Some(YAW_MODES),
        _ => None,
    };
    if defined.is_some_and(|d| leading_index(body).is_some_and(|i| i >= d)) {
        return Ok(Request::Unknown);
    }
    Ok(match ty {
        CONFIG => Request::Config(finish(body, crate::fast::config)?),
        COMMAND => Request::Command(finish(body, crate::fast::command)?),
        ACTUATION | STATUS => Request::Unexpected,
        _ => return Err(FrameError::Postcard),
    })
}

/// Whether `b` holds a frame delimiter (0x00), the host's test of a frame's bytes:
/// eight bytes at a time (a word has a zero byte iff `(x - 0x01..01) & !x & 0x80..80`
/// is non-zero), the last word overlapping the one before it rather than a byte-wise
/// tail, and no call into `memchr`.
#[cfg(feature = "std")]
#[inline(always)]
#[must_use]
pub fn has_delimiter(b: &[u8]) -> bool {
    const LO: u64 = u64::from_ne_bytes([0x01; 8]);
    const HI: u64 = u64::from_ne_bytes([0x80; 8]);
    let zero_in = |w: &[u8; 8]| {
        let x = u64::from_ne_bytes(*w);
        x.wrapping_sub(LO) & !x & HI
    };
    let Some(last) = b.last_chunk::<8>() else {
        return b.contains(&0);
    };
    let mut acc = zero_in(last);
    let mut chunks = b.chunks_exact(8);
    for c in &mut chunks {
        if let Some(w) = c.first_chunk::<8>() {
            acc |= zero_in(w);
        }
    }
    acc != 0
}

#[cfg(all(test, feature = "std"))]
mod tests {
    /// Against the byte-wise test, for every length up to three words and a 0x00 at
    /// every position (the overlapping last word included).
    #[test]
    fn has_delimiter_finds_a_zero_at_every_position() {
        for n in 0..=24 {
            let mut b = std::vec![0xA5u8; n];
            assert!(!super::has_delimiter(&b), "len {n}");
            for i in 0..n {
                b[i] = 0;
                assert!(super::has_delimiter(&b), "len {n}, zero at {i}");
                b[i] = 0x80;
                assert!(!super::has_delimiter(&b), "len {n}, 0x80 at {i}");
                b[i] = 0xA5;
            }
        }
    }
}
