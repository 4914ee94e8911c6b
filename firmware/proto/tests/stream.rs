//! The streaming decoder decides every frame as a whole-frame decoder built here from
//! the crates (`cobs`, `crc`, `postcard`: what a client written from the crate docs
//! does), on arbitrary byte strings (every COBS, length and CRC failure) and on valid
//! frames with bytes changed, dropped or added; the device's decoder decides as the
//! host's; neither result depends on how the bytes are cut into chunks.

mod common;

use common::*;
use proptest::prelude::*;
use wheelset_proto::*;

/// A client's decoder of one frame (the bytes between two delimiters, no 0x00): COBS,
/// length, CRC, version, postcard, no bytes left over, in the order the crate docs state.
fn reference(body: &[u8]) -> Result<Message, FrameError> {
    if body.len() + 1 > MAX_FRAME {
        return Err(FrameError::Length);
    }
    let mut b = body.to_vec();
    let n = match cobs::decode_in_place_report(&mut b) {
        Ok(r) if r.src_used == body.len() => r.dst_used,
        _ => return Err(FrameError::Cobs),
    };
    let frame = &b[..n];
    if n < MIN_DECODED {
        return Err(FrameError::Length);
    }
    let (raw, crc) = frame.split_at(n - CRC_LEN);
    let want = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(raw);
    if crc != want.to_le_bytes() {
        return Err(FrameError::Crc);
    }
    if raw[0] != VERSION {
        return Err(FrameError::Version);
    }
    match postcard::take_from_bytes::<Message>(&raw[1..]) {
        Ok((m, [])) => Ok(m),
        Ok(_) => Err(FrameError::Length),
        Err(_) => Err(FrameError::Postcard),
    }
}

/// Whether the device's result is the host's, for the messages the device takes; for
/// the others, `Unexpected` for a device -> host type whatever its body, and `Unknown`
/// for an undefined Command or YawMode index (the host refuses it as `Postcard`).
fn device_agrees(host: &Result<Message, FrameError>, dev: &Result<Request, FrameError>) -> bool {
    match (host, dev) {
        (Ok(Message::Sensor(x)), Ok(Request::Sensor(y))) => x == y,
        (Ok(Message::Config(x)), Ok(Request::Config(y))) => x == y,
        (Ok(Message::Command(x)), Ok(Request::Command(y))) => x == y,
        (Ok(Message::Actuation(_) | Message::Status(_)), Ok(Request::Unexpected)) => true,
        (Err(FrameError::Postcard | FrameError::Length), Ok(Request::Unexpected)) => true,
        (Err(FrameError::Postcard), Ok(Request::Unknown)) => true,
        (Err(e), Err(f)) => e == f,
        _ => false,
    }
}

/// The decoders' results for one frame body (no 0x00) followed by a delimiter.
fn both(body: &[u8]) {
    assert!(!body.contains(&0));
    let mut wire = body.to_vec();
    wire.push(0);
    let mut host = Decoder::new();
    let (got, rest) = host.next_message(&wire);
    assert!(rest.is_empty());
    let mut dev = Decoder::new();
    let (req, rest) = dev.next_request(&wire);
    assert!(rest.is_empty());
    assert_eq!((host.pending(), dev.pending()), (0, 0));
    let (Some(got), Some(req)) = (got, req) else {
        assert!(
            body.is_empty(),
            "only an empty frame closes nothing: {body:02x?}"
        );
        return;
    };
    assert_eq!(got, reference(body), "{body:02x?}");
    assert!(device_agrees(&got, &req), "{body:02x?}: {got:?} vs {req:?}");
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

/// The COBS body (no delimiter) of a CRC-valid frame `VERSION | ty | body | CRC`: one
/// that reaches the message decoder.
fn crc_valid(ty: u8, body: &[u8]) -> Vec<u8> {
    let mut raw = vec![VERSION, ty];
    raw.extend_from_slice(body);
    let mut framed = vec![0u8; MAX_FRAME];
    let n = frame_raw(&raw, &mut framed).expect("fits");
    framed.truncate(n - 1);
    framed
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

    /// Bodies of arbitrary bytes in CRC-valid frames of every type byte (every varint
    /// length, malformed varints, bytes missing or left over).
    #[test]
    fn crc_valid_arbitrary_bodies(
        ty in 0u8..7,
        body in proptest::collection::vec(
            prop_oneof![any::<u8>(), 0x80u8..=0xFF, 0u8..=3, Just(0x0Fu8), Just(0x10u8)],
            0..60,
        ),
    ) {
        both(&crc_valid(ty, &body));
    }
}

#[test]
fn length_limits_are_the_whole_frame_decoders() {
    // Code bytes only (each a valid one-byte block) up to and past MAX_FRAME.
    for n in 1..=MAX_FRAME + 3 {
        both(&vec![1u8; n]);
        both(&vec![0xFFu8; n]);
    }
}

/// Every frame closed in `wire`, fed in the given chunks.
fn in_chunks<'a>(chunks: impl IntoIterator<Item = &'a [u8]>) -> Vec<Result<Message, FrameError>> {
    let mut d = Decoder::new();
    chunks
        .into_iter()
        .flat_map(|c| d.messages(c).collect::<Vec<_>>())
        .collect()
}

/// A whole stream in one chunk, cut in two at every point, and byte by byte give the
/// same frames; `wire` is two frames back to back, so the second starts mid-chunk.
fn chunking(first: &[u8], second: &[u8]) {
    let mut wire = first.to_vec();
    wire.push(0);
    wire.extend_from_slice(second);
    wire.push(0);
    let whole = in_chunks([&wire[..]]);
    assert_eq!(whole, in_chunks(wire.chunks(1)), "{wire:02x?}");
    for cut in 0..=wire.len() {
        let split = in_chunks([&wire[..cut], &wire[cut..]]);
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

/// The CRC-valid Sensor bodies reach the Sensor decoder's success and each of its
/// failures.
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
        let mut dec = Decoder::new();
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
