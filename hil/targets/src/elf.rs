//! The firmware's ELF images, read without binutils: [`check_target_elf`] (so a host or
//! garbage image is refused by name before QEMU is launched), [`sizes`] (flash and static
//! RAM) and [`layout`] (sections and symbols, `cargo fw`'s memory-map check).

use std::io::Read;
use std::path::Path;

use object::elf::{SHF_ALLOC, SHF_WRITE, SHT_NOBITS};
use object::read::elf::{ElfFile32, ElfSection32, SectionHeader};
use object::{LittleEndian as LE, Object, ObjectSection, ObjectSymbol};

/// `e_machine` of ARM (32-bit).
const EM_ARM: u16 = 40;
/// `e_type` of an executable.
const ET_EXEC: u16 = 2;
/// Size of the ELF32 header.
const HEADER: usize = 52;

/// `Ok` if `path` starts with a 32-bit little-endian ARM executable's ELF header, else why not.
pub fn check_target_elf(path: &Path) -> Result<(), String> {
    let mut h = [0u8; HEADER];
    let mut f = std::fs::File::open(path).map_err(|e| format!("cannot read: {e}"))?;
    let n = f.read(&mut h).map_err(|e| format!("cannot read: {e}"))?;
    let h = h.get(..n).unwrap_or(&[]);
    let not = |why: String| {
        Err(format!(
            "not an ELF for the target (32-bit ARM executable): {why}"
        ))
    };
    if h.len() < 4 || h[..4] != *b"\x7fELF" {
        return not("no ELF magic at the start of the file".into());
    }
    if h.len() < HEADER {
        return not(format!("{} bytes, shorter than an ELF32 header", h.len()));
    }
    if h[4] != 1 {
        return not(format!("ELF class {} (want 1, 32-bit)", h[4]));
    }
    if h[5] != 1 {
        return not(format!("data encoding {} (want 1, little-endian)", h[5]));
    }
    let u16_at = |i: usize| u16::from_le_bytes([h[i], h[i + 1]]);
    if u16_at(18) != EM_ARM {
        return not(format!("machine {} (want {EM_ARM}, ARM)", u16_at(18)));
    }
    if u16_at(16) != ET_EXEC {
        return not(format!(
            "type {} (want {ET_EXEC}, an executable)",
            u16_at(16)
        ));
    }
    Ok(())
}

/// Memory use of one firmware image, bytes (what `arm-none-eabi-size -A` sums).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sizes {
    /// Loaded into flash: allocated sections with contents (vector table, code,
    /// read-only data, the initial values of `.data`).
    pub flash: u64,
    /// Static RAM: allocated, writable sections (`.data`, `.bss`, `.uninit`).
    pub ram: u64,
}

/// One allocated section.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Section {
    /// Its name (`.text`, `.bss`, ...).
    pub name: String,
    /// Its run-time address.
    pub addr: u64,
    /// Its size, bytes.
    pub size: u64,
    /// Writable (it lives in RAM).
    pub write: bool,
}

/// Where an image's allocated sections lie, and its symbols (what
/// `arm-none-eabi-readelf -S -s` shows of a firmware's placement).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Layout {
    /// The allocated sections (`SHF_ALLOC`), in header order.
    pub sections: Vec<Section>,
    /// Every named symbol of the symbol table and its value.
    pub symbols: Vec<(String, u64)>,
}

impl Layout {
    /// The value of the symbol `name`, if the image has it.
    pub fn symbol(&self, name: &str) -> Option<u64> {
        self.symbols
            .iter()
            .find(|(n, _)| n == name)
            .map(|&(_, v)| v)
    }
}

/// The allocated sections of an ELF32 LE image with their `sh_type` and `sh_flags`.
fn allocated<'a>(
    f: &'a ElfFile32<'a, LE>,
) -> impl Iterator<Item = (ElfSection32<'a, 'a, LE>, u32, u32)> {
    f.sections().filter_map(|s| {
        let h = s.elf_section_header();
        let flags = h.sh_flags(LE);
        (flags & SHF_ALLOC != 0).then(|| (s, h.sh_type(LE), flags))
    })
}

fn parse(b: &[u8]) -> Result<ElfFile32<'_, LE>, String> {
    ElfFile32::parse(b).map_err(|e| format!("not a 32-bit little-endian ELF: {e}"))
}

/// Sums the section sizes of an ELF32 LE image.
pub fn sizes(b: &[u8]) -> Result<Sizes, String> {
    let f = parse(b)?;
    let mut s = Sizes { flash: 0, ram: 0 };
    for (section, kind, flags) in allocated(&f) {
        if kind != SHT_NOBITS {
            s.flash += section.size();
        }
        if flags & SHF_WRITE != 0 {
            s.ram += section.size();
        }
    }
    Ok(s)
}

/// The allocated sections and the symbols of an ELF32 LE image.
pub fn layout(b: &[u8]) -> Result<Layout, String> {
    let f = parse(b)?;
    let sections = allocated(&f)
        .map(|(s, _, flags)| Section {
            name: s.name().unwrap_or_default().to_string(),
            addr: s.address(),
            size: s.size(),
            write: flags & SHF_WRITE != 0,
        })
        .collect();
    let symbols = f
        .symbols()
        .filter_map(|s| {
            let name = s.name().ok().filter(|n| !n.is_empty())?;
            Some((name.to_string(), s.address()))
        })
        .collect();
    Ok(Layout { sections, symbols })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal ELF32 LE: a null section, the given (type, flags, size) ones, the names.
    fn elf(sections: &[(u32, u32, u32)]) -> Vec<u8> {
        let mut b = vec![0u8; 0x34];
        b[0..4].copy_from_slice(b"\x7fELF");
        b[4..7].copy_from_slice(&[1, 1, 1]);
        b[0x20..0x24].copy_from_slice(&0x34u32.to_le_bytes());
        b[0x2E..0x30].copy_from_slice(&0x28u16.to_le_bytes());
        let n = sections.len() as u16 + 2;
        b[0x30..0x32].copy_from_slice(&n.to_le_bytes());
        b[0x32..0x34].copy_from_slice(&(n - 1).to_le_bytes()); // the names: last
        b.extend_from_slice(&[0u8; 0x28]);
        let names_at = 0x34 + 0x28 * u32::from(n);
        for (kind, flags, size, at) in sections
            .iter()
            .map(|&(k, f, s)| (k, f, s, 0))
            .chain([(3, 0, 1, names_at)])
        {
            let mut h = [0u8; 0x28];
            h[4..8].copy_from_slice(&kind.to_le_bytes());
            h[8..12].copy_from_slice(&flags.to_le_bytes());
            h[0x10..0x14].copy_from_slice(&at.to_le_bytes());
            h[0x14..0x18].copy_from_slice(&size.to_le_bytes());
            b.extend_from_slice(&h);
        }
        b.push(0); // the section-name table: one empty name
        b
    }

    #[test]
    fn counts_loaded_sections_as_flash_and_writable_ones_as_ram() {
        let (progbits, alloc, write) = (1, SHF_ALLOC, SHF_WRITE);
        let image = elf(&[
            (progbits, alloc, 1000),         // .text
            (progbits, alloc, 200),          // .rodata
            (progbits, alloc | write, 16),   // .data: flash and RAM
            (SHT_NOBITS, alloc | write, 64), // .bss: RAM only
            (progbits, 0, 5000),             // .debug_info: neither
        ]);
        assert_eq!(
            sizes(&image),
            Ok(Sizes {
                flash: 1216,
                ram: 80
            })
        );
        let l = layout(&image).expect("layout");
        let written: Vec<(u64, bool)> = l.sections.iter().map(|s| (s.size, s.write)).collect();
        assert_eq!(
            written,
            [(1000, false), (200, false), (16, true), (64, true)]
        );
    }

    #[test]
    fn refuses_what_is_not_an_elf32_le() {
        assert!(sizes(b"hello").is_err());
        let mut image = elf(&[]);
        image[4] = 2; // 64-bit
        assert!(sizes(&image).is_err());
        assert!(layout(&image).is_err());
        assert!(sizes(&elf(&[(1, SHF_ALLOC, 4)])[..0x40]).is_err());
    }

    #[test]
    fn refuses_garbage_and_host_images() {
        let dir = std::env::temp_dir().join(format!("hil-elf-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("tmp");
        let garbage = dir.join("garbage.elf");
        std::fs::write(&garbage, b"this is not firmware").expect("write");
        let e = check_target_elf(&garbage).expect_err("garbage");
        assert!(
            e.contains("not an ELF for the target") && e.contains("magic"),
            "{e}"
        );
        // A 64-bit header (a host executable).
        let mut host = vec![0u8; 64];
        host[..4].copy_from_slice(b"\x7fELF");
        host[4] = 2;
        host[5] = 1;
        let hp = dir.join("host.elf");
        std::fs::write(&hp, &host).expect("write");
        let e = check_target_elf(&hp).expect_err("host");
        assert!(e.contains("class 2"), "{e}");
        // A well-formed ARM executable header passes.
        let mut arm = vec![0u8; 52];
        arm[..4].copy_from_slice(b"\x7fELF");
        arm[4] = 1;
        arm[5] = 1;
        arm[16] = 2;
        arm[18] = 40;
        let ap = dir.join("arm.elf");
        std::fs::write(&ap, &arm).expect("write");
        assert_eq!(check_target_elf(&ap), Ok(()));
        let _ = std::fs::remove_dir_all(&dir);
    }
}
