//! The streaming decoder (COBS decoded as the bytes arrive) decides every frame as the
//! whole-frame decoders do: `Decoder::feed` = `decode_frame` and
//! `Decoder::next_request` = `decode_request`, on arbitrary byte strings (every COBS,
//! length and CRC failure) and on valid frames with bytes changed, dropped or added.

mod common;

use common::*;
use proptest::prelude::*;
use wheelset_proto::oracle::*;
use wheelset_proto::*;

/// The decoders' results for one frame body (no 0x00) followed by a delimiter.
fn both(body: &[u8]) {
    assert!(!body.contains(&0));
    let mut wire = body.to_vec();
    wire.push(0);
    let mut dec: Decoder = Decoder::new();
    let mut got = Vec::new();
    dec.feed(&wire, |r| got.push(r));
    let mut dev: Decoder = Decoder::new();
    let (req, rest) = dev.next_request(&wire);
    assert!(rest.is_empty());
    if body.is_empty() {
        assert!(got.is_empty() && req.is_none(), "an empty frame is skipped");
        return;
    }
    assert_eq!(got, vec![decode_frame(&mut body.to_vec())], "{body:02x?}");
    assert_eq!(req, Some(decode_request(&mut body.to_vec())), "{body:02x?}");
    assert_eq!((dec.pending(), dev.pending()), (0, 0));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    #[test]
    fn arbitrary_frames(body in proptest::collection::vec(1u8..=255, 0..130)) {
        both(&body);
    }

    #[test]
    fn changed_valid_frames(
        msg in message(),
        edits in proptest::collection::vec((0usize..120, 1u8..=255, 0u8..3), 0..4),
    ) {
        both(&edited(&msg, &edits));
    }
}

/// The body (no delimiter) of `msg`'s frame with `edits` applied: each `(at, byte,
/// kind)` replaces (kind 0), drops (1) or inserts (2) a byte at `at` modulo the length.
fn edited(msg: &Message, edits: &[(usize, u8, u8)]) -> Vec<u8> {
    let f = encode_vec(msg).expect("fits");
    let mut body = f[..f.len() - 1].to_vec();
    for &(at, b, kind) in edits {
        let at = at % (body.len() + 1);
        match kind {
            0 if at < body.len() => body[at] = b,
            1 if at < body.len() => {
                body.remove(at);
            }
            _ => body.insert(at, b),
        }
    }
    body
}

#[test]
fn length_limits_are_the_whole_frame_decoders() {
    // Code bytes only (each a valid one-byte block) up to and past MAX_FRAME.
    for n in 1..=MAX_FRAME + 3 {
        both(&vec![1u8; n]);
        both(&vec![0xFFu8; n]);
    }
}

/// `next_sensor_or_request` reports every frame as `next_request` does, a valid Sensor
/// written into the caller's `Sensor` instead.
fn sensor_path(body: &[u8]) {
    let mut wire = body.to_vec();
    wire.push(0);
    let mut a: Decoder = Decoder::new();
    let mut b: Decoder = Decoder::new();
    let (want, rest_a) = a.next_request(&wire);
    let mut s = Sensor {
        seq: 1,
        t_us: 2,
        lateral: Lateral::Acceleration(3),
        i_a_ma: 4,
        omega_m_mrad_s: 5,
        demand_nm: 6,
        v_ref_mm_s: 7,
    };
    let before = s;
    // A value no decoding returns: it stays unless the decoder reports `Frame`.
    let untouched = Ok(Request::Unexpected);
    let mut frame = untouched;
    let (got, rest_b) = b.next_sensor_or_request(&wire, &mut s, &mut frame);
    assert_eq!(rest_a, rest_b);
    match (want, got) {
        (None, NextFrame::Nothing) => assert_eq!((s, frame), (before, untouched)),
        (Some(Ok(Request::Sensor(w))), NextFrame::Sensor) => {
            assert_eq!(s, w, "{body:02x?}");
            assert_eq!(frame, untouched, "{body:02x?}");
        }
        (Some(w), NextFrame::Frame) => {
            assert!(!matches!(w, Ok(Request::Sensor(_))), "{body:02x?}");
            assert_eq!(frame, w, "{body:02x?}");
            assert_eq!(s, before, "{body:02x?}");
        }
        (w, g) => panic!("{body:02x?}: next_request {w:?}, next_sensor_or_request {g:?}"),
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    #[test]
    fn sensor_path_arbitrary_frames(body in proptest::collection::vec(1u8..=255, 0..130)) {
        sensor_path(&body);
    }

    #[test]
    fn sensor_path_changed_valid_frames(
        msg in message(),
        edits in proptest::collection::vec((0usize..120, 1u8..=255, 0u8..3), 0..4),
    ) {
        sensor_path(&edited(&msg, &edits));
    }
}

/// The decoder's results do not depend on how the bytes are chunked: a whole frame in one
/// chunk (the decoder's fast path, `Decoder::next_with`'s whole-frame walk), the same
/// bytes cut in two at every point (the general byte loop for a frame that starts in one
/// chunk and ends in the next) and byte by byte (`push`) give the same frames; `wire` is
/// two frames back to back, so the second starts mid-chunk.
fn chunking(first: &[u8], second: &[u8]) {
    let mut wire = first.to_vec();
    wire.push(0);
    wire.extend_from_slice(second);
    wire.push(0);
    let mut whole = Vec::new();
    Decoder::<MAX_FRAME>::new().feed(&wire, |r| whole.push(r));
    let mut bytewise = Vec::new();
    let mut d: Decoder = Decoder::new();
    for &b in &wire {
        if let Some(r) = d.push(b) {
            bytewise.push(r);
        }
    }
    assert_eq!(whole, bytewise, "{wire:02x?}");
    for cut in 0..=wire.len() {
        let mut split = Vec::new();
        let mut d: Decoder = Decoder::new();
        d.feed(&wire[..cut], |r| split.push(r));
        d.feed(&wire[cut..], |r| split.push(r));
        assert_eq!(whole, split, "{wire:02x?} cut at {cut}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(1000))]

    #[test]
    fn chunking_arbitrary_frames(
        a in proptest::collection::vec(1u8..=255, 0..40),
        b in proptest::collection::vec(1u8..=255, 0..40),
    ) {
        chunking(&a, &b);
    }

    #[test]
    fn chunking_changed_valid_frames(
        m1 in message(),
        m2 in message(),
        edits in proptest::collection::vec((0usize..120, 1u8..=255, 0u8..3), 0..3),
    ) {
        chunking(&edited(&m1, &edits), &edited(&m2, &[]));
    }
}

/// The COBS body (no delimiter) of a CRC-valid frame `VERSION | ty | body | CRC`: one
/// that reaches the message decoder.
fn crc_valid(ty: u8, body: &[u8]) -> Vec<u8> {
    let mut raw = vec![VERSION, ty];
    raw.extend_from_slice(body);
    raw.extend_from_slice(&CRC.checksum(&raw).to_le_bytes());
    let mut framed = vec![0u8; raw.len() + 2];
    let n = cobs_encode(&raw, &mut framed).expect("fits");
    framed.truncate(n);
    framed
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    /// Sensor bodies of arbitrary bytes (every varint length, malformed varints, bytes
    /// missing or left over) in CRC-valid frames: `next_sensor_or_request`'s Sensor
    /// decoder decides as `next_request`'s, and as the whole-frame decoder.
    #[test]
    fn sensor_path_crc_valid_sensor_bodies(
        body in proptest::collection::vec(
            prop_oneof![any::<u8>(), 0x80u8..=0xFF, 0u8..=3, Just(0x0Fu8), Just(0x10u8)],
            0..40,
        ),
    ) {
        let wire = crc_valid(0, &body);
        sensor_path(&wire);
        both(&wire);
    }
}

/// A varint-shaped token: `len - 1` continuation bytes (top bit set: 0x80, 0xFF or any)
/// then a last byte (any below 0x80, the fifth-byte limits 0x0F and 0x10, or with the top
/// bit set too, which runs into the next token).
fn varint_token() -> impl Strategy<Value = Vec<u8>> {
    (
        proptest::collection::vec(prop_oneof![Just(0x80u8), Just(0xFFu8), 0x80u8..=0xFF], 0..6),
        prop_oneof![
            0u8..0x80,
            Just(0u8),
            Just(0x0Fu8),
            Just(0x10u8),
            Just(0x7Fu8),
            Just(0x80u8)
        ],
    )
        .prop_map(|(mut cont, last)| {
            cont.push(last);
            cont
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(4000))]

    /// Sensor bodies built of varint-shaped tokens (every length 1 to 6, the limits of
    /// each byte), after a seq and t_us, in CRC-valid frames: the device's Sensor decoder
    /// (its short varint forms inline) decides as `next_request`'s and as the whole-frame
    /// decoder.
    #[test]
    fn sensor_path_varint_shaped_sensor_bodies(
        head in proptest::collection::vec(any::<u8>(), 4),
        lateral in prop_oneof![0u8..3, Just(3u8), Just(0x80u8)],
        tokens in proptest::collection::vec(varint_token(), 0..8),
    ) {
        let mut body = head;
        body.push(lateral);
        for t in &tokens {
            body.extend_from_slice(t);
        }
        let wire = crc_valid(0, &body);
        sensor_path(&wire);
        both(&wire);
    }
}

/// The CRC-valid Sensor bodies decode at all (the test above reaches the Sensor decoder's
/// success and each of its failures).
#[test]
fn crc_valid_sensor_bodies_reach_each_outcome() {
    let ok = [1, 0, 2, 0, 0, 4, 6, 8, 10, 12];
    let mut outcomes = Vec::new();
    for body in [
        &ok[..],
        &ok[..9],
        &[&ok[..], &[1]].concat()[..],
        &[1, 0, 2, 0, 7][..],
    ] {
        let mut dec: Decoder = Decoder::new();
        outcomes.push(dec.next_request(&[crc_valid(0, body), vec![0]].concat()).0);
    }
    assert!(
        matches!(outcomes[0], Some(Ok(Request::Sensor(_)))),
        "{outcomes:?}"
    );
    assert_eq!(outcomes[1], Some(Err(FrameError::Postcard)));
    assert_eq!(outcomes[2], Some(Err(FrameError::Length)));
    assert_eq!(outcomes[3], Some(Err(FrameError::Postcard)));
}
