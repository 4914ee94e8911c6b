//! The decoder's state between calls: `Decoder::pending` is the number of bytes of the
//! open frame (0 between frames, at most `MAX_FRAME` however long an overlong frame
//! runs).

use wheelset_proto::*;

fn reset_counters() -> Vec<u8> {
    encode_vec(&Message::Command(Command::ResetCounters))
        .expect("fits")
        .to_vec()
}

#[test]
fn pending_counts_the_bytes_of_the_open_frame() {
    let f = reset_counters();
    let body = f.len() - 1; // the delimiter closes the frame
    assert!(body >= 3);
    let mut d = Decoder::new();
    assert_eq!(d.pending(), 0);
    for k in 1..=body {
        let (got, rest) = d.next_message(&f[k - 1..k]);
        assert_eq!((got, rest.len()), (None, 0));
        assert_eq!(d.pending(), k, "after {k} bytes");
    }
    let (got, _) = d.next_message(&f[body..]);
    assert_eq!(got, Some(Ok(Message::Command(Command::ResetCounters))));
    assert_eq!(d.pending(), 0, "closed");
    // An overlong frame: counted up to MAX_FRAME, not beyond.
    let long = vec![1u8; 3 * MAX_FRAME];
    let _ = d.next_message(&long);
    assert_eq!(d.pending(), MAX_FRAME);
    assert_eq!(d.next_message(&[0]).0, Some(Err(FrameError::Length)));
    assert_eq!(d.pending(), 0);
}

#[test]
fn a_frame_of_max_frame_bytes_is_decoded_and_one_more_is_too_long() {
    // The longest frame the decoder keeps is MAX_FRAME bytes with its delimiter: a body
    // of MAX_FRAME - 1 bytes is judged on its content (here: not COBS-valid), one byte
    // more is a Length error whatever it holds.
    let mut d = Decoder::new();
    let mut at_limit = vec![0xffu8; MAX_FRAME - 1];
    at_limit.push(0);
    assert_ne!(d.next_message(&at_limit).0, Some(Err(FrameError::Length)));
    let mut over = vec![0xffu8; MAX_FRAME];
    over.push(0);
    assert_eq!(d.next_message(&over).0, Some(Err(FrameError::Length)));
}
