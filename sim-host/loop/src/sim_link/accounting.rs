//! Frame accounting: the receiving port ([`RxPort`]) attributes every sent frame to one
//! fate (received, rejected, dropped, in flight), summed in [`Accounting`].

use std::fmt;

use wheelset_proto::{Decoder, FrameError, Message};

use super::{Channel, FrameId};

/// The fate of a sent frame, as seen by the receiving port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Fate {
    Open,
    Received,
    Rejected,
}

/// The receiving end of a channel: attributes every sent frame to its fate, decoded by
/// the receiver ([`Self::push_with`]) or by its own decoder ([`Self::push`]).
#[derive(Debug, Clone, Default)]
pub struct RxPort {
    decoder: Decoder,
    book: Book,
}

/// The attribution state of an [`RxPort`], apart from its decoder (the counts: [`Accounting`]'s).
#[derive(Debug, Clone, Default)]
struct Book {
    pending: Vec<FrameId>,
    fates: Vec<Fate>,
    reached: Vec<bool>,
    received: u64,
    rejected: u64,
    errors: [u64; 5],
    rejected_by: [u64; 5],
}

impl RxPort {
    /// Decodes delivered bytes of frame `id` with its own decoder; `on_msg` per valid message.
    pub fn push(&mut self, run: &[u8], id: FrameId, mut on_msg: impl FnMut(Message)) {
        let dec = &mut self.decoder;
        self.book.attribute(run, id, |piece| {
            // A piece holds at most one delimiter, its last byte.
            dec.next_message(piece).0.map(|r| r.map(&mut on_msg))
        });
    }

    /// Delivered bytes of frame `id` decoded elsewhere: `decode(piece)` (split after each
    /// 0x00) returns the closed frame's outcome, attributed to every frame with bytes in it.
    pub fn push_with(
        &mut self,
        run: &[u8],
        id: FrameId,
        decode: impl FnMut(&[u8]) -> Option<Result<(), FrameError>>,
    ) {
        self.book.attribute(run, id, decode);
    }

    /// The final accounting of `channel`'s frames at the end of a run.
    #[must_use]
    pub fn account(&self, channel: &Channel) -> Accounting {
        let sent = channel.counters().frames_sent;
        let mut in_flight: Vec<FrameId> = channel.queued_frames().collect();
        let book = &self.book;
        in_flight.extend(book.pending.iter().copied());
        in_flight.sort_unstable();
        in_flight.dedup();
        let open = |id: FrameId| book.fates.get(id as usize).is_none_or(|f| *f == Fate::Open);
        in_flight.retain(|&id| open(id));
        // Dropped: no byte reached the decoder, and none is on its way.
        let dropped = (0..sent as FrameId)
            .filter(|&id| {
                !book.reached.get(id as usize).copied().unwrap_or(false)
                    && in_flight.binary_search(&id).is_err()
            })
            .count() as u64;
        Accounting {
            sent,
            received: book.received,
            rejected: book.rejected,
            dropped,
            in_flight: in_flight.len() as u64,
            link_dropped_whole: channel.counters().frames_dropped,
            errors: book.errors,
            rejected_by: book.rejected_by,
        }
    }
}

impl Book {
    /// See [`RxPort::push_with`].
    fn attribute(
        &mut self,
        run: &[u8],
        id: FrameId,
        mut decode: impl FnMut(&[u8]) -> Option<Result<(), FrameError>>,
    ) {
        let i = id as usize;
        if self.fates.len() <= i {
            // Grown in chunks (ids come in order); entries past the last id sent stay
            // Open / not reached, which is what `account` assumes for missing ones.
            let len = (i + 1).max(2 * self.fates.len()).max(1024);
            self.fates.resize(len, Fate::Open);
            self.reached.resize(len, false);
        }
        match run.split_last() {
            // Typical: one whole frame, its delimiter last.
            Some((&0, head)) if !head.contains(&0) => self.piece(run, id, &mut decode),
            _ => {
                for piece in run.split_inclusive(|&b| b == 0) {
                    self.piece(piece, id, &mut decode);
                }
            }
        }
    }

    /// One piece of a run: bytes up to and including a 0x00, or the run's tail.
    #[inline(always)]
    fn piece(
        &mut self,
        piece: &[u8],
        id: FrameId,
        decode: &mut impl FnMut(&[u8]) -> Option<Result<(), FrameError>>,
    ) {
        let closes = piece.last() == Some(&0);
        if piece.len() > usize::from(closes) {
            if let Some(r) = self.reached.get_mut(id as usize) {
                *r = true;
            }
            if self.pending.last() != Some(&id) {
                self.pending.push(id);
            }
        }
        let r = decode(piece);
        if !closes {
            return;
        }
        let mut cause = None;
        let (to, count) = match r {
            Some(Ok(())) => (Fate::Received, &mut self.received),
            Some(Err(e)) => {
                self.errors[e.index()] += 1;
                cause = Some(e.index());
                (Fate::Rejected, &mut self.rejected)
            }
            None => {
                self.pending.clear();
                return;
            }
        };
        // (Every pending id is below `fates.len()`: resized when its bytes came.)
        for &p in self.pending.iter() {
            if let Some(f) = self.fates.get_mut(p as usize) {
                if *f == Fate::Open {
                    *f = to;
                    *count += 1;
                    if let Some(c) = cause {
                        self.rejected_by[c] += 1;
                    }
                }
            }
        }
        self.pending.clear();
    }
}

/// Every frame of one direction, accounted for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Accounting {
    /// Frames sent.
    pub sent: u64,
    /// Frames received valid.
    pub received: u64,
    /// Frames rejected by the receiver (they were part of a CRC/COBS/length/... reject).
    pub rejected: u64,
    /// Frames of which no byte reached the receiver's decoder.
    pub dropped: u64,
    /// Frames still on the way at the end.
    pub in_flight: u64,
    /// Of `dropped`: frames the link dropped whole (`drop=`).
    pub link_dropped_whole: u64,
    /// Decoder rejections (events) by kind: CRC, COBS, version, length, postcard.
    pub errors: [u64; 5],
    /// Rejected frames by the kind of their reject, same order; sums to `rejected`.
    pub rejected_by: [u64; 5],
}

impl Accounting {
    /// `sent == received + rejected + dropped + in_flight`, and by cause sum to `rejected`.
    #[must_use]
    pub fn adds_up(&self) -> bool {
        self.sent == self.received + self.rejected + self.dropped + self.in_flight
            && self.rejected_by.iter().sum::<u64>() == self.rejected
    }
}

impl fmt::Display for Accounting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [crc, cobs, ver, len, pc] = self.rejected_by;
        let events: u64 = self.errors.iter().sum();
        write!(
            f,
            "sent {} = received {} + rejected {} + dropped {} + in flight {} [{}] \
             (rejected frames: crc {crc} + cobs {cobs} + version {ver} + length {len} + postcard {pc}, \
             in {events} decoder rejects; dropped whole by the link {})",
            self.sent,
            self.received,
            self.rejected,
            self.dropped,
            self.in_flight,
            if self.adds_up() {
                "adds up"
            } else {
                "DOES NOT ADD UP"
            },
            self.link_dropped_whole
        )
    }
}
