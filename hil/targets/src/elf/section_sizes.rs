//! Flash and static RAM of a 32-bit little-endian ELF (a Cortex-M firmware), from its
//! section headers: what `arm-none-eabi-size -A` shows, without needing binutils.

/// Memory use of one firmware image, bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sizes {
    /// Loaded into flash: allocated sections with contents (vector table, code,
    /// read-only data, the initial values of `.data`).
    pub flash: u64,
    /// Static RAM: allocated, writable sections (`.data`, `.bss`, `.uninit`).
    pub ram: u64,
}

pub(super) const SHF_WRITE: u32 = 0x1;
pub(super) const SHF_ALLOC: u32 = 0x2;
pub(super) const SHT_NOBITS: u32 = 8;

pub(super) fn u16_at(b: &[u8], at: usize) -> Result<u16, String> {
    b.get(at..at + 2)
        .and_then(|s| s.try_into().ok())
        .map(u16::from_le_bytes)
        .ok_or_else(|| format!("truncated ELF (offset {at})"))
}

pub(super) fn u32_at(b: &[u8], at: usize) -> Result<u32, String> {
    b.get(at..at + 4)
        .and_then(|s| s.try_into().ok())
        .map(u32::from_le_bytes)
        .ok_or_else(|| format!("truncated ELF (offset {at})"))
}

/// The offsets of the section headers of an ELF32 LE image.
pub(super) fn section_headers(b: &[u8]) -> Result<impl Iterator<Item = usize>, String> {
    if b.get(0..4) != Some(b"\x7fELF".as_slice()) {
        return Err("not an ELF file".into());
    }
    if b.get(4) != Some(&1) || b.get(5) != Some(&1) {
        return Err("not a 32-bit little-endian ELF".into());
    }
    let shoff = u32_at(b, 0x20)? as usize;
    let shentsize = u16_at(b, 0x2E)? as usize;
    let shnum = u16_at(b, 0x30)? as usize;
    if shentsize < 0x28 {
        return Err(format!("bad section header size {shentsize}"));
    }
    Ok((0..shnum).map(move |i| shoff + i * shentsize))
}

/// Sums the section sizes of an ELF32 LE image.
pub fn sizes(b: &[u8]) -> Result<Sizes, String> {
    let mut s = Sizes { flash: 0, ram: 0 };
    for h in section_headers(b)? {
        let kind = u32_at(b, h + 0x04)?;
        let flags = u32_at(b, h + 0x08)?;
        let size = u64::from(u32_at(b, h + 0x14)?);
        if flags & SHF_ALLOC == 0 {
            continue;
        }
        if kind != SHT_NOBITS {
            s.flash += size;
        }
        if flags & SHF_WRITE != 0 {
            s.ram += size;
        }
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal ELF32 LE with the given (type, flags, size) sections.
    fn elf(sections: &[(u32, u32, u32)]) -> Vec<u8> {
        let mut b = vec![0u8; 0x34];
        b[0..4].copy_from_slice(b"\x7fELF");
        b[4] = 1;
        b[5] = 1;
        b[0x20..0x24].copy_from_slice(&0x34u32.to_le_bytes());
        b[0x2E..0x30].copy_from_slice(&0x28u16.to_le_bytes());
        b[0x30..0x32].copy_from_slice(&(sections.len() as u16).to_le_bytes());
        for &(kind, flags, size) in sections {
            let mut h = [0u8; 0x28];
            h[4..8].copy_from_slice(&kind.to_le_bytes());
            h[8..12].copy_from_slice(&flags.to_le_bytes());
            h[0x14..0x18].copy_from_slice(&size.to_le_bytes());
            b.extend_from_slice(&h);
        }
        b
    }

    #[test]
    fn counts_loaded_sections_as_flash_and_writable_ones_as_ram() {
        let progbits = 1;
        let image = elf(&[
            (progbits, SHF_ALLOC, 1000),             // .text
            (progbits, SHF_ALLOC, 200),              // .rodata
            (progbits, SHF_ALLOC | SHF_WRITE, 16),   // .data: flash and RAM
            (SHT_NOBITS, SHF_ALLOC | SHF_WRITE, 64), // .bss: RAM only
            (progbits, 0, 5000),                     // .debug_info: neither
        ]);
        assert_eq!(
            sizes(&image),
            Ok(Sizes {
                flash: 1216,
                ram: 80
            })
        );
    }

    #[test]
    fn refuses_what_is_not_an_elf32_le() {
        assert!(sizes(b"hello").is_err());
        let mut image = elf(&[]);
        image[4] = 2; // 64-bit
        assert!(sizes(&image).is_err());
        assert!(sizes(&elf(&[(1, SHF_ALLOC, 4)])[..0x40]).is_err());
    }
}
