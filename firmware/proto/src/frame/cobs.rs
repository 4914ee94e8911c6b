//! Consistent overhead byte stuffing: a frame without `0x00` inside, so the delimiter
//! marks its end (encode; decode in place and into a second buffer).

/// COBS-encodes `src` into `dst` (no delimiter); returns the encoded length, or None if
/// `dst` is too short. Output identical to `cobs::try_encode` (tested against it).
///
/// Inputs shorter than 254 bytes (every frame of ours: at most [`MAX_RAW`] + [`CRC_LEN`])
/// need no 0xFF blocks and take a single pass with one bound check for the whole
/// output; longer ones take the general loop (`encode_blocks`), with 0xFF blocks. The
/// `cobs` crate is the test oracle of both.
///
/// [`MAX_RAW`]: super::MAX_RAW
/// [`CRC_LEN`]: super::CRC_LEN
pub fn cobs_encode(src: &[u8], dst: &mut [u8]) -> Option<usize> {
    if src.is_empty() {
        return Some(0);
    }
    if src.len() >= 254 {
        return encode_blocks(src, dst);
    }
    let out = dst.get_mut(..=src.len())?;
    let (mut code_idx, mut code) = (0usize, 1u8);
    for (i, &b) in src.iter().enumerate() {
        if b == 0 {
            *out.get_mut(code_idx)? = code;
            code_idx = i + 1;
            code = 1;
        } else {
            *out.get_mut(i + 1)? = b;
            code += 1;
        }
    }
    *out.get_mut(code_idx)? = code;
    Some(src.len() + 1)
}

/// [`cobs_encode`] of any input: a full block (254 data bytes) is closed with the code
/// 0xFF and no implied 0x00; a full block at the very end of the input opens no empty
/// block after it (as the `cobs` crate encodes).
fn encode_blocks(src: &[u8], dst: &mut [u8]) -> Option<usize> {
    let (mut code_idx, mut code, mut o) = (0usize, 1u8, 1usize);
    for (i, &b) in src.iter().enumerate() {
        if b == 0 {
            *dst.get_mut(code_idx)? = code;
            code_idx = o;
            o += 1;
            code = 1;
        } else {
            *dst.get_mut(o)? = b;
            o += 1;
            code += 1;
            if code == 0xFF {
                *dst.get_mut(code_idx)? = code;
                if i + 1 == src.len() {
                    return Some(o);
                }
                code_idx = o;
                o += 1;
                code = 1;
            }
        }
    }
    *dst.get_mut(code_idx)? = code;
    Some(o)
}

/// COBS-decodes a whole frame (the bytes between two delimiters, no 0x00) in place;
/// returns the decoded length, or None if `buf` is empty, contains a 0x00, or a code
/// byte points past its end. Accepts and rejects exactly what
/// `cobs::decode_in_place_report` does with `src_used == buf.len()` (tested against it),
/// with a scan for 0x00 and one block copy per code byte: the crate's general decoder
/// (bounds-checked byte by byte) measured about 20 instructions per byte (callgrind),
/// the largest single cost of decoding a frame in the host's closed loop.
pub fn cobs_decode_in_place(buf: &mut [u8]) -> Option<usize> {
    // A 0x00 anywhere ends the crate's frame early: `src_used` would fall short.
    if buf.contains(&0) {
        return None;
    }
    cobs_decode_nonzero(buf)
}

/// [`cobs_decode_in_place`] of bytes known to hold no 0x00 (the [`crate::Decoder`]'s
/// buffer: it splits at every delimiter), without scanning for one.
pub(crate) fn cobs_decode_nonzero(buf: &mut [u8]) -> Option<usize> {
    if buf.is_empty() {
        return None;
    }
    let end = buf.len();
    let (mut src, mut dst) = (0usize, 0usize);
    while let Some(&code) = buf.get(src) {
        let code = usize::from(code);
        // The block's `code - 1` data bytes must lie within (a 0x00 code, impossible
        // here, would not advance: refused).
        let next = src + code;
        if code == 0 || next > end {
            return None;
        }
        if code > 1 {
            // In range (checked above); `dst <= src`, so the move is within `buf`.
            buf.copy_within(src + 1..next, dst);
        }
        src = next;
        dst += code - 1;
        if code != 0xFF && src < end {
            *buf.get_mut(dst)? = 0;
            dst += 1;
        }
    }
    Some(dst)
}

#[cfg(any(test, feature = "test-support"))]
/// [`cobs_decode_nonzero`] from `src` into another buffer `dst` (at least as long):
/// the same accept/reject decisions and output (tested through [`decode_request`]),
/// with block copies between distinct buffers (`memcpy`) instead of moves within one
/// (`memmove`, 1.5 KiB of library code the device has no other use for).
pub(super) fn cobs_decode_nonzero_to(src: &[u8], dst: &mut [u8]) -> Option<usize> {
    if src.is_empty() {
        return None;
    }
    let end = src.len();
    let (mut s, mut d) = (0usize, 0usize);
    while let Some(&code) = src.get(s) {
        let code = usize::from(code);
        let next = s + code;
        if code == 0 || next > end {
            return None;
        }
        if code > 1 {
            dst.get_mut(d..d + code - 1)?
                .copy_from_slice(src.get(s + 1..next)?);
        }
        s = next;
        d += code - 1;
        if code != 0xFF && s < end {
            *dst.get_mut(d)? = 0;
            d += 1;
        }
    }
    Some(d)
}

#[cfg(test)]
mod tests {
    extern crate std;
    use super::*;
    use std::{vec, vec::Vec};

    /// The block boundaries the proptest of `tests/roundtrip.rs` reaches only by chance:
    /// inputs ending at, just before and just after a full block, with and without zeros.
    #[test]
    fn full_blocks_match_the_cobs_crate() {
        for len in [253, 254, 255, 256, 507, 508, 509, 600] {
            for zero_at in [None, Some(0), Some(253), Some(254), Some(len - 1)] {
                let mut src: Vec<u8> = (0..len).map(|i| (i % 255 + 1) as u8).collect();
                if let Some(z) = zero_at.filter(|&z| z < len) {
                    src[z] = 0;
                }
                let mut ours = vec![0u8; len + len / 254 + 2];
                let mut theirs = ours.clone();
                let n = cobs_encode(&src, &mut ours).expect("fits");
                let m = cobs::try_encode(&src, &mut theirs).expect("fits");
                assert_eq!(&ours[..n], &theirs[..m], "len {len}, zero at {zero_at:?}");
                let mut back = ours[..n].to_vec();
                let k = cobs_decode_in_place(&mut back).expect("decodes");
                assert_eq!(&back[..k], &src[..], "len {len}, zero at {zero_at:?}");
                for short in 0..n {
                    assert_eq!(cobs_encode(&src, &mut vec![0u8; short]), None, "{short}");
                }
            }
        }
    }
}
