//! The firmware's ELF images, read without binutils: [`check_target_elf`] (so a host or
//! garbage image is refused by name before QEMU is launched), [`sizes`] (flash and static
//! RAM) and [`layout`] (sections and symbols, `cargo fw`'s memory-map check).

use std::io::Read;
use std::path::Path;

mod layout;
mod section_sizes;

pub use layout::{layout, Layout, Section};
pub use section_sizes::{sizes, Sizes};

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

#[cfg(test)]
mod tests {
    use super::*;

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
