//! The emulated boards: `mps2-an386` (Cortex-M4F, the default) and `mps2-an385` (Cortex-M3,
//! no FPU). Same memory map, CMSDK UART0 and interrupt numbers: one board layer
//! (`firmware/app`, `board-qemu`) serves both, built by `cargo fw` for each core.

use std::fmt;
use std::str::FromStr;

/// A QEMU machine with its CPU and the firmware ELF built for it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Machine {
    /// `mps2-an386`: Cortex-M4F (the firmware's production target).
    #[default]
    An386,
    /// `mps2-an385`: Cortex-M3, no FPU (the fixed-point build where it matters).
    An385,
}

impl Machine {
    /// QEMU's `-machine` name.
    pub fn name(self) -> &'static str {
        match self {
            Self::An386 => "mps2-an386",
            Self::An385 => "mps2-an385",
        }
    }

    /// QEMU's `-cpu`.
    pub fn cpu(self) -> &'static str {
        match self {
            Self::An386 => "cortex-m4",
            Self::An385 => "cortex-m3",
        }
    }

    /// The file name `cargo fw` gives this machine's firmware (in `target/fw/`).
    pub fn elf_name(self) -> &'static str {
        match self {
            Self::An386 => "wheelset-qemu.elf",
            Self::An385 => "wheelset-qemu-m3.elf",
        }
    }
}

impl fmt::Display for Machine {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Machine {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "mps2-an386" => Ok(Self::An386),
            "mps2-an385" => Ok(Self::An385),
            _ => Err(format!(
                "unknown QEMU machine `{s}` (expected mps2-an386 (Cortex-M4F) or mps2-an385 \
                 (Cortex-M3))"
            )),
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_bad_ones_are_named() {
        for m in [Machine::An386, Machine::An385] {
            assert_eq!(m.name().parse::<Machine>(), Ok(m));
        }
        assert_eq!(Machine::An385.cpu(), "cortex-m3");
        assert_eq!(Machine::default().cpu(), "cortex-m4");
        let e = "mps2-an505".parse::<Machine>().unwrap_err();
        assert!(e.contains("mps2-an505") && e.contains("mps2-an385"), "{e}");
    }
}
