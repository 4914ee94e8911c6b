//! The frames' CRC-32C (Castagnoli, reflected, init and final XOR `0xFFFF_FFFF`): the
//! `crc` crate's table for the host, a slice-by-16 table built at compile time for the
//! device, and the byte-wise register the streaming decoder checks against the residue.

/// The frame CRC: CRC-32C (Castagnoli, `crc::CRC_32_ISCSI`), stored little-endian.
///
/// Why 32 bits: a 1- or 2-bit flip inside COBS data bytes is a 1- or 2-bit error of the
/// payload, which any CRC with Hamming distance >= 3 rejects (CRC-16/CCITT: HD 4 up to
/// 32 751 bits). But a flip in a COBS code byte, or one that creates or destroys a 0x00
/// delimiter, moves zeros around or splits/merges frames: the decoded payload then differs
/// in many bits, and a CRC rejects it only with probability `1 - 2^-n`.
///
/// Measured (`cargo test -p wheelset-proto --test flips -- --nocapture`): of the 2.44 M
/// one- and two-bit corruptions of 120 random Sensor/Actuation frames, 51 446 (2.1 %)
/// reach the CRC with a scrambled payload. At BER 1e-3 a 23-byte frame takes a structural
/// hit with probability ~4e-3; with 16 bits `4e-3 * 2^-16` ~ 6e-8 per frame pass the CRC
/// (before the version and exact-length checks), i.e. at 2 x 2000 frames/s an undetected,
/// wrong torque command every ~70 min. CRC-32C makes it `2^-32` (~9 years of continuous
/// BER 1e-3, before the version and length checks) for two more
/// bytes per frame. Castagnoli's polynomial keeps Hamming distance 6 at these lengths.
///
/// One implementation per target: on the host (the `std` feature), where the simulated
/// loop encodes and decodes four frames per period, slice-by-16 over tables built at
/// compile time (16 KiB, [`HostCrc`]); on the device, byte-wise over a 1 KiB table built
/// in RAM on first use ([`crate::RamCrc`]: no flash for the table). Same polynomial, same
/// checksums; the `crc` crate is the test oracle of both.
#[cfg(feature = "std")]
pub static CRC: HostCrc = HostCrc;
/// See the `std` variant.
#[cfg(not(feature = "std"))]
pub static CRC: crate::RamCrc = crate::RamCrc::new();

/// The host's CRC-32C (the `std` feature): slice-by-16 over compile-time tables
/// specialised to CRC-32C (reflected, init and xor-out `0xFFFF_FFFF`), where a generic
/// table-driven CRC reads the algorithm's parameters at run time.
#[cfg(feature = "std")]
#[derive(Debug, Clone, Copy)]
pub struct HostCrc;

#[cfg(feature = "std")]
impl HostCrc {
    /// The CRC-32C of `bytes` (as the `crc` crate's `CRC_32_ISCSI` checksum).
    #[must_use]
    pub fn checksum(&self, bytes: &[u8]) -> u32 {
        slice16(bytes)
    }
}

/// The frame CRC of `bytes`: CRC-32C, the same value as [`CRC`]`.checksum(bytes)`:
/// [`HostCrc`] on the host (`std`), the byte-wise table in RAM on the device
/// ([`crate::RamCrc`]).
#[must_use]
pub fn crc32c(bytes: &[u8]) -> u32 {
    #[cfg(feature = "std")]
    {
        slice16(bytes)
    }
    #[cfg(not(feature = "std"))]
    {
        CRC.checksum(bytes)
    }
}

/// `TABLES[k][b]`: the CRC-32C register contribution of byte `b` followed by `k` zero
/// bytes (reflected polynomial `0x82F6_3B78`). (Compiled without `std` too, so the
/// crate's own tests check it; unused there, the linker drops it.)
static TABLES: [[u32; 256]; 16] = crc_tables();

const fn crc_tables() -> [[u32; 256]; 16] {
    let mut t = [[0u32; 256]; 16];
    let mut i = 0;
    while i < 256 {
        // The one-byte step from a zero register is the byte-wise table's entry.
        t[0][i] = crc_byte_const(0, i as u8);
        i += 1;
    }
    let mut k = 1;
    while k < 16 {
        let mut i = 0;
        while i < 256 {
            let prev = t[k - 1][i];
            t[k][i] = (prev >> 8) ^ t[0][(prev & 0xFF) as usize];
            i += 1;
        }
        k += 1;
    }
    t
}

#[cfg_attr(not(feature = "std"), allow(dead_code))]
fn slice16(bytes: &[u8]) -> u32 {
    let t = &TABLES;
    let mut crc = !0u32;
    let mut chunks = bytes.chunks_exact(16);
    for c in &mut chunks {
        let mut w = [0u8; 16];
        w.copy_from_slice(c);
        let [a0, a1, a2, a3] = (u32::from_le_bytes([w[0], w[1], w[2], w[3]]) ^ crc).to_le_bytes();
        crc = t[15][usize::from(a0)]
            ^ t[14][usize::from(a1)]
            ^ t[13][usize::from(a2)]
            ^ t[12][usize::from(a3)]
            ^ t[11][usize::from(w[4])]
            ^ t[10][usize::from(w[5])]
            ^ t[9][usize::from(w[6])]
            ^ t[8][usize::from(w[7])]
            ^ t[7][usize::from(w[8])]
            ^ t[6][usize::from(w[9])]
            ^ t[5][usize::from(w[10])]
            ^ t[4][usize::from(w[11])]
            ^ t[3][usize::from(w[12])]
            ^ t[2][usize::from(w[13])]
            ^ t[1][usize::from(w[14])]
            ^ t[0][usize::from(w[15])];
    }
    // The 0..15 bytes left: slices of 8, 4 and then 1..3 bytes, each step's table
    // look-ups independent of each other (a byte-at-a-time tail is a chain of dependent
    // loads: with ~20-byte frames it took most of the CRC's time, `perf`).
    let mut rest = chunks.remainder();
    if let Some((c, r)) = rest.split_first_chunk::<8>() {
        let [a0, a1, a2, a3] = (u32::from_le_bytes([c[0], c[1], c[2], c[3]]) ^ crc).to_le_bytes();
        crc = t[7][usize::from(a0)]
            ^ t[6][usize::from(a1)]
            ^ t[5][usize::from(a2)]
            ^ t[4][usize::from(a3)]
            ^ t[3][usize::from(c[4])]
            ^ t[2][usize::from(c[5])]
            ^ t[1][usize::from(c[6])]
            ^ t[0][usize::from(c[7])];
        rest = r;
    }
    if let Some((c, r)) = rest.split_first_chunk::<4>() {
        let [a0, a1, a2, a3] = (u32::from_le_bytes(*c) ^ crc).to_le_bytes();
        crc = t[3][usize::from(a0)]
            ^ t[2][usize::from(a1)]
            ^ t[1][usize::from(a2)]
            ^ t[0][usize::from(a3)];
        rest = r;
    }
    // k = 1..3 bytes: crc' = (crc >> 8k) ^ sum over j of t[k-1-j][byte j of (crc ^ bytes)].
    match *rest {
        [b0] => crc = (crc >> 8) ^ t[0][usize::from((crc as u8) ^ b0)],
        [b0, b1] => {
            let [a0, a1, _, _] = crc.to_le_bytes();
            crc = (crc >> 16) ^ t[1][usize::from(a0 ^ b0)] ^ t[0][usize::from(a1 ^ b1)];
        }
        [b0, b1, b2] => {
            let [a0, a1, a2, _] = crc.to_le_bytes();
            crc = (crc >> 24)
                ^ t[2][usize::from(a0 ^ b0)]
                ^ t[1][usize::from(a1 ^ b1)]
                ^ t[0][usize::from(a2 ^ b2)];
        }
        _ => {}
    }
    !crc
}

/// The CRC-32C register (reflected, before the final XOR) after a frame's bytes
/// followed by their own CRC, little-endian: the same for every frame (the CRC's
/// residue), so a receiver that runs the register over all the decoded bytes, CRC
/// included, checks the CRC with one compare.
pub(crate) const CRC_RESIDUE: u32 = 0xB798_B438;

/// One byte into the CRC-32C register (reflected, no final XOR: start from `!0`,
/// compare with [`CRC_RESIDUE`]). Call [`crc_ready`] once before a run of these.
#[inline(always)]
pub(crate) fn crc_byte(reg: u32, b: u8) -> u32 {
    #[cfg(feature = "std")]
    {
        TABLES[0][usize::from((reg as u8) ^ b)] ^ (reg >> 8)
    }
    #[cfg(not(feature = "std"))]
    {
        CRC.step(reg, b)
    }
}

/// [`crc_byte`] bit by bit, no table (reflected polynomial `0x82F6_3B78`): at compile
/// time the register after bytes known in advance (a frame's version and type) and the
/// slice-by-16 tables; at start-up the device's RAM table (`crc_ram`, from a zero
/// register).
pub(crate) const fn crc_byte_const(reg: u32, b: u8) -> u32 {
    let mut c = reg ^ b as u32;
    let mut k = 0;
    while k < 8 {
        c = if c & 1 != 0 {
            (c >> 1) ^ 0x82F6_3B78
        } else {
            c >> 1
        };
        k += 1;
    }
    c
}

/// Makes [`crc_byte`]'s table ready (the device's RAM table is filled on first use).
#[inline(always)]
pub(crate) fn crc_ready() {
    #[cfg(not(feature = "std"))]
    CRC.ensure();
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn slice16_is_crc32c_at_every_length() {
        // Every tail (0..15 bytes after the 16-byte blocks) and offset, pseudo-random data.
        let mut x = 0x1234_5678u32;
        let mut data = [0u8; 300];
        for d in &mut data {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            *d = x as u8;
        }
        let reference = crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISCSI);
        for start in 0..20 {
            for len in 0..=120 {
                let d = &data[start..start + len];
                assert_eq!(
                    slice16(d),
                    reference.checksum(d),
                    "offset {start}, {len} bytes"
                );
            }
        }
        assert_eq!(slice16(b"123456789"), 0xE306_9283);
    }

    /// This build's frame CRC, as the encoder and the streaming decoder use it, against
    /// the `crc` crate: with `std` the host's slice-by-16, without it the device's RAM
    /// table (`cargo xtest` runs this crate's tests without `std` too, so both are
    /// tested on the host).
    #[test]
    fn the_frame_crc_of_this_build_is_the_crc_crates() {
        #[cfg(not(feature = "std"))]
        let _: &crate::RamCrc = &CRC;
        let reference = crc::Crc::<u32, crc::NoTable>::new(&crc::CRC_32_ISCSI);
        let mut x = 0x9E37_79B9u32;
        let mut data = [0u8; crate::MAX_RAW];
        for d in &mut data {
            x ^= x << 13;
            x ^= x >> 17;
            x ^= x << 5;
            *d = x as u8;
        }
        crc_ready();
        for len in 0..=data.len() {
            let d = &data[..len];
            let want = reference.checksum(d);
            assert_eq!(crc32c(d), want, "{len} bytes");
            assert_eq!(CRC.checksum(d), want, "{len} bytes");
            // The decoder's register over the bytes and their CRC ends at the residue.
            let reg = d
                .iter()
                .chain(&want.to_le_bytes())
                .fold(!0u32, |r, &b| crc_byte(r, b));
            assert_eq!(reg, CRC_RESIDUE, "{len} bytes");
        }
    }

    #[test]
    fn the_const_step_is_the_table_step() {
        crc_ready();
        for reg in [0u32, !0, 0x1234_5678, 0xDEAD_BEEF] {
            for b in 0..=255u8 {
                assert_eq!(crc_byte_const(reg, b), crc_byte(reg, b), "{reg:08x} {b}");
            }
        }
    }
}
