//! Every message survives encode -> any chunking -> decode, extremes included; the
//! encoder writes what postcard, the `crc` crate and the `cobs` crate write; the decoder
//! never panics on arbitrary bytes, reports each kind of error and resynchronises on 0x00.

mod common;

use common::*;
use proptest::prelude::*;
use wheelset_proto::*;

proptest! {
    #![proptest_config(ProptestConfig::with_cases(2000))]

    #[test]
    fn round_trip_any_chunking(msg in message(), cuts in proptest::collection::vec(0usize..200, 0..6)) {
        let frame = encode_vec(&msg).expect("every message fits MAX_FRAME");
        prop_assert!(frame.len() <= MAX_FRAME);
        prop_assert_eq!(frame.last().copied(), Some(0));
        prop_assert!(!frame[..frame.len() - 1].contains(&0));
        // Split the frame at arbitrary points and feed the chunks one by one.
        let mut cuts: Vec<usize> = cuts.into_iter().map(|c| c % (frame.len() + 1)).collect();
        cuts.sort_unstable();
        let mut dec = Decoder::new();
        let mut got = Vec::new();
        let mut prev = 0;
        for c in cuts.into_iter().chain([frame.len()]) {
            got.extend(dec.messages(&frame[prev..c]));
            prev = c;
        }
        prop_assert_eq!(got, vec![Ok(msg)]);
        prop_assert_eq!(dec.pending(), 0);
    }

    /// The frame is postcard + CRC-32C + COBS as the crates write them (a client built on
    /// them), into every buffer that holds it; every shorter buffer is refused.
    #[test]
    fn encode_is_the_crates_frame_at_every_buffer_length(msg in message()) {
        let want = reference_frame(&msg);
        prop_assert_eq!(&encode_vec(&msg).expect("fits")[..], &want[..]);
        for len in 0..=MAX_FRAME {
            let mut buf = vec![0xA5u8; len];
            match encode(&msg, &mut buf) {
                Ok(n) => prop_assert_eq!(&buf[..n], &want[..], "{}", len),
                Err(e) => {
                    prop_assert_eq!(e, EncodeError::BufferTooSmall);
                    prop_assert!(len < want.len(), "{}", len);
                }
            }
        }
    }

    /// The device's decoder takes what the host sends, and recognises the rest by type.
    #[test]
    fn device_decoder_takes_every_message(msg in message()) {
        let frame = encode_vec(&msg).expect("fits");
        let (got, rest) = Decoder::new().next_request(&frame);
        let want = match msg {
            Message::Sensor(s) => Request::Sensor(s),
            Message::Config(c) => Request::Config(c),
            Message::Command(c) => Request::Command(c),
            Message::Actuation(_) | Message::Status(_) => Request::Unexpected,
        };
        prop_assert_eq!((got, rest.len()), (Some(Ok(want)), 0));
    }

    #[test]
    fn the_crc_is_the_crc_catalogues(data in proptest::collection::vec(any::<u8>(), 0..200)) {
        let reference = crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISCSI);
        prop_assert_eq!(CRC.checksum(&data), reference.checksum(&data));
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let results = decode_all(&bytes);
        // One result per non-empty run closed by a delimiter, at most.
        prop_assert!(results.len() <= bytes.iter().filter(|&&b| b == 0).count());
        let mut dev = Decoder::new();
        let mut rest = &bytes[..];
        while !rest.is_empty() {
            rest = dev.next_request(rest).1;
        }
    }

    #[test]
    fn resync_after_garbage(garbage in proptest::collection::vec(any::<u8>(), 0..300), msg in message()) {
        // Garbage, then a delimiter, then a valid frame: the frame is always recovered.
        let mut stream = garbage;
        stream.push(0);
        stream.extend_from_slice(&encode_vec(&msg).expect("fits"));
        let results = decode_all(&stream);
        prop_assert_eq!(results.last().cloned(), Some(Ok(msg)));
    }

    #[test]
    fn quantize_round_trips_within_half_lsb(x in -1.0e6f64..1.0e6, lsb in prop_oneof![Just(1e-6), Just(1e-3), Just(0.1), Just(1.0)]) {
        let (q, clamped) = units::quantize(x, lsb);
        if !clamped {
            prop_assert!((units::to_si(q, lsb) - x).abs() <= 0.5 * lsb * (1.0 + 1e-9));
        } else {
            prop_assert!(q == i32::MAX || q == i32::MIN);
            prop_assert!((x / lsb).abs() >= 2.0e9);
        }
    }
}

/// `COBS(VERSION | body | CRC)` with its delimiter, built from the crates directly.
fn reference_wire(body: &[u8]) -> Vec<u8> {
    let mut raw = vec![VERSION];
    raw.extend_from_slice(body);
    let crc = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum(&raw);
    raw.extend_from_slice(&crc.to_le_bytes());
    let mut f = cobs::encode_vec(&raw);
    f.push(0);
    f
}

/// The frame of `msg` as postcard + CRC + COBS write it, delimiter included.
fn reference_frame(msg: &Message) -> Vec<u8> {
    reference_wire(&postcard::to_allocvec(msg).expect("postcard"))
}

/// What a decoder's call closed.
type Closed<M> = Option<Result<M, FrameError>>;

/// The host's and the device's results for one frame.
fn decide(frame: &[u8]) -> (Closed<Message>, Closed<Request>) {
    (
        Decoder::new().next_message(frame).0,
        Decoder::new().next_request(frame).0,
    )
}

/// The errors of [`decide`] (`None`: no error).
fn errors(frame: &[u8]) -> (Option<FrameError>, Option<FrameError>) {
    let (host, dev) = decide(frame);
    (host.and_then(Result::err), dev.and_then(Result::err))
}

#[test]
fn overlong_frame_is_a_length_error_then_resync() {
    let ok = Message::Command(Command::RequestStatus);
    let mut stream = vec![0x55u8; MAX_FRAME * 3];
    stream.push(0);
    stream.extend_from_slice(&encode_vec(&ok).expect("fits"));
    assert_eq!(decode_all(&stream), vec![Err(FrameError::Length), Ok(ok)]);
}

#[test]
fn each_error_kind_is_reported() {
    let msg = Message::Command(Command::ResetCounters);
    let body = postcard::to_allocvec(&msg).expect("postcard");
    // Version: another version (the next one) with a valid CRC.
    let mut raw = vec![VERSION.wrapping_add(1)];
    raw.extend_from_slice(&body);
    let mut f = vec![0u8; MAX_FRAME];
    let n = frame_raw(&raw, &mut f).expect("fits");
    let e = Some(FrameError::Version);
    assert_eq!(errors(&f[..n]), (e, e));
    // Postcard: valid CRC over an unknown message type (enum index 9).
    let e = Some(FrameError::Postcard);
    assert_eq!(errors(&reference_wire(&[9])), (e, e));
    // Length: a trailing byte after a valid message.
    let mut long = body.clone();
    long.push(7);
    let e = Some(FrameError::Length);
    assert_eq!(errors(&reference_wire(&long)), (e, e));
    // Length: too short.
    assert_eq!(errors(&[2, 1, 1, 0]), (e, e));
    // COBS: the code byte points past the end.
    let e = Some(FrameError::Cobs);
    assert_eq!(errors(&[9, 1, 1, 0]), (e, e));
    // CRC: one byte changed.
    let mut frame = encode_vec(&msg).expect("fits");
    let last = frame.len() - 2;
    frame[last] ^= 0x10;
    if frame[last] == 0 {
        frame[last] = 0x33;
    }
    let e = Some(FrameError::Crc);
    assert_eq!(errors(&frame), (e, e));
}

/// `next_request` stops after each delimiter and hands back the rest; split frames
/// complete across calls; an empty frame yields nothing.
#[test]
fn next_request_stops_after_each_frame() {
    let a = encode_vec(&Message::Command(Command::RequestStatus)).expect("fits");
    let b = encode_vec(&Message::Command(Command::ResetCounters)).expect("fits");
    let stream = [&a[..], &[0u8][..], &b[..3]].concat();
    let mut dec = Decoder::new();
    let (r, rest) = dec.next_request(&stream);
    assert_eq!(r, Some(Ok(Request::Command(Command::RequestStatus))));
    assert_eq!(rest, &stream[a.len()..]);
    let (r, rest) = dec.next_request(rest);
    assert_eq!(r, None);
    assert_eq!(rest, &b[..3]);
    let (r, rest) = dec.next_request(rest);
    assert_eq!((r, rest.len()), (None, 0));
    let (r, rest) = dec.next_request(&b[3..]);
    assert_eq!(r, Some(Ok(Request::Command(Command::ResetCounters))));
    assert!(rest.is_empty());
}

/// An undefined Command or YawMode index is an unknown request to the device whatever
/// the form of its varint (the host's decoder, which decodes every message, refuses it);
/// a defined index in a longer form is that request; a malformed varint is a decoding
/// error for both.
#[test]
fn an_undefined_index_is_unknown_in_any_varint_form() {
    let decide = |ty: u8, body: &[u8]| {
        let mut raw = vec![ty];
        raw.extend_from_slice(body);
        decide(&reference_wire(&raw))
    };
    let postcard = Some(Err(FrameError::Postcard));
    for (ty, body) in [
        (3u8, vec![5u8]),
        (3, vec![0xC8, 0x01]),
        (3, vec![0x85, 0x00]),
        (3, vec![0xFF, 0xFF, 0xFF, 0xFF, 0x0F]),
        (2, vec![0x83, 0x80, 0x00, 1, 1, 10, 0]),
    ] {
        let unknown = Some(Ok(Request::Unknown));
        assert_eq!(decide(ty, &body), (postcard, unknown), "{ty} {body:x?}");
    }
    // A defined index in a padded form: the request itself, for both decoders.
    let (full, dev) = decide(3, &[0x81, 0x00]);
    assert_eq!(full, Some(Ok(Message::Command(Command::RequestStatus))));
    assert_eq!(dev, Some(Ok(Request::Command(Command::RequestStatus))));
    // Malformed: cut short, or a fifth byte over 0x0F.
    for body in [vec![0x85], vec![0xFF, 0xFF, 0xFF, 0xFF, 0x10]] {
        let (full, dev) = decide(3, &body);
        assert_eq!(
            (full, dev.map(|r| r.err())),
            (postcard, Some(Some(FrameError::Postcard))),
            "{body:x?}"
        );
    }
}
