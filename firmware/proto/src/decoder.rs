//! The streaming frame accumulator: bytes in any chunking, frames out.

use crate::frame::{check, request, whole, FrameError, Request, MAX_FRAME};
use crate::message::Message;

/// Longest encoded frame (delimiter excluded) decoded; longer ones are [`FrameError::Length`].
const LIMIT: usize = MAX_FRAME - 1;

/// The result of a frame a call closed: `None` when it closed none.
type Next<'b, M> = (Option<Result<M, FrameError>>, &'b [u8]);

/// Collects the bytes up to each 0x00 in a fixed buffer and decodes the frame there;
/// empty frames are skipped, an over-long one reported once as [`FrameError::Length`].
///
/// ```
/// use wheelset_proto::{encode_vec, Command, Decoder, Message};
/// let frame = encode_vec(&Message::Command(Command::ResetCounters)).unwrap();
/// let mut dec = Decoder::new();
/// let (first, rest) = dec.next_message(&frame[..5]);
/// assert_eq!((first, rest.len()), (None, 0));
/// let (got, rest) = dec.next_message(&frame[5..]);
/// assert_eq!(got, Some(Ok(Message::Command(Command::ResetCounters))));
/// assert!(rest.is_empty());
/// ```
#[derive(Debug, Clone)]
pub struct Decoder {
    /// The encoded bytes of the frame in progress (its first [`LIMIT`]).
    buf: [u8; MAX_FRAME],
    /// Encoded bytes of the frame in progress (saturating; beyond [`LIMIT`] not kept).
    enc: usize,
}

impl Default for Decoder {
    fn default() -> Self {
        Self::new()
    }
}

impl Decoder {
    /// An empty decoder, waiting for the first byte of a frame.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            buf: [0; MAX_FRAME],
            enc: 0,
        }
    }

    /// Bytes of the frame in progress (at most [`MAX_FRAME`]).
    #[must_use]
    pub fn pending(&self) -> usize {
        self.enc.min(MAX_FRAME)
    }

    /// The host's decoder: `bytes` up to the first delimiter; that frame's result, and the rest.
    pub fn next_message<'b>(&mut self, bytes: &'b [u8]) -> Next<'b, Message> {
        self.next_with(bytes, whole::<Message>)
    }

    /// The device's decoder: the same decisions, decoding only what the device takes.
    pub fn next_request<'b>(&mut self, bytes: &'b [u8]) -> Next<'b, Request> {
        self.next_with(bytes, request)
    }

    /// The bytes up to the next delimiter; at a delimiter the frame's result.
    fn next_with<'b, M>(
        &mut self,
        bytes: &'b [u8],
        decode: fn(&[u8]) -> Result<M, FrameError>,
    ) -> Next<'b, M> {
        let mut split = bytes.splitn(2, |&b| b == 0);
        let data = split.next().unwrap_or_default();
        let rest = split.next();
        let start = self.enc;
        self.enc = self.enc.saturating_add(data.len());
        if self.enc <= LIMIT {
            if let Some(to) = self.buf.get_mut(start..self.enc) {
                to.copy_from_slice(data);
            }
        }
        let Some(rest) = rest else {
            return (None, &[]);
        };
        let enc = core::mem::take(&mut self.enc);
        if enc == 0 {
            return (None, rest);
        }
        if enc > LIMIT {
            return (Some(Err(FrameError::Length)), rest);
        }
        let frame = self.buf.get_mut(..enc).unwrap_or_default();
        let r = match cobs::decode_in_place(frame) {
            Ok(n) => check(frame.get(..n).unwrap_or_default()).and_then(decode),
            Err(_) => Err(FrameError::Cobs),
        };
        (Some(r), rest)
    }
}
