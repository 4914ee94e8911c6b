//! No frame with one or two flipped bits is ever accepted: exhaustively over every single
//! flip and every pair of flips of sample frames, and by a property test over random
//! frames and flip positions. The same sweep run through a CRC-16 variant of the framing
//! measures why the format carries CRC-32C.

mod common;

use common::*;
use proptest::prelude::*;
use proptest::strategy::ValueTree;
use proptest::test_runner::{Config as PtConfig, TestRunner};
use wheelset_proto::*;

/// True if the stream (a corrupted frame, then one more delimiter as the next frame would
/// bring) yields any accepted message.
fn accepted(wire: &[u8]) -> bool {
    let mut dec = Decoder::new();
    let any = dec.messages(wire).any(|r| r.is_ok());
    any | matches!(dec.next_message(&[0]).0, Some(Ok(_)))
}

fn flip(wire: &mut [u8], bit: usize) {
    wire[bit / 8] ^= 1 << (bit % 8);
}

/// Counts accepted corruptions over all 1- and 2-bit flips of `wire` with `accept`.
fn sweep(wire: &[u8], accept: impl Fn(&[u8]) -> bool) -> (u64, u64) {
    let bits = wire.len() * 8;
    let (mut tried, mut passed) = (0u64, 0u64);
    let mut w = wire.to_vec();
    for i in 0..bits {
        flip(&mut w, i);
        tried += 1;
        passed += u64::from(accept(&w));
        for j in i + 1..bits {
            flip(&mut w, j);
            tried += 1;
            passed += u64::from(accept(&w));
            flip(&mut w, j);
        }
        flip(&mut w, i);
    }
    (tried, passed)
}

/// The same framing with CRC-16/CCITT (CRC-16/IBM-3740) instead of CRC-32C: test only.
mod crc16 {
    use wheelset_proto::{Message, VERSION};
    const CRC16: crc::Crc<u16> = crc::Crc::<u16>::new(&crc::CRC_16_IBM_3740);

    pub fn encode(msg: &Message) -> Vec<u8> {
        let mut raw = vec![VERSION];
        raw.extend_from_slice(&postcard::to_allocvec(msg).expect("postcard"));
        let c = CRC16.checksum(&raw).to_le_bytes();
        raw.extend_from_slice(&c);
        let mut out = cobs::encode_vec(&raw);
        out.push(0);
        out
    }

    fn decode(enc: &[u8]) -> bool {
        let mut buf = enc.to_vec();
        let Ok(r) = cobs::decode_in_place_report(&mut buf) else {
            return false;
        };
        if r.src_used != enc.len() || r.dst_used < 4 {
            return false;
        }
        let f = &buf[..r.dst_used];
        let (body, c) = f.split_at(f.len() - 2);
        if CRC16.checksum(body) != u16::from_le_bytes([c[0], c[1]]) || body[0] != VERSION {
            return false;
        }
        matches!(
            postcard::take_from_bytes::<Message>(&body[1..]),
            Ok((_, []))
        )
    }

    pub fn accepted(wire: &[u8]) -> bool {
        let mut any = false;
        let mut stream = wire.to_vec();
        stream.push(0);
        for part in stream.split(|&b| b == 0) {
            if !part.is_empty() {
                any |= decode(part);
            }
        }
        any
    }
}

fn sample_frames(n: u32) -> Vec<Message> {
    let mut runner = TestRunner::new_with_rng(
        PtConfig::default(),
        proptest::test_runner::TestRng::deterministic_rng(
            proptest::test_runner::RngAlgorithm::ChaCha,
        ),
    );
    let strat = prop_oneof![
        sensor().prop_map(Message::Sensor),
        actuation().prop_map(Message::Actuation),
    ];
    (0..n)
        .map(|_| strat.new_tree(&mut runner).expect("tree").current())
        .collect()
}

/// Whether a corrupted wire frame reaches the CRC check with a payload that differs from
/// `orig` in more than 3 bits or in length (beyond any CRC's Hamming-distance guarantee:
/// only the CRC's `2^-n` protects against these).
fn structural(wire: &[u8], orig: &[u8]) -> bool {
    let mut stream = wire.to_vec();
    stream.push(0);
    stream
        .split(|&b| b == 0)
        .filter(|p| !p.is_empty())
        .any(|p| {
            let mut b = p.to_vec();
            match cobs::decode_in_place_report(&mut b) {
                Ok(r) if r.src_used == p.len() && r.dst_used >= MIN_DECODED => {
                    let d = &b[..r.dst_used];
                    d.len() != orig.len()
                        || d.iter()
                            .zip(orig)
                            .map(|(x, y)| (x ^ y).count_ones())
                            .sum::<u32>()
                            > 3
                }
                _ => false,
            }
        })
}

#[test]
fn every_one_and_two_bit_flip_is_rejected_exhaustively() {
    let (mut tried, mut passed16, mut tried16, mut reach) = (0u64, 0u64, 0u64, 0u64);
    for msg in sample_frames(120) {
        let wire = encode_vec(&msg).expect("fits");
        let (t, p) = sweep(&wire, accepted);
        assert_eq!(p, 0, "a corrupted frame of {msg:?} was accepted");
        tried += t;
        let mut orig = wire[..wire.len() - 1].to_vec();
        let n = cobs::decode_in_place(&mut orig).expect("valid");
        let orig = &orig[..n];
        reach += sweep(&wire, |w| structural(w, orig)).1;
        let (t16, p16) = sweep(&crc16::encode(&msg), crc16::accepted);
        tried16 += t16;
        passed16 += p16;
    }
    println!(
        "CRC-32C: 0 of {tried} corrupted frames accepted; {reach} reached the CRC with a \
         structurally scrambled payload; CRC-16 variant: {passed16} of {tried16} accepted"
    );
    assert!(tried > 1_000_000);
    // The structural cases exist (so the CRC width matters) but are a small share.
    assert!(reach > 0 && reach < tried / 10);
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(20_000))]

    #[test]
    fn random_frames_random_flips_rejected(msg in message(), a in any::<usize>(), b in any::<usize>(), two in any::<bool>()) {
        let mut wire = encode_vec(&msg).expect("fits").to_vec();
        let bits = wire.len() * 8;
        let (a, b) = (a % bits, b % bits);
        flip(&mut wire, a);
        if two && b != a {
            flip(&mut wire, b);
        }
        prop_assert!(!accepted(&wire));
    }
}
