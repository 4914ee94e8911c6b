//! The streaming frame accumulator: bytes in any chunking, frames out.

#[cfg(any(test, feature = "test-support"))]
use crate::frame::request_from_raw;
use crate::frame::{
    crc_byte, crc_ready, message_from_raw, sensor_or_request_from_raw, FrameError, Request,
    MAX_FRAME,
};
use crate::message::{Message, Sensor};

/// What [`Decoder::next_sensor_or_request`] closed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum NextFrame {
    /// No frame closed (no delimiter in the bytes, or an empty frame).
    Nothing,
    /// A valid Sensor frame, written into the caller's [`Sensor`].
    Sensor,
    /// Any other frame: its result written into the caller's
    /// `Result<Request, FrameError>`.
    Frame,
}

/// Collects bytes up to each 0x00 delimiter in a fixed buffer and decodes the frame.
///
/// - Empty frames (repeated delimiters) are skipped silently: a sender may put a 0x00
///   before a frame to resynchronise the receiver.
/// - A frame longer than [`MAX_FRAME`] is discarded up to the next delimiter and
///   reported once as [`FrameError::Length`]: the decoder resynchronises on 0x00.
/// - Never panics, never allocates; `N` bounds the memory (default [`MAX_FRAME`]).
///
/// The device takes its requests with [`Self::next_sensor_or_request`], the host its
/// replies with [`Self::next_message`]; both take any chunk of bytes and return the bytes
/// after the frame they closed.
///
/// ```
/// use wheelset_proto::{encode_vec, Command, Decoder, Message};
/// let frame = encode_vec(&Message::Command(Command::ResetCounters)).unwrap();
/// let mut dec: Decoder = Decoder::new();
/// let (first, rest) = dec.next_message(&frame[..5]);
/// assert_eq!((first, rest.len()), (None, 0));
/// let (got, rest) = dec.next_message(&frame[5..]);
/// assert_eq!(got, Some(Ok(Message::Command(Command::ResetCounters))));
/// assert!(rest.is_empty());
/// ```
#[derive(Debug, Clone)]
pub struct Decoder<const N: usize = MAX_FRAME> {
    /// The frame in progress, COBS-decoded as its bytes arrive (one pass, no copy of
    /// the encoded bytes and no zeroing per frame).
    raw: [u8; N],
    /// Decoded bytes in `raw`.
    n: usize,
    /// Encoded bytes of the frame in progress (saturating).
    enc: usize,
    /// Data bytes the current COBS block still owes.
    left: u8,
    /// The current block ends in an implied 0x00 (its code byte is not 0xFF): written
    /// when the next block's code byte arrives.
    zero: bool,
    /// The CRC-32C register over the decoded bytes so far (from `!0`, no final XOR):
    /// the frame's CRC check is one compare at its end (`frame::CRC_RESIDUE`), no
    /// second pass over the bytes.
    crc: u32,
}

impl<const N: usize> Default for Decoder<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Decoder<N> {
    /// Longest frame (encoded, delimiter excluded) that is decoded: the buffer's `N`,
    /// and at most `MAX_FRAME - 1`. Longer ones are [`FrameError::Length`].
    const LIMIT: usize = if N < MAX_FRAME - 1 { N } else { MAX_FRAME - 1 };

    /// An empty decoder, waiting for the first byte of a frame.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            raw: [0; N],
            n: 0,
            enc: 0,
            left: 0,
            zero: false,
            crc: !0,
        }
    }

    /// Discards any partial frame.
    pub fn reset(&mut self) {
        self.n = 0;
        self.enc = 0;
        self.left = 0;
        self.zero = false;
        self.crc = !0;
    }

    /// Bytes of the frame in progress (at most `N`).
    #[must_use]
    pub fn pending(&self) -> usize {
        self.enc.min(N)
    }

    #[cfg(any(test, feature = "test-support"))]
    /// Takes one byte; returns a result when the byte closed a non-empty frame.
    pub fn push(&mut self, byte: u8) -> Option<Result<Message, FrameError>> {
        if byte == 0 {
            self.close(message_from_raw)
        } else {
            self.step(byte);
            None
        }
    }

    #[cfg(any(test, feature = "test-support"))]
    /// Takes a chunk of bytes, calling `f` for every frame closed in it. Same results as
    /// [`Self::push`] byte by byte.
    pub fn feed(&mut self, bytes: &[u8], mut f: impl FnMut(Result<Message, FrameError>)) {
        let mut rest = bytes;
        while !rest.is_empty() {
            let (r, more) = self.next_with(rest, message_from_raw);
            rest = more;
            if let Some(r) = r {
                f(r);
            }
        }
    }

    /// The host's decoder. Takes `bytes` up to and including the first delimiter: returns
    /// the frame's result if that closed one and the bytes not yet taken. A caller loops
    /// until the rest is empty, and may use its own state between frames (the bytes each
    /// frame took on the wire, say). The result does not depend on how the bytes were cut
    /// into chunks (tested: `tests/stream.rs`).
    pub fn next_message<'b>(
        &mut self,
        bytes: &'b [u8],
    ) -> (Option<Result<Message, FrameError>>, &'b [u8]) {
        self.next_with(bytes, message_from_raw)
    }

    #[cfg(any(test, feature = "test-support"))]
    /// [`Self::feed`] for the device: frames decoded as by [`crate::decode_request`] (the
    /// messages the device takes; the others recognised by their type only).
    pub fn feed_requests(&mut self, bytes: &[u8], mut f: impl FnMut(Result<Request, FrameError>)) {
        let mut rest = bytes;
        while !rest.is_empty() {
            let (r, more) = self.next_with(rest, request_from_raw);
            rest = more;
            if let Some(r) = r {
                f(r);
            }
        }
    }

    #[cfg(any(test, feature = "test-support"))]
    /// Takes `bytes` up to and including the first delimiter: returns the frame's result
    /// if that closed one (as [`Self::feed_requests`] would report it) and the bytes not
    /// yet taken. A caller loops until the rest is empty; unlike the callback form, it
    /// may use its own state (the one that owns the decoder) between frames.
    #[inline(never)]
    pub fn next_request<'b>(
        &mut self,
        bytes: &'b [u8],
    ) -> (Option<Result<Request, FrameError>>, &'b [u8]) {
        self.next_with(bytes, request_from_raw)
    }

    /// The device's decoder. Takes `bytes` up to and including the first delimiter, as
    /// [`Self::next_message`] does, and decodes only the messages the device takes: a
    /// valid Sensor frame (the one frame of every period) is written into `sensor`
    /// ([`NextFrame::Sensor`]), every other frame's result into `frame`
    /// ([`NextFrame::Frame`]: a [`Request`], the device -> host types recognised by their
    /// type byte only). The same accept/reject decisions as [`Self::next_message`]
    /// (tested on arbitrary byte strings). Nothing Config-sized is returned: a
    /// `Result<Request, _>` (a Config's size) returned by value is copied on its way to
    /// the caller, on every tick; written in place, the per-tick Sensor frame costs no
    /// copy.
    #[inline(never)]
    pub fn next_sensor_or_request<'b>(
        &mut self,
        bytes: &'b [u8],
        sensor: &mut Sensor,
        frame: &mut Result<Request, FrameError>,
    ) -> (NextFrame, &'b [u8]) {
        let (r, rest) = self.next_with(bytes, |raw, reg| {
            sensor_or_request_from_raw(raw, reg, sensor).map(|r| match r {
                None => true,
                Some(req) => {
                    *frame = Ok(req);
                    false
                }
            })
        });
        let next = match r {
            None => NextFrame::Nothing,
            Some(Ok(true)) => NextFrame::Sensor,
            Some(Ok(false)) => NextFrame::Frame,
            Some(Err(e)) => {
                *frame = Err(e);
                NextFrame::Frame
            }
        };
        (next, rest)
    }

    #[cfg(any(test, feature = "test-support"))]
    /// One non-zero byte of the frame in progress: COBS-decoded on the spot. A code byte
    /// writes the previous block's implied 0x00 (unless that block's code was 0xFF) and
    /// opens a block of `code - 1` data bytes; a data byte is stored. (Decoded bytes never
    /// outnumber encoded ones, so within [`Self::LIMIT`] they always fit in `raw`; beyond
    /// it the frame is a length error and its bytes are dropped.)
    #[inline(always)]
    fn step(&mut self, b: u8) {
        self.enc = self.enc.saturating_add(1);
        let byte = if self.left == 0 {
            let zero = core::mem::replace(&mut self.zero, b != 0xFF);
            self.left = b - 1;
            if !zero {
                return;
            }
            0
        } else {
            self.left -= 1;
            b
        };
        if let Some(slot) = self.raw.get_mut(self.n) {
            *slot = byte;
            self.n += 1;
            crc_ready();
            self.crc = crc_byte(self.crc, byte);
        }
    }

    /// The delimiter: the frame's result (`None` for an empty frame), decisions in the
    /// order of [`crate::decode_frame`]: length, COBS (a block cut short by the
    /// delimiter), then `decode` (length, CRC, version, message).
    #[inline(always)]
    fn close<M>(
        &mut self,
        decode: impl FnOnce(&[u8], Option<u32>) -> Result<M, FrameError>,
    ) -> Option<Result<M, FrameError>> {
        if self.enc == 0 {
            return None;
        }
        let r = if self.enc > Self::LIMIT {
            Err(FrameError::Length)
        } else if self.left != 0 {
            Err(FrameError::Cobs)
        } else {
            decode(self.raw.get(..self.n).unwrap_or(&[]), Some(self.crc))
        };
        self.reset();
        Some(r)
    }

    /// The fast path of [`Self::next_with`] at the start of a frame: the whole frame, up
    /// to its 0x00, is in `bytes` (on the device it always is), within [`Self::LIMIT`],
    /// and its COBS is well formed. Walks the COBS blocks: each code byte once (the
    /// previous block's implied 0x00), then the block's data bytes in a loop of their own
    /// (copy, CRC, the delimiter test) without the per-byte block-state test of the
    /// general loop. Writes the decoded bytes into `raw` and returns the decoded length,
    /// the CRC register and the encoded length (the delimiter's index); `None` for
    /// anything else (no delimiter in reach, a block cut short by a 0x00): the general
    /// loop then takes the same bytes from the same state (nothing in `self` but `raw`'s
    /// unused bytes has changed), so every decision stays its (tested: `tests/stream.rs`,
    /// chunkings). Slice iteration over each block, not indices: the compiler then keeps
    /// the CRC table's address and the counts in registers across the blocks.
    #[cfg(not(feature = "std"))]
    #[inline(always)]
    fn whole_frame(&mut self, bytes: &[u8]) -> Option<(usize, u32, usize)> {
        let w = bytes.get(..bytes.len().min(Self::LIMIT + 1))?;
        let (mut p, mut n, mut crc, mut zero) = (0usize, 0usize, !0u32, false);
        loop {
            let c = *w.get(p)?;
            if c == 0 {
                return Some((n, crc, p));
            }
            if zero {
                *self.raw.get_mut(n)? = 0;
                n += 1;
                crc = crc_byte(crc, 0);
            }
            let src = w.get(p + 1..p + usize::from(c))?;
            let dst = self.raw.get_mut(n..n + src.len())?;
            for (d, &b) in dst.iter_mut().zip(src) {
                if b == 0 {
                    return None;
                }
                *d = b;
                crc = crc_byte(crc, b);
            }
            n += src.len();
            p += usize::from(c);
            zero = c != 0xFF;
        }
    }

    /// The host's [`Self::whole_frame`] (the `std` build): the same frames taken, the
    /// same results, in bulk rather than byte by byte. The code bytes lead from the first
    /// byte to the delimiter (a 0x00 reached by them, with no 0x00 before it: one
    /// word-wise scan); then the decoded bytes are the encoded ones after the first code
    /// byte, each later code byte standing for its block's implied 0x00 (no block of a
    /// frame within [`Self::LIMIT`] is a 0xFF block, whose code byte stands for
    /// nothing: one takes the general loop), copied at once; the CRC register is run over
    /// them by the host's slice-by-16 CRC rather than a chain of byte-wise look-ups.
    #[cfg(feature = "std")]
    #[inline(always)]
    fn whole_frame(&mut self, bytes: &[u8]) -> Option<(usize, u32, usize)> {
        let w = bytes.get(..bytes.len().min(Self::LIMIT + 1))?;
        let mut z = 0usize;
        loop {
            match *w.get(z)? {
                0 => break,
                0xFF => return None,
                c => z += usize::from(c),
            }
        }
        let Some((&first, data)) = w.get(..z)?.split_first() else {
            // An empty frame (a lone delimiter).
            return Some((0, !0, 0));
        };
        if crate::frame::has_delimiter(data) {
            return None;
        }
        let n = data.len();
        let raw = self.raw.get_mut(..n)?;
        raw.copy_from_slice(data);
        // Encoded index q is decoded index q - 1: each later code byte is a 0x00.
        let mut q = usize::from(first);
        while q < z {
            let slot = raw.get_mut(q - 1)?;
            q += usize::from(*slot);
            *slot = 0;
        }
        Some((n, !crate::frame::crc32c(raw), z))
    }

    /// The bytes up to and including the next delimiter (or all of them): a whole frame
    /// at the start of `bytes` by [`Self::whole_frame`]; otherwise (a frame split over
    /// chunks, a malformed one) [`Self::step`] per byte, on the state held in locals for
    /// the run (the encoded count added once), the CRC register run over each decoded
    /// byte as it is stored. (A block-wise inner loop for this general case, with a call
    /// and set-up per block, measured slower: the Sensor frame's COBS blocks are one to
    /// four bytes.)
    #[inline(always)]
    fn next_with<'b, M>(
        &mut self,
        bytes: &'b [u8],
        decode: impl FnOnce(&[u8], Option<u32>) -> Result<M, FrameError>,
    ) -> (Option<Result<M, FrameError>>, &'b [u8]) {
        crc_ready();
        let whole = if self.enc == 0 {
            self.whole_frame(bytes)
        } else {
            None
        };
        let (closed, rest) = match whole {
            Some((n, crc, enc)) => {
                (self.n, self.crc, self.enc) = (n, crc, enc);
                (true, bytes.get(enc + 1..).unwrap_or(&[]))
            }
            None => self.general(bytes),
        };
        if closed {
            (self.close(decode), rest)
        } else {
            (None, &[])
        }
    }

    /// [`Self::next_with`]'s general loop: takes the bytes up to and including the next
    /// delimiter (or all of them); returns whether a delimiter closed the frame and the
    /// bytes after it. ([`Self::next_with`] calls [`Self::close`] once for both paths, so
    /// the message decoder is inlined once.)
    #[inline(always)]
    fn general<'b>(&mut self, bytes: &'b [u8]) -> (bool, &'b [u8]) {
        let (mut n, mut left, mut zero, mut crc) = (self.n, self.left, self.zero, self.crc);
        let mut it = bytes.iter();
        let mut closed = false;
        for &b in it.by_ref() {
            if b == 0 {
                closed = true;
                break;
            }
            let byte = if left == 0 {
                let z = zero;
                zero = b != 0xFF;
                left = b - 1;
                if !z {
                    continue;
                }
                0
            } else {
                left -= 1;
                b
            };
            if let Some(slot) = self.raw.get_mut(n) {
                *slot = byte;
                n += 1;
                crc = crc_byte(crc, byte);
            }
        }
        let rest = it.as_slice();
        let taken = bytes.len() - rest.len() - usize::from(closed);
        self.enc = self.enc.saturating_add(taken);
        (self.n, self.left, self.zero, self.crc) = (n, left, zero, crc);
        (closed, rest)
    }
}
