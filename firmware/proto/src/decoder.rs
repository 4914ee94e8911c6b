//! The streaming frame accumulator: bytes in any chunking, frames out.

use crate::frame::{decode_nonzero_frame, decode_nonzero_request, FrameError, Request, MAX_FRAME};
use crate::message::Message;

/// Collects bytes up to each 0x00 delimiter in a fixed buffer and decodes the frame.
///
/// - Empty frames (repeated delimiters) are skipped silently: a sender may put a 0x00
///   before a frame to resynchronise the receiver.
/// - A frame longer than [`MAX_FRAME`] is discarded up to the next delimiter and
///   reported once as [`FrameError::Length`]: the decoder resynchronises on 0x00.
/// - Never panics, never allocates; `N` bounds the memory (default [`MAX_FRAME`]).
///
/// ```
/// use wheelset_proto::{encode_vec, Command, Decoder, Message};
/// let frame = encode_vec(&Message::Command(Command::ResetCounters)).unwrap();
/// let mut dec: Decoder = Decoder::new();
/// let mut got = None;
/// for &b in &frame {
///     if let Some(r) = dec.push(b) {
///         got = Some(r);
///     }
/// }
/// assert_eq!(got, Some(Ok(Message::Command(Command::ResetCounters))));
/// ```
#[derive(Debug, Clone)]
pub struct Decoder<const N: usize = MAX_FRAME> {
    buf: heapless::Vec<u8, N>,
    overflow: bool,
}

impl<const N: usize> Default for Decoder<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Decoder<N> {
    /// An empty decoder, waiting for the first byte of a frame.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            buf: heapless::Vec::new(),
            overflow: false,
        }
    }

    /// Discards any partial frame.
    pub fn reset(&mut self) {
        self.buf.clear();
        self.overflow = false;
    }

    /// Bytes of the frame in progress.
    #[must_use]
    pub fn pending(&self) -> usize {
        self.buf.len()
    }

    /// Takes one byte; returns a result when the byte closed a non-empty frame.
    pub fn push(&mut self, byte: u8) -> Option<Result<Message, FrameError>> {
        self.push_with(byte, decode_nonzero_frame)
    }

    /// Takes a chunk of bytes, calling `f` for every frame closed in it. Same results as
    /// [`Self::push`] byte by byte, but copies the runs between delimiters at once.
    pub fn feed(&mut self, bytes: &[u8], f: impl FnMut(Result<Message, FrameError>)) {
        self.feed_with(bytes, decode_nonzero_frame, f);
    }

    /// [`Self::feed`] for the device: frames decoded as by [`crate::decode_request`] (the
    /// messages the device takes; the others recognised by their type only).
    pub fn feed_requests(&mut self, bytes: &[u8], f: impl FnMut(Result<Request, FrameError>)) {
        self.feed_with(bytes, decode_nonzero_request, f);
    }

    /// Takes `bytes` up to and including the first delimiter: returns the frame's result
    /// if that closed one (as [`Self::feed_requests`] would report it) and the bytes not
    /// yet taken. A caller loops until the rest is empty; unlike the callback form, it
    /// may use its own state (the one that owns the decoder) between frames.
    #[inline(never)]
    pub fn next_request<'b>(
        &mut self,
        bytes: &'b [u8],
    ) -> (Option<Result<Request, FrameError>>, &'b [u8]) {
        self.next_with(bytes, decode_nonzero_request)
    }

    #[inline(always)]
    fn push_with<M>(
        &mut self,
        byte: u8,
        decode: impl FnOnce(&mut [u8]) -> Result<M, FrameError>,
    ) -> Option<Result<M, FrameError>> {
        if byte != 0 {
            if !self.overflow && self.buf.push(byte).is_err() {
                self.overflow = true;
            }
            return None;
        }
        if self.overflow {
            self.reset();
            return Some(Err(FrameError::Length));
        }
        if self.buf.is_empty() {
            return None;
        }
        // (`buf` holds no 0x00: `push` and `feed` end the frame at every one.)
        let r = decode(&mut self.buf);
        self.buf.clear();
        Some(r)
    }

    #[inline(always)]
    fn feed_with<M>(
        &mut self,
        bytes: &[u8],
        decode: impl Fn(&mut [u8]) -> Result<M, FrameError>,
        mut f: impl FnMut(Result<M, FrameError>),
    ) {
        let mut rest = bytes;
        while !rest.is_empty() {
            let (r, more) = self.next_with(rest, &decode);
            rest = more;
            if let Some(r) = r {
                f(r);
            }
        }
    }

    /// One run of bytes up to and including the next delimiter (or all of them).
    #[inline(always)]
    fn next_with<'b, M>(
        &mut self,
        bytes: &'b [u8],
        decode: impl FnOnce(&mut [u8]) -> Result<M, FrameError>,
    ) -> (Option<Result<M, FrameError>>, &'b [u8]) {
        let (run, closes) = match bytes.iter().position(|&b| b == 0) {
            Some(i) => (bytes.get(..i).unwrap_or(&[]), true),
            None => (bytes, false),
        };
        if !self.overflow {
            let room = N - self.buf.len();
            if run.len() > room {
                self.overflow = true;
            }
            // Fits by construction: `room` bytes at most.
            let _ = self.buf.extend_from_slice(run.get(..room).unwrap_or(run));
        }
        let rest = bytes.get(run.len() + usize::from(closes)..).unwrap_or(&[]);
        let r = if closes {
            self.push_with(0, decode)
        } else {
            None
        };
        (r, rest)
    }
}
