//! CRC-32C with its byte-wise table in RAM, built on first use: the device's CRC.
//!
//! The `crc` crate's byte-wise table is a 1 KiB constant, i.e. 1 KiB of flash; here it
//! is 1 KiB of `.bss` instead. Same algorithm as `crc::CRC_32_ISCSI` (reflected polynomial `0x82F63B78`,
//! initial value and final XOR `0xFFFFFFFF`), same per-byte work (one table load, a
//! shift and two XORs); the table is filled in zero-initialised RAM by the first
//! checksum (about 10 000 instructions on the Cortex-M4: `wheelset-runtime` makes that
//! call at start-up, outside the ticks). Tested against the `crc` crate.

use core::sync::atomic::{AtomicBool, AtomicU32, Ordering};

/// A CRC-32C whose byte-wise table lives in RAM (`.bss`), filled on first use.
///
/// Atomics instead of `unsafe`: a relaxed `AtomicU32` load is a plain `LDR` on
/// Cortex-M. Two contexts racing to fill the table write the same values.
#[derive(Debug)]
pub struct RamCrc {
    table: [AtomicU32; 256],
    ready: AtomicBool,
}

impl Default for RamCrc {
    fn default() -> Self {
        Self::new()
    }
}

impl RamCrc {
    /// An empty table (all zero: it lives in `.bss`, not in flash).
    #[must_use]
    pub const fn new() -> Self {
        Self {
            table: [const { AtomicU32::new(0) }; 256],
            ready: AtomicBool::new(false),
        }
    }

    /// The CRC-32C of `bytes` (as `crc::Crc::<u32>::new(&crc::CRC_32_ISCSI).checksum`).
    pub fn checksum(&self, bytes: &[u8]) -> u32 {
        if !self.ready.load(Ordering::Acquire) {
            self.fill();
        }
        let mut crc = !0u32;
        for &b in bytes {
            let i = ((crc ^ u32::from(b)) & 0xff) as usize;
            crc = self.table[i].load(Ordering::Relaxed) ^ (crc >> 8);
        }
        !crc
    }

    /// Fills the table if it is not yet (before a run of [`Self::step`]).
    #[inline(always)]
    pub fn ensure(&self) {
        if !self.ready.load(Ordering::Acquire) {
            self.fill();
        }
    }

    /// One byte into the register (reflected, no final XOR): `T[(reg ^ b) & 0xFF] ^
    /// (reg >> 8)`, four instructions. The table must be ready ([`Self::ensure`]).
    #[inline(always)]
    pub fn step(&self, reg: u32, b: u8) -> u32 {
        self.table[usize::from((reg as u8) ^ b)].load(Ordering::Relaxed) ^ (reg >> 8)
    }

    #[cold]
    #[inline(never)]
    fn fill(&self) {
        for (i, slot) in self.table.iter().enumerate() {
            // The bit-wise step from a zero register is the table's entry (`i < 256`).
            slot.store(crate::frame::crc_byte_const(0, i as u8), Ordering::Relaxed);
        }
        self.ready.store(true, Ordering::Release);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_crc_crate() {
        let reference = crc::Crc::<u32>::new(&crc::CRC_32_ISCSI);
        let ours = RamCrc::new();
        assert_eq!(ours.checksum(b"123456789"), 0xE306_9283);
        let mut data = [0u8; 300];
        let mut s = 0x1234_5678u32;
        for n in 0..data.len() {
            for b in data.iter_mut() {
                s ^= s << 13;
                s ^= s >> 17;
                s ^= s << 5;
                *b = s as u8;
            }
            assert_eq!(
                ours.checksum(&data[..n]),
                reference.checksum(&data[..n]),
                "{n}"
            );
            // The register stepped over the bytes and their CRC (little-endian) ends
            // at the residue the streaming decoder compares with.
            ours.ensure();
            let crc = ours.checksum(&data[..n]).to_le_bytes();
            let reg = data[..n]
                .iter()
                .chain(&crc)
                .fold(!0u32, |r, &b| ours.step(r, b));
            assert_eq!(reg, crate::frame::CRC_RESIDUE, "{n}");
            let mut bad = crc;
            bad[n % 4] ^= 1 << (n % 8);
            let reg = data[..n]
                .iter()
                .chain(&bad)
                .fold(!0u32, |r, &b| ours.step(r, b));
            assert_ne!(reg, crate::frame::CRC_RESIDUE, "{n}");
        }
    }
}
