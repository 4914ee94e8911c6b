//! Framing: `COBS( VERSION | postcard(Message) | CRC-32C LE ) 0x00`.
//!
//! The CRC covers the version byte and the postcard bytes. Decoding checks, in order:
//! COBS structure, length, CRC, version, postcard, no trailing bytes; the first failure is
//! the [`FrameError`].

use crate::message::{Actuation, Command, Config, Message, Sensor, Status};

/// Protocol version, the first byte of every decoded frame.
pub const VERSION: u8 = 2;

/// The frame CRC: CRC-32C (Castagnoli, `crc::CRC_32_ISCSI`), stored little-endian.
///
/// Why 32 bits: a 1- or 2-bit flip inside COBS data bytes is a 1- or 2-bit error of the
/// payload, which any CRC with Hamming distance >= 3 rejects (CRC-16/CCITT: HD 4 up to
/// 32 751 bits). But a flip in a COBS code byte, or one that creates or destroys a 0x00
/// delimiter, moves zeros around or splits/merges frames: the decoded payload then differs
/// in many bits, and a CRC rejects it only with probability `1 - 2^-n`.
///
/// Measured (`cargo test -p wheelset-proto --test flips -- --nocapture`): of the 2.44 M
/// one- and two-bit corruptions of 120 random Sensor/Actuation frames, 51 446 (2.1 %)
/// reach the CRC with a scrambled payload. At BER 1e-3 a 23-byte frame takes a structural
/// hit with probability ~4e-3; with 16 bits `4e-3 * 2^-16` ~ 6e-8 per frame pass the CRC
/// (before the version and exact-length checks), i.e. at 2 x 2000 frames/s an undetected,
/// wrong torque command every ~70 min. CRC-32C makes it `2^-32` (~9 years of continuous
/// BER 1e-3, before the version and length checks) for two more
/// bytes per frame. Castagnoli's polynomial keeps Hamming distance 6 at these lengths.
///
/// The table: slice-by-16 (16 KiB) with the `std` feature on the host, where the
/// simulated loop encodes and decodes four frames per period; byte-wise (1 KiB) on the
/// device, built in RAM on first use ([`crate::RamCrc`]: no flash for the table). Same
/// polynomial, same checksums (tested).
#[cfg(feature = "std")]
pub static CRC: crc::Crc<u32, crc::Table<16>> =
    crc::Crc::<u32, crc::Table<16>>::new(&crc::CRC_32_ISCSI);
/// See the `std` variant.
#[cfg(not(feature = "std"))]
pub static CRC: crate::RamCrc = crate::RamCrc::new();

/// The frame CRC of `bytes`: CRC-32C, the same value as [`CRC`]`.checksum(bytes)`
/// (tested). On the host (`std`) a slice-by-16 over compile-time tables specialised to
/// CRC-32C (reflected, init and xor-out `0xFFFF_FFFF`): ~85 instructions per ~20-byte
/// frame (callgrind). The `crc` crate's generic version reads the algorithm's parameters
/// at run time and measured 92 in one build and 156 in another (inlining), four calls per
/// exchange in the closed loop. On the device: the byte-wise table in RAM
/// ([`crate::RamCrc`]).
#[must_use]
pub fn crc32c(bytes: &[u8]) -> u32 {
    #[cfg(feature = "std")]
    {
        slice16(bytes)
    }
    #[cfg(not(feature = "std"))]
    {
        CRC.checksum(bytes)
    }
}

/// `TABLES[k][b]`: the CRC-32C register contribution of byte `b` followed by `k` zero
/// bytes (reflected polynomial `0x82F6_3B78`). (Compiled without `std` too, so the
/// crate's own tests check it; unused there, the linker drops it.)
static TABLES: [[u32; 256]; 16] = crc_tables();

const fn crc_tables() -> [[u32; 256]; 16] {
    let mut t = [[0u32; 256]; 16];
    let mut i = 0;
    while i < 256 {
        let mut c = i as u32;
        let mut k = 0;
        while k < 8 {
            c = if c & 1 != 0 {
                (c >> 1) ^ 0x82F6_3B78
            } else {
                c >> 1
            };
            k += 1;
        }
        t[0][i] = c;
        i += 1;
    }
    let mut k = 1;
    while k < 16 {
        let mut i = 0;
        while i < 256 {
            let prev = t[k - 1][i];
            t[k][i] = (prev >> 8) ^ t[0][(prev & 0xFF) as usize];
            i += 1;
        }
        k += 1;
    }
    t
}

#[cfg_attr(not(feature = "std"), allow(dead_code))]
fn slice16(bytes: &[u8]) -> u32 {
    let t = &TABLES;
    let mut crc = !0u32;
    let mut chunks = bytes.chunks_exact(16);
    for c in &mut chunks {
        let mut w = [0u8; 16];
        w.copy_from_slice(c);
        let [a0, a1, a2, a3] = (u32::from_le_bytes([w[0], w[1], w[2], w[3]]) ^ crc).to_le_bytes();
        crc = t[15][usize::from(a0)]
            ^ t[14][usize::from(a1)]
            ^ t[13][usize::from(a2)]
            ^ t[12][usize::from(a3)]
            ^ t[11][usize::from(w[4])]
            ^ t[10][usize::from(w[5])]
            ^ t[9][usize::from(w[6])]
            ^ t[8][usize::from(w[7])]
            ^ t[7][usize::from(w[8])]
            ^ t[6][usize::from(w[9])]
            ^ t[5][usize::from(w[10])]
            ^ t[4][usize::from(w[11])]
            ^ t[3][usize::from(w[12])]
            ^ t[2][usize::from(w[13])]
            ^ t[1][usize::from(w[14])]
            ^ t[0][usize::from(w[15])];
    }
    // The 0..15 bytes left: slices of 8, 4 and then 1..3 bytes, each step's table
    // look-ups independent of each other (a byte-at-a-time tail is a chain of dependent
    // loads: with ~20-byte frames it took most of the CRC's time, `perf`).
    let mut rest = chunks.remainder();
    if let Some((c, r)) = rest.split_first_chunk::<8>() {
        let [a0, a1, a2, a3] = (u32::from_le_bytes([c[0], c[1], c[2], c[3]]) ^ crc).to_le_bytes();
        crc = t[7][usize::from(a0)]
            ^ t[6][usize::from(a1)]
            ^ t[5][usize::from(a2)]
            ^ t[4][usize::from(a3)]
            ^ t[3][usize::from(c[4])]
            ^ t[2][usize::from(c[5])]
            ^ t[1][usize::from(c[6])]
            ^ t[0][usize::from(c[7])];
        rest = r;
    }
    if let Some((c, r)) = rest.split_first_chunk::<4>() {
        let [a0, a1, a2, a3] = (u32::from_le_bytes(*c) ^ crc).to_le_bytes();
        crc = t[3][usize::from(a0)]
            ^ t[2][usize::from(a1)]
            ^ t[1][usize::from(a2)]
            ^ t[0][usize::from(a3)];
        rest = r;
    }
    // k = 1..3 bytes: crc' = (crc >> 8k) ^ sum over j of t[k-1-j][byte j of (crc ^ bytes)].
    match *rest {
        [b0] => crc = (crc >> 8) ^ t[0][usize::from((crc as u8) ^ b0)],
        [b0, b1] => {
            let [a0, a1, _, _] = crc.to_le_bytes();
            crc = (crc >> 16) ^ t[1][usize::from(a0 ^ b0)] ^ t[0][usize::from(a1 ^ b1)];
        }
        [b0, b1, b2] => {
            let [a0, a1, a2, _] = crc.to_le_bytes();
            crc = (crc >> 24)
                ^ t[2][usize::from(a0 ^ b0)]
                ^ t[1][usize::from(a1 ^ b1)]
                ^ t[0][usize::from(a2 ^ b2)];
        }
        _ => {}
    }
    !crc
}

/// CRC length in bytes.
pub const CRC_LEN: usize = 4;

/// Largest `VERSION | postcard(Message)` (the [`crate::Status`] with every counter at
/// `u32::MAX` and every flag set: 1 + 1 + 28 * 5 + 1 + 1 + 3 = 147), rounded up so that
/// [`MAX_FRAME`] is a multiple of 4 (an odd size made the compiler clear the buffers
/// byte-wise: 208 B more flash, measured with `cargo fw`).
pub const MAX_RAW: usize = 150;

/// Largest COBS-encoded frame including the 0x00 delimiter:
/// `MAX_RAW + CRC_LEN` bytes need one COBS overhead byte per 254 (here 1).
pub const MAX_FRAME: usize = MAX_RAW + CRC_LEN + 1 + 1;

/// Shortest valid decoded frame: version, type, CRC.
pub const MIN_DECODED: usize = 1 + 1 + CRC_LEN;

/// Why a frame was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
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
/// ```
/// use wheelset_proto::{encode, Command, Message, MAX_FRAME};
/// let mut buf = [0u8; MAX_FRAME];
/// let n = encode(&Message::Command(Command::RequestStatus), &mut buf).unwrap();
/// assert_eq!(buf[n - 1], 0);
/// assert!(!buf[..n - 1].contains(&0));
/// ```
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

/// The device's encoder for [`Message::Actuation`]: the frame of [`encode`] (tested),
/// without the encoders of the messages the device never sends.
pub fn encode_actuation(a: &Actuation, out: &mut [u8]) -> Result<usize, EncodeError> {
    encode_with(out, |body_area| crate::fast::encode_actuation(a, body_area))
}

/// The device's encoder for [`Message::Status`]: the frame of [`encode`] (tested),
/// without the serialisers of the other messages.
pub fn encode_status(s: &Status, out: &mut [u8]) -> Result<usize, EncodeError> {
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
/// them, the COBS code bytes, the delimiter; returns the frame's length. One copy for
/// every message's encoder.
#[inline(never)]
fn finish_frame(out: &mut [u8], n: usize) -> Result<usize, EncodeError> {
    let too_small = EncodeError::BufferTooSmall;
    let with_crc = n + CRC_LEN;
    // The frame: code byte, raw bytes out[1..=n], CRC, delimiter.
    let frame = out.get_mut(..with_crc + 2).ok_or(too_small)?;
    // One pass over the raw bytes: the CRC register and the COBS code bytes together
    // (with_crc <= MAX_RAW + CRC_LEN < 254: no 0xFF blocks, no overflow of `code`).
    // (Plain `while` loops: at opt-level z the range and array iterators stay calls.)
    crc_ready();
    let (mut reg, mut code_idx, mut code) = (!0u32, 0usize, 1u8);
    let mut i = 1;
    while let Some(&b) = frame.get(i).filter(|_| i <= n) {
        reg = crc_byte(reg, b);
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
    // The CRC, little-endian, then its COBS codes.
    frame
        .get_mut(n + 1..=with_crc)
        .ok_or(too_small)?
        .copy_from_slice(&(!reg).to_le_bytes());
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

/// COBS-encodes `src` into `dst` (no delimiter); returns the encoded length, or None if
/// `dst` is too short. Output identical to `cobs::try_encode` (tested against it).
///
/// Frames shorter than 254 bytes (all of ours: at most [`MAX_RAW`] + [`CRC_LEN`] = 100)
/// need no 0xFF blocks, and take a single pass at about 5 instructions per byte; the
/// `cobs` crate's general streaming encoder measured about 24 per byte (callgrind), the
/// largest single cost of the host's closed loop. Longer inputs go to the crate.
pub fn cobs_encode(src: &[u8], dst: &mut [u8]) -> Option<usize> {
    if src.is_empty() {
        return Some(0);
    }
    if src.len() >= 254 {
        return cobs::try_encode(src, dst).ok();
    }
    let out = dst.get_mut(..=src.len())?;
    let (mut code_idx, mut code) = (0usize, 1u8);
    for (i, &b) in src.iter().enumerate() {
        if b == 0 {
            *out.get_mut(code_idx)? = code;
            code_idx = i + 1;
            code = 1;
        } else {
            *out.get_mut(i + 1)? = b;
            code += 1;
        }
    }
    *out.get_mut(code_idx)? = code;
    Some(src.len() + 1)
}

/// COBS-decodes a whole frame (the bytes between two delimiters, no 0x00) in place;
/// returns the decoded length, or None if `buf` is empty, contains a 0x00, or a code
/// byte points past its end. Accepts and rejects exactly what
/// `cobs::decode_in_place_report` does with `src_used == buf.len()` (tested against it),
/// with a scan for 0x00 and one block copy per code byte: the crate's general decoder
/// (bounds-checked byte by byte) measured about 20 instructions per byte (callgrind),
/// the largest single cost of decoding a frame in the host's closed loop.
pub fn cobs_decode_in_place(buf: &mut [u8]) -> Option<usize> {
    // A 0x00 anywhere ends the crate's frame early: `src_used` would fall short.
    if buf.contains(&0) {
        return None;
    }
    cobs_decode_nonzero(buf)
}

/// [`cobs_decode_in_place`] of bytes known to hold no 0x00 (the [`crate::Decoder`]'s
/// buffer: it splits at every delimiter), without scanning for one.
pub(crate) fn cobs_decode_nonzero(buf: &mut [u8]) -> Option<usize> {
    if buf.is_empty() {
        return None;
    }
    let end = buf.len();
    let (mut src, mut dst) = (0usize, 0usize);
    while let Some(&code) = buf.get(src) {
        let code = usize::from(code);
        // The block's `code - 1` data bytes must lie within (a 0x00 code, impossible
        // here, would not advance: refused).
        let next = src + code;
        if code == 0 || next > end {
            return None;
        }
        if code > 1 {
            // In range (checked above); `dst <= src`, so the move is within `buf`.
            buf.copy_within(src + 1..next, dst);
        }
        src = next;
        dst += code - 1;
        if code != 0xFF && src < end {
            *buf.get_mut(dst)? = 0;
            dst += 1;
        }
    }
    Some(dst)
}

/// Encodes into a fixed-capacity vector (convenience for callers that keep frames).
pub fn encode_vec(msg: &Message) -> Result<heapless::Vec<u8, MAX_FRAME>, EncodeError> {
    let mut buf = [0u8; MAX_FRAME];
    let n = encode(msg, &mut buf)?;
    heapless::Vec::from_slice(buf.get(..n).ok_or(EncodeError::BufferTooSmall)?)
        .map_err(|_| EncodeError::BufferTooSmall)
}

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

/// [`decode_frame`] of bytes known to hold no 0x00 (the [`crate::Decoder`]'s buffer).
pub(crate) fn decode_nonzero_frame(encoded: &mut [u8]) -> Result<Message, FrameError> {
    let msg = open_nonzero(encoded)?;
    // postcard's decisions without serde (see `fast`).
    crate::fast::decode_body(msg).map_err(FrameError::from)
}

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

/// Checks a COBS-decoded frame's length, CRC and version; returns the message bytes.
#[inline(always)]
fn check(frame: &[u8]) -> Result<&[u8], FrameError> {
    check_reg(frame, None)
}

/// The CRC-32C register (reflected, before the final XOR) after a frame's bytes
/// followed by their own CRC, little-endian: the same for every frame (the CRC's
/// residue), so a receiver that runs the register over all the decoded bytes, CRC
/// included, checks the CRC with one compare.
pub(crate) const CRC_RESIDUE: u32 = 0xB798_B438;

/// One byte into the CRC-32C register (reflected, no final XOR: start from `!0`,
/// compare with [`CRC_RESIDUE`]). Call [`crc_ready`] once before a run of these.
#[inline(always)]
pub(crate) fn crc_byte(reg: u32, b: u8) -> u32 {
    #[cfg(feature = "std")]
    {
        TABLES[0][usize::from((reg as u8) ^ b)] ^ (reg >> 8)
    }
    #[cfg(not(feature = "std"))]
    {
        CRC.step(reg, b)
    }
}

/// Makes [`crc_byte`]'s table ready (the device's RAM table is filled on first use).
#[inline(always)]
pub(crate) fn crc_ready() {
    #[cfg(not(feature = "std"))]
    CRC.ensure();
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

/// [`cobs_decode_nonzero`] from `src` into another buffer `dst` (at least as long):
/// the same accept/reject decisions and output (tested through [`decode_request`]),
/// with block copies between distinct buffers (`memcpy`) instead of moves within one
/// (`memmove`, 1.5 KiB of library code the device has no other use for).
fn cobs_decode_nonzero_to(src: &[u8], dst: &mut [u8]) -> Option<usize> {
    if src.is_empty() {
        return None;
    }
    let end = src.len();
    let (mut s, mut d) = (0usize, 0usize);
    while let Some(&code) = src.get(s) {
        let code = usize::from(code);
        let next = s + code;
        if code == 0 || next > end {
            return None;
        }
        if code > 1 {
            dst.get_mut(d..d + code - 1)?
                .copy_from_slice(src.get(s + 1..next)?);
        }
        s = next;
        d += code - 1;
        if code != 0xFF && s < end {
            *dst.get_mut(d)? = 0;
            d += 1;
        }
    }
    Some(d)
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
    /// not define (the leading byte of the body, below 0x80; the rest is not checked; a
    /// multi-byte index is a decoding error like any other malformed varint): the device
    /// refuses it as an unknown request (`CMD_REFUSED`,
    /// [`crate::RefuseReason::UnknownRequest`]), not as a decoding error.
    Unknown,
}

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

/// [`decode_request`] of bytes known to hold no 0x00 (the [`crate::Decoder`]'s buffer).
/// (`encoded` is left as it was: the frame is decoded into a buffer of its own.)
pub(crate) fn decode_nonzero_request(encoded: &mut [u8]) -> Result<Request, FrameError> {
    if encoded.len() + 1 > MAX_FRAME {
        return Err(FrameError::Length);
    }
    let mut raw = [0u8; MAX_FRAME];
    let n = cobs_decode_nonzero_to(encoded, &mut raw).ok_or(FrameError::Cobs)?;
    request_from_raw(raw.get(..n).ok_or(FrameError::Cobs)?, None)
}

/// [`decode_nonzero_frame`] of a frame already COBS-decoded (the [`crate::Decoder`]
/// decodes COBS as the bytes arrive): length, CRC, version, then the message.
pub(crate) fn message_from_raw(raw: &[u8], reg: Option<u32>) -> Result<Message, FrameError> {
    crate::fast::decode_body(check_reg(raw, reg)?).map_err(FrameError::from)
}

/// [`decode_nonzero_request`] of a frame already COBS-decoded: length, CRC, version,
/// then the request.
pub(crate) fn request_from_raw(raw: &[u8], reg: Option<u32>) -> Result<Request, FrameError> {
    let msg = check_reg(raw, reg)?;
    // postcard writes an enum as its variant index (a varint), then the variant.
    use crate::fast::{
        finish, leading_index, message_type, ACTUATION, COMMAND, COMMANDS, CONFIG, SENSOR, STATUS,
        YAW_MODES,
    };
    let (ty, body) = message_type(msg).ok_or(FrameError::Postcard)?;
    let defined = match ty {
        COMMAND => COMMANDS,
        CONFIG => YAW_MODES,
        _ => u32::MAX,
    };
    if leading_index(body).is_some_and(|i| i >= defined) {
        return Ok(Request::Unknown);
    }
    Ok(match ty {
        SENSOR => Request::Sensor(finish(body, crate::fast::sensor)?),
        CONFIG => Request::Config(finish(body, crate::fast::config)?),
        COMMAND => Request::Command(finish(body, crate::fast::command)?),
        ACTUATION | STATUS => Request::Unexpected,
        _ => return Err(FrameError::Postcard),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slice16_is_crc32c_at_every_length() {
        // Every tail (0..15 bytes after the 16-byte blocks) and offset, pseudo-random data.
        let mut x = 0x1234_5678u32;
        let mut data = [0u8; 300];
        for d in &mut data {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            *d = x as u8;
        }
        let reference = crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISCSI);
        for start in 0..20 {
            for len in 0..=120 {
                let d = &data[start..start + len];
                assert_eq!(
                    slice16(d),
                    reference.checksum(d),
                    "offset {start}, {len} bytes"
                );
            }
        }
        assert_eq!(slice16(b"123456789"), 0xE306_9283);
    }
}
