//! Arbitrary bytes into the streaming decoder, in two chunkings: it must never panic,
//! both chunkings must agree, and every accepted message must re-encode to a frame that
//! decodes to itself.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wheelset_proto::{encode_vec, Decoder};

fuzz_target!(|data: &[u8]| {
    let mut a: Decoder = Decoder::new();
    let mut by_byte = Vec::new();
    for &b in data {
        if let Some(r) = a.push(b) {
            by_byte.push(r);
        }
    }
    let mut b: Decoder = Decoder::new();
    let mut fed = Vec::new();
    b.feed(data, |r| fed.push(r));
    assert_eq!(by_byte, fed);
    for m in by_byte.into_iter().flatten() {
        let frame = encode_vec(&m).expect("a decoded message re-encodes");
        let mut c: Decoder = Decoder::new();
        let mut again = None;
        c.feed(&frame, |r| again = Some(r));
        assert_eq!(again, Some(Ok(m)));
    }
});
