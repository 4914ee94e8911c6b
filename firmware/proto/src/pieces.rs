//! Reading a run of bytes with the host's decoder, [`Decoder::next_message`] looped once.

use crate::{Decoder, FrameError, Message};

/// The result of the frame a piece closed (`None`: none).
pub type Closed = Option<Result<Message, FrameError>>;

/// The pieces of a byte run as [`Decoder::next_message`] takes them, with what each closed.
#[derive(Debug)]
pub struct Pieces<'d, 'b> {
    dec: &'d mut Decoder,
    rest: &'b [u8],
}

impl<'b> Iterator for Pieces<'_, 'b> {
    type Item = (&'b [u8], Closed);

    fn next(&mut self) -> Option<Self::Item> {
        if self.rest.is_empty() {
            return None;
        }
        let (r, more) = self.dec.next_message(self.rest);
        let taken = self.rest.len().saturating_sub(more.len());
        let piece = self.rest.get(..taken).unwrap_or_default();
        self.rest = more;
        Some((piece, r))
    }
}

impl Decoder {
    /// The pieces of `bytes` and what each closed; the decoder's state carries over runs.
    pub fn pieces<'d, 'b>(&'d mut self, bytes: &'b [u8]) -> Pieces<'d, 'b> {
        Pieces {
            dec: self,
            rest: bytes,
        }
    }

    /// Every frame closed in `bytes`, in order: [`Self::pieces`] without the pieces.
    pub fn messages<'d, 'b>(
        &'d mut self,
        bytes: &'b [u8],
    ) -> impl Iterator<Item = Result<Message, FrameError>> + use<'d, 'b> {
        self.pieces(bytes).filter_map(|(_, r)| r)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    extern crate std;
    use std::vec::Vec;

    use crate::{encode_vec, Command, Decoder, FrameError, Message};

    #[test]
    fn pieces_cover_the_run_and_messages_are_the_frames_closed() {
        let a = encode_vec(&Message::Command(Command::ResetCounters)).unwrap();
        let b = encode_vec(&Message::Command(Command::RequestStatus)).unwrap();
        // A frame, an empty frame, a corrupted frame, a frame cut at the end of the run.
        let mut run = a.to_vec();
        run.push(0);
        let mut bad = b.to_vec();
        bad[2] = if bad[2] == 0x55 { 0x56 } else { 0x55 };
        run.extend_from_slice(&bad);
        run.extend_from_slice(&a[..3]);
        let mut dec = Decoder::new();
        // Bounded: every piece takes at least one byte, so an iterator that never ends
        // fails here instead of hanging the suite.
        let pieces: Vec<_> = dec.pieces(&run).take(run.len() + 1).collect();
        let joined: Vec<u8> = pieces.iter().flat_map(|(p, _)| p.iter().copied()).collect();
        assert_eq!(joined, run);
        assert_eq!(
            pieces.iter().map(|(p, _)| p.len()).collect::<Vec<_>>(),
            [a.len(), 1, bad.len(), 3]
        );
        assert_eq!(pieces[1].1, None);
        assert_eq!(pieces[3].1, None);
        // The cut frame's rest completes it in the next run.
        let got: Vec<_> = dec.messages(&a[3..]).collect();
        assert_eq!(got, [Ok(Message::Command(Command::ResetCounters))]);
        let mut dec = Decoder::new();
        let got: Vec<_> = dec.messages(&run).collect();
        assert_eq!(got.len(), 2);
        assert_eq!(got[0], Ok(Message::Command(Command::ResetCounters)));
        assert!(matches!(got[1], Err(FrameError::Crc | FrameError::Cobs)));
    }
}
