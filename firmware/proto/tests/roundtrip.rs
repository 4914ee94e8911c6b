//! Every message survives encode -> any chunking -> decode, extremes included; the
//! decoder never panics on arbitrary bytes and resynchronises on 0x00.

mod common;

use common::*;
use proptest::prelude::*;
use wheelset_proto::oracle::*;
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
        let mut dec: Decoder = Decoder::new();
        let mut got = Vec::new();
        let mut prev = 0;
        for c in cuts.into_iter().chain([frame.len()]) {
            dec.feed(&frame[prev..c], |r| got.push(r));
            prev = c;
        }
        prop_assert_eq!(got, vec![Ok(msg)]);
        prop_assert_eq!(dec.pending(), 0);
    }

    /// The device's encoders write exactly the frames of `encode`.
    #[test]
    fn device_encoders_are_encode(a in actuation(), st in status()) {
        let mut buf = [0u8; MAX_FRAME];
        let n = encode_reply(Reply::Actuation(&a), &mut buf).expect("fits");
        prop_assert_eq!(&buf[..n], &encode_vec(&Message::Actuation(a)).expect("fits")[..]);
        let n = encode_reply(Reply::Status(&st), &mut buf).expect("fits");
        prop_assert_eq!(&buf[..n], &encode_vec(&Message::Status(st)).expect("fits")[..]);
        let mut short = [0u8; 8];
        prop_assert_eq!(encode_reply(Reply::Status(&st), &mut short), Err(EncodeError::BufferTooSmall));
    }

    /// The host's one-pass Sensor encoder (and `encode_vec`, which uses it) writes
    /// exactly the frame of the general `encode`.
    #[test]
    fn sensor_encoder_is_encode(s in sensor()) {
        let mut general = [0u8; MAX_FRAME];
        let len = encode(&Message::Sensor(s), &mut general).expect("fits");
        let mut buf = [0xA5u8; SENSOR_FRAME_CAP];
        let n = encode_sensor(&s, &mut buf);
        prop_assert_eq!(&buf[..n], &general[..len]);
        prop_assert_eq!(&encode_vec(&Message::Sensor(s)).expect("fits")[..], &general[..len]);
    }

    /// `encode_actuation` (one pass into a buffer that holds the longest Actuation frame,
    /// the general path otherwise) writes `encode`'s frame into every buffer that holds
    /// it, and refuses every shorter one, as `encode` does.
    #[test]
    fn actuation_encoder_at_every_buffer_length(a in actuation()) {
        let want = encode_vec(&Message::Actuation(a)).expect("fits");
        for len in 0..=MAX_FRAME {
            let mut buf = vec![0xA5u8; len];
            let mut reference = vec![0xA5u8; len];
            let got = encode_reply(Reply::Actuation(&a), &mut buf);
            prop_assert_eq!(got, encode(&Message::Actuation(a), &mut reference), "{}", len);
            match got {
                Ok(n) => prop_assert_eq!(&buf[..n], &want[..], "{}", len),
                Err(_) => prop_assert!(len < want.len(), "{}", len),
            }
        }
    }

    /// The device's decoder agrees with `decode_frame` on every message: the same message
    /// for the host -> device types, `Unexpected` for the others.
    #[test]
    fn device_decoder_is_decode_frame(msg in message()) {
        let frame = encode_vec(&msg).expect("fits");
        let mut dec: Decoder = Decoder::new();
        let mut got = Vec::new();
        dec.feed_requests(&frame, |r| got.push(r));
        let want = match msg {
            Message::Sensor(s) => Request::Sensor(s),
            Message::Config(c) => Request::Config(c),
            Message::Command(c) => Request::Command(c),
            Message::Actuation(_) | Message::Status(_) => Request::Unexpected,
        };
        prop_assert_eq!(got, vec![Ok(want)]);
    }

    /// On arbitrary bytes the two decoders agree, except that the device does not decode
    /// the bodies of the types it does not take; neither panics.
    #[test]
    fn device_decoder_agrees_on_garbage(body in proptest::collection::vec(any::<u8>(), 0..120), ty in 0u8..7) {
        // A CRC-valid frame with a random body of type `ty`, and the raw garbage itself.
        let mut raw = vec![VERSION, ty];
        raw.extend_from_slice(&body);
        raw.extend_from_slice(&CRC.checksum(&raw).to_le_bytes());
        let mut framed = vec![0u8; raw.len() + 2];
        let n = cobs_encode(&raw, &mut framed).expect("fits");
        // Also the garbage with its zeros replaced: COBS-shaped input the decoders must
        // accept or reject alike.
        let mut nonzero: Vec<u8> = body.iter().map(|&b| b.max(1)).collect();
        for bytes in [&mut framed[..n], &mut body.clone()[..], &mut nonzero[..]] {
            let (mut a, mut b) = (bytes.to_vec(), bytes.to_vec());
            let full = decode_frame(&mut a);
            let dev = decode_request(&mut b);
            match (full, dev) {
                (Ok(Message::Sensor(x)), Ok(Request::Sensor(y))) => prop_assert_eq!(x, y),
                (Ok(Message::Config(x)), Ok(Request::Config(y))) => prop_assert_eq!(x, y),
                (Ok(Message::Command(x)), Ok(Request::Command(y))) => prop_assert_eq!(x, y),
                (Ok(Message::Actuation(_) | Message::Status(_)), Ok(Request::Unexpected)) => {}
                (Err(_), Ok(Request::Unexpected)) => prop_assert!(ty == 1 || ty == 4),
                // An undefined Command variant or Config mode: an unknown request.
                (Err(FrameError::Postcard), Ok(Request::Unknown)) => {
                    prop_assert!(ty == 2 || ty == 3);
                    let defined = if ty == 3 { 5 } else { 3 };
                    prop_assert!(leading_varint(&body).is_some_and(|v| v >= defined));
                }
                (Err(e), Err(f)) => prop_assert_eq!(e, f),
                (x, y) => prop_assert!(false, "{:?} vs {:?}", x, y),
            }
        }
    }

    #[test]
    fn encode_into_short_buffer_is_an_error(msg in message()) {
        let n = encode_vec(&msg).expect("fits").len();
        let mut buf = vec![0u8; n - 1];
        prop_assert_eq!(encode(&msg, &mut buf), Err(EncodeError::BufferTooSmall));
    }

    #[test]
    fn cobs_encode_matches_the_cobs_crate(
        data in prop_oneof![
            proptest::collection::vec(any::<u8>(), 0..300),
            proptest::collection::vec(1u8..=255, 0..600),
            proptest::collection::vec(prop_oneof![Just(0u8), 1u8..=255], 0..300),
        ]
    ) {
        let mut ours = vec![0u8; data.len() + data.len() / 254 + 2];
        let mut theirs = ours.clone();
        let n = cobs_encode(&data, &mut ours);
        let m = cobs::try_encode(&data, &mut theirs).ok();
        prop_assert_eq!(n, m);
        if let Some(n) = n {
            prop_assert_eq!(&ours[..n], &theirs[..n]);
        }
        // Too short an output buffer is refused, never a panic.
        let mut short = vec![0u8; data.len() / 2];
        let _ = cobs_encode(&data, &mut short);
    }

    #[test]
    fn cobs_decode_matches_the_cobs_crate(
        data in prop_oneof![
            // Valid encodings (of data with and without zeros, short and > 254 bytes) ...
            proptest::collection::vec(prop_oneof![Just(0u8), 1u8..=255], 0..600)
                .prop_map(|d| cobs::encode_vec(&d)),
            proptest::collection::vec(1u8..=255, 0..600).prop_map(|d| cobs::encode_vec(&d)),
            // ... with a byte changed ...
            (proptest::collection::vec(any::<u8>(), 1..120), any::<usize>(), any::<u8>())
                .prop_map(|(d, i, b)| {
                    let mut e = cobs::encode_vec(&d);
                    let i = i % e.len();
                    e[i] = b;
                    e
                }),
            // ... and arbitrary bytes, mostly without zeros.
            proptest::collection::vec(1u8..=255, 0..300),
            proptest::collection::vec(any::<u8>(), 0..300),
        ]
    ) {
        let mut ours = data.clone();
        let mut theirs = data.clone();
        let n = cobs_decode_in_place(&mut ours);
        let m = match cobs::decode_in_place_report(&mut theirs) {
            Ok(r) if r.src_used == data.len() => Some(r.dst_used),
            _ => None,
        };
        prop_assert_eq!(n, m);
        if let Some(n) = n {
            prop_assert_eq!(&ours[..n], &theirs[..n]);
        }
    }

    #[test]
    fn encode_writes_what_postcard_writes(msg in message()) {
        // Sensor and Actuation bodies are written without serde: same bytes.
        prop_assert_eq!(encode_vec(&msg).expect("fits").to_vec(), reference_frame(&msg));
    }

    #[test]
    fn decode_decides_what_postcard_decides(
        body in prop_oneof![
            // Valid bodies of every message, mutated in one or two bytes, cut or extended.
            (message(), any::<usize>(), any::<u8>(), any::<usize>(), any::<u8>(), 0usize..3, any::<u8>())
                .prop_map(|(m, i, b, j, c, how, extra)| {
                    let mut v = postcard::to_allocvec(&m).expect("postcard");
                    match how {
                        0 => {
                            let n = v.len();
                            v[i % n] = b;
                            v[j % n] ^= c;
                        }
                        1 => v.truncate(i % (v.len() + 1)),
                        _ => v.push(extra),
                    }
                    v
                }),
            // Arbitrary bodies of every type (and an unknown one), varint-heavy bytes
            // included, some with the type as a zero-padded varint.
            (0u8..6, any::<bool>(), proptest::collection::vec(prop_oneof![any::<u8>(), 0x80u8..=0xFF, 0u8..0x20, 0u8..2], 0..90))
                .prop_map(|(t, padded, rest)| {
                    let ty = if padded { vec![t | 0x80, 0] } else { vec![t] };
                    [ty, rest].concat()
                }),
            // A valid body whose type is written as a zero-padded varint.
            message().prop_map(|m| {
                let mut v = postcard::to_allocvec(&m).expect("postcard");
                v[0] |= 0x80;
                v.insert(1, 0);
                v
            }),
        ]
    ) {
        let mut frame = reference_wire(&body);
        let ours = decode_frame(&mut frame);
        let theirs = match postcard::take_from_bytes::<Message>(&body) {
            // (No type byte: shorter than MIN_DECODED.)
            _ if body.is_empty() => Err(FrameError::Length),
            Ok((m, [])) => Ok(m),
            Ok(_) => Err(FrameError::Length),
            Err(_) => Err(FrameError::Postcard),
        };
        prop_assert_eq!(ours, theirs);
    }

    #[test]
    fn crc_table_choice_does_not_change_the_checksum(data in proptest::collection::vec(any::<u8>(), 0..200)) {
        let reference = crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISCSI);
        prop_assert_eq!(CRC.checksum(&data), reference.checksum(&data));
        // The frame path's own CRC (slice-by-16 on the host) too.
        prop_assert_eq!(crc32c(&data), reference.checksum(&data));
    }

    #[test]
    fn arbitrary_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..600)) {
        let results = decode_all(&bytes);
        // One result per non-empty run closed by a delimiter, at most.
        prop_assert!(results.len() <= bytes.iter().filter(|&&b| b == 0).count());
    }

    #[test]
    fn feed_equals_push_byte_by_byte(
        parts in proptest::collection::vec(
            prop_oneof![
                message().prop_map(|m| encode_vec(&m).expect("fits").to_vec()),
                proptest::collection::vec(any::<u8>(), 0..250),
            ],
            0..8,
        ),
        cut in 0usize..400,
    ) {
        let stream: Vec<u8> = parts.concat();
        let mut a: Decoder = Decoder::new();
        let mut by_byte = Vec::new();
        for &b in &stream {
            if let Some(r) = a.push(b) {
                by_byte.push(r);
            }
        }
        let mut b: Decoder = Decoder::new();
        let mut fed = Vec::new();
        let cut = cut.min(stream.len());
        b.feed(&stream[..cut], |r| fed.push(r));
        b.feed(&stream[cut..], |r| fed.push(r));
        prop_assert_eq!(by_byte, fed);
        prop_assert_eq!(a.pending(), b.pending());
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

/// `COBS(VERSION | body | CRC)` without the delimiter, built from the crates directly.
fn reference_wire(body: &[u8]) -> Vec<u8> {
    let mut raw = vec![VERSION];
    raw.extend_from_slice(body);
    let crc = CRC.checksum(&raw).to_le_bytes();
    raw.extend_from_slice(&crc);
    cobs::encode_vec(&raw)
}

/// The frame of `msg` as postcard + CRC + COBS write it, delimiter included.
fn reference_frame(msg: &Message) -> Vec<u8> {
    let mut f = reference_wire(&postcard::to_allocvec(msg).expect("postcard"));
    f.push(0);
    f
}

#[test]
fn crc_is_crc32c() {
    // The catalogue's check value of CRC-32C over "123456789".
    assert_eq!(CRC.checksum(b"123456789"), 0xE306_9283);
    assert_eq!(crc32c(b"123456789"), 0xE306_9283);
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
    let mut raw = [0u8; MAX_FRAME];
    // Version: re-frame with another version (the next one) and a valid CRC.
    let mut body = vec![VERSION.wrapping_add(1)];
    body.extend_from_slice(&postcard::to_allocvec(&msg).expect("postcard"));
    let mut with_crc = body.clone();
    with_crc.extend_from_slice(&CRC.checksum(&body).to_le_bytes());
    let n = cobs::encode(&with_crc, &mut raw);
    assert_eq!(
        decode_frame(&mut raw[..n].to_vec()),
        Err(FrameError::Version)
    );

    // Postcard: valid CRC over an unknown message type (enum index 9).
    let body = vec![VERSION, 9];
    let mut with_crc = body.clone();
    with_crc.extend_from_slice(&CRC.checksum(&body).to_le_bytes());
    let n = cobs::encode(&with_crc, &mut raw);
    assert_eq!(
        decode_frame(&mut raw[..n].to_vec()),
        Err(FrameError::Postcard)
    );

    // Length: trailing byte after a valid message.
    let mut body = vec![VERSION];
    body.extend_from_slice(&postcard::to_allocvec(&msg).expect("postcard"));
    body.push(7);
    let mut with_crc = body.clone();
    with_crc.extend_from_slice(&CRC.checksum(&body).to_le_bytes());
    let n = cobs::encode(&with_crc, &mut raw);
    assert_eq!(
        decode_frame(&mut raw[..n].to_vec()),
        Err(FrameError::Length)
    );

    // Length: too short.
    assert_eq!(decode_frame(&mut [2, 1, 1]), Err(FrameError::Length));
    // COBS: the code byte points past the end.
    assert_eq!(decode_frame(&mut [9, 1, 1]), Err(FrameError::Cobs));
    // CRC: one byte changed.
    let mut frame = encode_vec(&msg).expect("fits");
    let last = frame.len() - 2;
    frame[last] ^= 0x10;
    if frame[last] == 0 {
        frame[last] = 0x33;
    }
    assert_eq!(decode_all(&frame), vec![Err(FrameError::Crc)]);
}

/// What postcard decides on a body, as `decode_frame` reports it.
fn postcard_decides(body: &[u8]) -> Result<Message, FrameError> {
    match postcard::take_from_bytes::<Message>(body) {
        _ if body.is_empty() => Err(FrameError::Length),
        Ok((m, [])) => Ok(m),
        Ok(_) => Err(FrameError::Length),
        Err(_) => Err(FrameError::Postcard),
    }
}

/// The edges of postcard's rules that random bodies rarely reach, one field of a valid
/// Config at a time: varint lengths and last-byte limits of u16/u32/u64 (valid, padded,
/// too long, last byte one over), bool and Option bytes 0/1/2, enum indices in and out
/// of range, padded type bytes.
#[test]
fn config_edges_decide_as_postcard() {
    let varints: Vec<Vec<u8>> = vec![
        vec![0x00],
        vec![0x7F],
        vec![0x80, 0x00],
        vec![0xFF, 0x7F],
        vec![0x80, 0x80, 0x03],
        vec![0x80, 0x80, 0x04],
        vec![0xFF, 0xFF, 0x03],
        vec![0x80, 0x80, 0x80, 0x00],
        vec![0x80, 0x80, 0x80, 0x80, 0x0F],
        vec![0x80, 0x80, 0x80, 0x80, 0x10],
        vec![0xFF, 0xFF, 0xFF, 0xFF, 0x0F],
        vec![0x80, 0x80, 0x80, 0x80, 0x80, 0x00],
        [vec![0x80; 9], vec![0x01]].concat(),
        [vec![0x80; 9], vec![0x02]].concat(),
        [vec![0xFF; 9], vec![0x01]].concat(),
        vec![0x80; 10],
        vec![0x80; 11],
    ];
    let small: Vec<Vec<u8>> = (0u8..4).map(|b| vec![b]).chain(varints.clone()).collect();
    // type, mode, traction, enable, hold_ticks, Some, numeric, fingerprint (4 raw),
    // base rate, yaw div, traction div, six u32 coefficients, two fixint u64 (8 raw).
    let base: Vec<Vec<u8>> = [
        vec![
            vec![2],
            vec![2],
            vec![1],
            vec![0],
            vec![10],
            vec![1],
            vec![0],
        ],
        vec![vec![1, 2, 3, 4]],
        vec![vec![0x88, 0x27]; 3],
        vec![vec![5]; 6],
        vec![vec![7, 0, 0, 0, 0, 0, 0, 0]; 2],
    ]
    .concat();
    let mut tried = 0;
    for field in 0..base.len() {
        let choices = match field {
            0..=3 | 5 | 6 => &small,
            7 | 17 | 18 => continue, // raw bytes: any value is valid
            _ => &varints,
        };
        for c in choices {
            let mut parts = base.clone();
            parts[field] = c.clone();
            let body = parts.concat();
            let mut frame = reference_wire(&body);
            assert_eq!(
                decode_frame(&mut frame),
                postcard_decides(&body),
                "field {field}, bytes {c:02x?}"
            );
            // Cut short, and with a byte left over.
            for b in [&body[..body.len() - 1], &[&body[..], &[0]].concat()[..]] {
                let mut frame = reference_wire(b);
                assert_eq!(decode_frame(&mut frame), postcard_decides(b));
            }
            tried += 1;
        }
    }
    assert!(tried > 250, "{tried}");
    // Commands and a Status too, with their type padded.
    for body in [
        vec![0x83, 0x00, 0x01],
        vec![0x83, 0x00, 0x02],
        vec![0x84, 0x80, 0x00],
    ] {
        let mut frame = reference_wire(&body);
        assert_eq!(
            decode_frame(&mut frame),
            postcard_decides(&body),
            "{body:02x?}"
        );
    }
}

/// `next_request` stops after each delimiter and hands back the rest; split frames
/// complete across calls; an empty frame yields nothing.
#[test]
fn next_request_stops_after_each_frame() {
    let a = encode_vec(&Message::Command(Command::RequestStatus)).expect("fits");
    let b = encode_vec(&Message::Command(Command::ResetCounters)).expect("fits");
    let stream = [&a[..], &[0u8][..], &b[..3]].concat();
    let mut dec: Decoder = Decoder::new();
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

/// A body's leading varint as postcard reads a `u32` (at most 5 bytes, the fifth at most
/// 0x0F); `None` if malformed.
fn leading_varint(body: &[u8]) -> Option<u32> {
    let mut v = 0u32;
    for (i, &b) in body.iter().take(5).enumerate() {
        if i == 4 && b > 0x0F {
            return None;
        }
        v |= u32::from(b & 0x7F) << (7 * i);
        if b < 0x80 {
            return Some(v);
        }
    }
    None
}

/// An undefined Command or YawMode index is an unknown request whatever the form of its
/// varint; a defined index in a longer form is that request; a malformed varint is a
/// decoding error (as `decode_frame` says, which decodes every message).
#[test]
fn an_undefined_index_is_unknown_in_any_varint_form() {
    let decide = |ty: u8, body: &[u8]| {
        let mut raw = vec![ty];
        raw.extend_from_slice(body);
        let mut f = reference_wire(&raw);
        let full = decode_frame(&mut f.clone());
        (full, decode_request(&mut f))
    };
    for (ty, body) in [
        (3u8, vec![5u8]),
        (3, vec![0xC8, 0x01]),
        (3, vec![0x85, 0x00]),
        (3, vec![0xFF, 0xFF, 0xFF, 0xFF, 0x0F]),
        (2, vec![0x83, 0x80, 0x00, 1, 1, 10, 0]),
    ] {
        let (full, dev) = decide(ty, &body);
        assert_eq!(full, Err(FrameError::Postcard), "{ty} {body:x?}");
        assert_eq!(dev, Ok(Request::Unknown), "{ty} {body:x?}");
    }
    // A defined index in a padded form: the request itself, for both decoders.
    let (full, dev) = decide(3, &[0x81, 0x00]);
    assert_eq!(full, Ok(Message::Command(Command::RequestStatus)));
    assert_eq!(dev, Ok(Request::Command(Command::RequestStatus)));
    // Malformed: cut short, or a fifth byte over 0x0F.
    for body in [vec![0x85], vec![0xFF, 0xFF, 0xFF, 0xFF, 0x10]] {
        let (full, dev) = decide(3, &body);
        assert_eq!(full, Err(FrameError::Postcard), "{body:x?}");
        assert_eq!(dev, Err(FrameError::Postcard), "{body:x?}");
    }
}
