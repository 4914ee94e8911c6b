//! The allocated sections of a 32-bit little-endian ELF (addresses, sizes) and its
//! symbols' values: what `arm-none-eabi-readelf -S -s` shows of a firmware's placement.

use super::section_sizes::{section_headers, u16_at, u32_at, SHF_ALLOC, SHF_WRITE};

/// `sh_type` of the symbol table.
const SHT_SYMTAB: u32 = 2;
/// Bytes of one ELF32 symbol.
const SYM_SIZE: usize = 16;

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

/// Where an image's allocated sections lie, and its symbols.
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

/// The NUL-terminated string at `at` of the string table at file offset `table`.
fn string(b: &[u8], table: usize, at: usize) -> String {
    let bytes = b.get(table + at..).unwrap_or(&[]);
    let end = bytes.iter().position(|&c| c == 0).unwrap_or(bytes.len());
    String::from_utf8_lossy(&bytes[..end]).into_owned()
}

/// File offset of the section whose header index is `index`.
fn section_offset(b: &[u8], index: usize) -> Result<usize, String> {
    let h = section_headers(b)?
        .nth(index)
        .ok_or_else(|| format!("no section {index}"))?;
    Ok(u32_at(b, h + 0x10)? as usize)
}

/// The allocated sections and the symbols of an ELF32 LE image.
pub fn layout(b: &[u8]) -> Result<Layout, String> {
    let names = section_offset(b, usize::from(u16_at(b, 0x32)?))?;
    let mut out = Layout::default();
    for h in section_headers(b)? {
        let kind = u32_at(b, h + 0x04)?;
        let flags = u32_at(b, h + 0x08)?;
        let offset = u32_at(b, h + 0x10)? as usize;
        let size = u32_at(b, h + 0x14)? as usize;
        if flags & SHF_ALLOC != 0 {
            out.sections.push(Section {
                name: string(b, names, u32_at(b, h)? as usize),
                addr: u64::from(u32_at(b, h + 0x0C)?),
                size: size as u64,
                write: flags & SHF_WRITE != 0,
            });
        }
        if kind == SHT_SYMTAB {
            let strings = section_offset(b, u32_at(b, h + 0x18)? as usize)?;
            for s in (offset..offset + size).step_by(SYM_SIZE).skip(1) {
                let name = string(b, strings, u32_at(b, s)? as usize);
                if !name.is_empty() {
                    out.symbols.push((name, u64::from(u32_at(b, s + 4)?)));
                }
            }
        }
    }
    Ok(out)
}
