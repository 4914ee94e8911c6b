//! Arbitrary bytes into the streaming decoders, whole and byte by byte: they must never
//! panic, both chunkings must agree, and every accepted message must re-encode to a
//! frame that decodes to itself.
#![no_main]

use libfuzzer_sys::fuzz_target;
use wheelset_proto::{encode_vec, Decoder};

fuzz_target!(|data: &[u8]| {
    let whole: Vec<_> = Decoder::new().messages(data).collect();
    let mut a = Decoder::new();
    let by_byte: Vec<_> = data.chunks(1).flat_map(|b| a.messages(b).collect::<Vec<_>>()).collect();
    assert_eq!(whole, by_byte);
    let mut dev = Decoder::new();
    let mut rest = data;
    while !rest.is_empty() {
        rest = dev.next_request(rest).1;
    }
    for m in whole.into_iter().flatten() {
        let frame = encode_vec(&m).expect("a decoded message re-encodes");
        let again: Vec<_> = Decoder::new().messages(&frame).collect();
        assert_eq!(again, [Ok(m)]);
    }
});
