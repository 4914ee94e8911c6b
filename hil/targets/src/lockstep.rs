//! Bookkeeping shared by the lock-step transports (QEMU, a frame-clocked serial device):
//! every 0x00 delimiter the host sends is one device tick, answered by one Actuation
//! frame (and a Status frame after a `RequestStatus`). [`Expect`] counts the frames owed.
//!
//! One frame in flight: two frames back to back are two clock edges in one burst, one
//! tick, and the host would wait forever for the other answer; so it waits for what is
//! owed before sending ([`frames`], [`Expect::stash`]). A device taking frames whole (QEMU
//! bulk) may have two in flight ([`Expect::owed_before`]).

use std::collections::VecDeque;

use wheelset_loop::transport::TransportError;
use wheelset_proto::{Command, Decoder, Message};

/// The parts of one write as the device's clock sees them: each up to and including a
/// 0x00 delimiter, then the rest without one (if any). Empty input gives nothing.
pub fn frames(bytes: &[u8]) -> impl Iterator<Item = &[u8]> {
    bytes.split_inclusive(|&b| b == 0)
}

/// Frames the device owes the host.
#[derive(Debug, Default)]
pub struct Expect {
    decoder: Decoder,
    owed: u64,
    early: Vec<u8>,
    /// The answers owed by send time, oldest first: (sent at, ns; frames); their sum is
    /// `owed` when every send was timed ([`Self::sent_at`]).
    by_time: VecDeque<(u64, u64)>,
}

impl Expect {
    /// Accounts for bytes sent: one frame per delimiter, two for a status request.
    pub fn sent(&mut self, bytes: &[u8]) {
        for (taken, r) in self.decoder.pieces(bytes) {
            if taken.last() == Some(&0) {
                self.owed += 1;
                if let Some(Ok(Message::Command(Command::RequestStatus))) = r {
                    self.owed += 1;
                }
            }
        }
    }

    /// [`Self::sent`] at `t_ns` on the transport's clock, for [`Self::owed_before`].
    pub fn sent_at(&mut self, t_ns: u64, bytes: &[u8]) {
        let before = self.owed;
        self.sent(bytes);
        let n = self.owed - before;
        if n > 0 {
            match self.by_time.back_mut() {
                Some((t, k)) if *t == t_ns => *k += n,
                _ => self.by_time.push_back((t_ns, n)),
            }
        }
    }

    /// Accounts for received bytes: one frame per delimiter.
    pub fn received(&mut self, bytes: &[u8]) {
        let mut n = bytes.iter().filter(|&&b| b == 0).count() as u64;
        self.owed = self.owed.saturating_sub(n);
        // The oldest answers first: the device answers in order.
        while n > 0 {
            let Some((_, k)) = self.by_time.front_mut() else {
                break;
            };
            let take = n.min(*k);
            *k -= take;
            n -= take;
            if *k == 0 {
                self.by_time.pop_front();
            }
        }
    }

    /// Frames owed for what was sent before `deadline_ns` ([`Self::sent_at`]).
    #[must_use]
    pub fn owed_before(&self, deadline_ns: u64) -> u64 {
        self.by_time
            .iter()
            .take_while(|&&(t, _)| t < deadline_ns)
            .map(|&(_, k)| k)
            .sum()
    }

    /// Frames still owed.
    #[must_use]
    pub fn owed(&self) -> u64 {
        self.owed
    }

    /// Keeps bytes received before a send (answers to earlier frames) for the next receive.
    pub fn stash(&mut self, bytes: &[u8]) {
        self.early.extend_from_slice(bytes);
    }

    /// The bytes kept by [`Self::stash`], in arrival order; empty after.
    pub fn take_early(&mut self) -> Vec<u8> {
        std::mem::take(&mut self.early)
    }
}

/// A lock-step link with one frame in flight (a serial device, QEMU over its UART).
pub(crate) trait OneInFlight {
    fn expect(&mut self) -> &mut Expect;

    /// Writes one part of a write ([`frames`]).
    fn write(&mut self, part: &[u8]) -> Result<(), TransportError>;

    /// The next bytes from the device to `sink`, accounted as received; a timeout on silence.
    fn recv_some(&mut self, sink: &mut dyn FnMut(&[u8])) -> Result<(), TransportError>;

    fn wait_owed(&mut self, sink: &mut dyn FnMut(&[u8])) -> Result<(), TransportError> {
        while self.expect().owed() > 0 {
            self.recv_some(sink)?;
        }
        Ok(())
    }

    /// Sends each frame of `bytes` after the answers owed (kept for [`Self::recv_owed`]).
    fn send_frames(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        for part in frames(bytes) {
            let mut early = Vec::new();
            self.wait_owed(&mut |b| early.extend_from_slice(b))?;
            self.expect().stash(&early);
            self.expect().sent(part);
            self.write(part)?;
        }
        Ok(())
    }

    /// The answers kept by [`Self::send_frames`], then all owed, to `sink` at `deadline_ns`.
    fn recv_owed(
        &mut self,
        deadline_ns: u64,
        sink: &mut dyn FnMut(u64, &[u8]),
    ) -> Result<(), TransportError> {
        let early = self.expect().take_early();
        if !early.is_empty() {
            sink(deadline_ns, &early);
        }
        self.wait_owed(&mut |b| sink(deadline_ns, b))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wheelset_proto::{encode_vec, Sensor};

    #[test]
    fn a_frame_owes_one_a_status_request_two() {
        let mut e = Expect::default();
        let s = Sensor {
            seq: 1,
            ..Sensor::ZERO
        };
        e.sent(&encode_vec(&Message::Sensor(s)).unwrap_or_default());
        assert_eq!(e.owed(), 1);
        e.sent(&encode_vec(&Message::Command(Command::RequestStatus)).unwrap_or_default());
        assert_eq!(e.owed(), 3);
        e.sent(&[0]);
        assert_eq!(e.owed(), 4);
        e.received(&[1, 2, 0, 5, 0]);
        assert_eq!(e.owed(), 2);
    }

    #[test]
    fn answers_are_owed_by_send_time_oldest_first() {
        let mut e = Expect::default();
        let s = |seq| {
            encode_vec(&Message::Sensor(Sensor {
                seq,
                ..Sensor::ZERO
            }))
            .unwrap_or_default()
        };
        e.sent_at(0, &s(1));
        e.sent_at(
            0,
            &encode_vec(&Message::Command(Command::RequestStatus)).unwrap_or_default(),
        );
        e.sent_at(200, &s(2));
        assert_eq!(e.owed(), 4);
        assert_eq!(e.owed_before(0), 0);
        assert_eq!(e.owed_before(200), 3);
        assert_eq!(e.owed_before(201), 4);
        // Two answers: both to the frames sent at 0.
        e.received(&[1, 0, 2, 0]);
        assert_eq!(
            (e.owed(), e.owed_before(200), e.owed_before(400)),
            (2, 1, 2)
        );
        e.received(&[3, 0, 4, 0]);
        assert_eq!((e.owed(), e.owed_before(400)), (0, 0));
    }

    #[test]
    fn a_write_splits_after_each_delimiter() {
        let parts: Vec<&[u8]> = frames(&[1, 2, 0, 0, 3, 0, 4]).collect();
        assert_eq!(parts, vec![&[1, 2, 0][..], &[0][..], &[3, 0][..], &[4][..]]);
        assert_eq!(frames(&[]).count(), 0);
    }

    #[test]
    fn stashed_answers_come_back_once_in_order() {
        let mut e = Expect::default();
        e.stash(&[1, 2, 0]);
        e.stash(&[3, 0]);
        assert_eq!(e.take_early(), vec![1, 2, 0, 3, 0]);
        assert!(e.take_early().is_empty());
    }
}
