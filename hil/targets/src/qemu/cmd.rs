//! The QEMU command line, defined once for the harness, `cargo xtask fw-bench` and
//! `cargo xtask qemu-cmd`. `-icount shift=N,sleep=off`: `2^N` ns of virtual time per
//! instruction, none while the guest sleeps; the firmware converts its SysTick counts to
//! instructions, so its `settings::QEMU_ICOUNT_SHIFT` must equal [`ICOUNT_SHIFT`].

/// The QEMU executable.
pub const QEMU_BIN: &str = "qemu-system-arm";

/// `-icount shift` of every run: `2^10` ns of virtual time per instruction.
pub const ICOUNT_SHIFT: u32 = 10;

/// Semihosting on, to the host's files (stdout for the log, exit, the bulk channel).
const SEMIHOSTING: &str = "enable=on,target=native";

/// Where the guest's UART0 goes.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SerialTo {
    /// Nowhere (the benchmarks talk over semihosting only).
    Null,
    /// A TCP server on `127.0.0.1:PORT` that waits for the harness to connect (the
    /// lock-step device), `nodelay` so each frame leaves at once.
    Tcp(u16),
    /// Nowhere: the frames go over the semihosting bulk channel, FIFOs `DIR/rx` and `DIR/tx`
    /// (`arg=bulk:DIR`; firmware/app/src/board/qemu/bulk.rs).
    Bulk(String),
}

/// The arguments (after [`QEMU_BIN`]) running `elf` on `machine` with CPU `cpu`, UART0 to
/// `serial`, the [`ICOUNT_SHIFT`] clock and semihosting to the host's stdout.
#[must_use]
pub fn qemu_args(machine: &str, cpu: &str, elf: &str, serial: SerialTo) -> Vec<String> {
    let (serial, semihosting) = match serial {
        SerialTo::Null => ("null".to_string(), SEMIHOSTING.to_string()),
        SerialTo::Tcp(port) => (
            format!("tcp:127.0.0.1:{port},server=on,wait=on,nodelay=on"),
            SEMIHOSTING.to_string(),
        ),
        SerialTo::Bulk(dir) => (
            "null".to_string(),
            format!("{SEMIHOSTING},arg=wheelset-qemu,arg=bulk:{dir}"),
        ),
    };
    [
        "-machine",
        machine,
        "-cpu",
        cpu,
        "-nographic",
        "-monitor",
        "none",
        "-serial",
        &serial,
        "-icount",
        &format!("shift={ICOUNT_SHIFT},sleep=off"),
        "-semihosting-config",
        &semihosting,
        "-kernel",
        elf,
    ]
    .iter()
    .map(|s| (*s).to_string())
    .collect()
}

/// `args` ([`qemu_args`]) without `-icount`: the virtual clock follows the host's.
#[must_use]
pub fn without_icount(mut args: Vec<String>) -> Vec<String> {
    if let Some(i) = args.iter().position(|a| a == "-icount") {
        args.drain(i..(i + 2).min(args.len()));
    }
    args
}

/// The command line as one shell line (arguments outside `[A-Za-z0-9_./=:,+-]` single-quoted).
#[must_use]
pub fn shell_line(args: &[String]) -> String {
    let quote = |a: &String| {
        let plain = !a.is_empty()
            && a.chars()
                .all(|c| c.is_ascii_alphanumeric() || "_./=:,+-".contains(c));
        if plain {
            a.clone()
        } else {
            format!("'{}'", a.replace('\'', r"'\''"))
        }
    };
    std::iter::once(QEMU_BIN.to_string())
        .chain(args.iter().map(quote))
        .collect::<Vec<_>>()
        .join(" ")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_command_line_carries_the_icount_shift_and_the_serial() {
        let a = qemu_args("mps2-an385", "cortex-m3", "fw.elf", SerialTo::Tcp(4321));
        let at = |k: &str| {
            a.iter()
                .position(|x| x == k)
                .and_then(|i| a.get(i + 1))
                .cloned()
        };
        assert_eq!(at("-icount").as_deref(), Some("shift=10,sleep=off"));
        assert_eq!(at("-machine").as_deref(), Some("mps2-an385"));
        assert_eq!(at("-cpu").as_deref(), Some("cortex-m3"));
        assert_eq!(at("-kernel").as_deref(), Some("fw.elf"));
        assert_eq!(
            at("-serial").as_deref(),
            Some("tcp:127.0.0.1:4321,server=on,wait=on,nodelay=on")
        );
        let c = qemu_args(
            "mps2-an386",
            "cortex-m4",
            "x",
            SerialTo::Bulk("/tmp/d".into()),
        );
        assert!(c.windows(2).any(|w| w[0] == "-serial" && w[1] == "null"));
        assert!(c.windows(2).any(|w| w[0] == "-semihosting-config"
            && w[1] == "enable=on,target=native,arg=wheelset-qemu,arg=bulk:/tmp/d"));
        let free = without_icount(a.clone());
        assert_eq!(free.len() + 2, a.len());
        assert!(!free.iter().any(|x| x.contains("icount")));
        assert!(free
            .windows(2)
            .any(|w| w[0] == "-kernel" && w[1] == "fw.elf"));
        let b = qemu_args("mps2-an386", "cortex-m4", "x", SerialTo::Null);
        assert!(b.windows(2).any(|w| w[0] == "-serial" && w[1] == "null"));
        let line = shell_line(&qemu_args(
            "mps2-an386",
            "cortex-m4",
            "my fw.elf",
            SerialTo::Null,
        ));
        assert!(
            line.starts_with("qemu-system-arm -machine mps2-an386 "),
            "{line}"
        );
        assert!(line.ends_with(" -kernel 'my fw.elf'"), "{line}");
    }
}
