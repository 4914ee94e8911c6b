//! Project automation, run through cargo aliases (`.cargo/config.toml`):
//!
//! - `cargo xtest`: the test command. Checks that every board build has the device
//!   crates' features of the tested builds ([`features`]), does the set-up a fresh
//!   machine lacks (the MCU targets, QEMU), checks that the `no_std` crates build for
//!   both Cortex-M targets, builds the firmware and enforces its size budget, then runs
//!   `cargo test --workspace` (with `REQUIRE_QEMU=1` when QEMU is there, so the
//!   processor-in-the-loop smoke test cannot silently skip) and the device-feature run:
//!   the wire crate's and the runtime's tests once more with the firmware's features
//!   (the wire crate without `std`),
//!   and the runtime's tests with `fault-inject` (the QEMU firmware's runtime: the
//!   tests of the honoured fault injections compile only there);
//!   then it builds every criterion benchmark (`cargo test --workspace --benches
//!   --no-run`: they compile; they are not run), checks the pages' fw-bench figures
//!   against a bench run when QEMU is there (`cargo xtask fw-bench --check`) and the
//!   pages' generated blocks (`cargo xtask readme --check`).
//! - `cargo fw [--f32]`: builds every board build of [`FIRMWARE`] with the `fw` profile
//!   (release, LTO, size-optimised; the STM32 builds linked with flip-link, installed
//!   when missing, in `target/flip-link`) and copies them to `target/fw/` (and with
//!   `--f32` the f32 builds `wheelset-nucleo-f32.elf`, `wheelset-qemu-f32.elf`). Prints
//!   flash and RAM of each against the budget (flash 64 KiB, static RAM 16 KiB) and fails
//!   above either (the f32 measurement builds: printed, not enforced) or when an image is
//!   not placed by its own board's memory map ([`size`]).
//! - `cargo xtask fw-bench [--json FILE] [--check]`: builds `wheelset-qemu-bench` (fixed
//!   point and f32, for the Cortex-M4F on `mps2-an386` and the Cortex-M3 on `mps2-an385`)
//!   and runs it under QEMU: instructions per control-law step and per whole runtime
//!   tick, and the stack high-water mark; prints a table, and with `--json` writes
//!   `{"cortex-m4":{"fixed":{"law":{"min","mean","max"},"tick":{..},"stack_peak_bytes":N},
//!   "f32":{..}},"cortex-m3":{..}}`; rewrites the pages' fw-bench table and README row
//!   from the run (`--check`: fails instead when they differ; `cargo xtest` runs that
//!   when QEMU is there).
//! - `cargo xtask fuzz --frames N [--seed S]`: random, mutated, truncated and bit-flipped
//!   frames and hostile Configs into `Runtime<Fx>` and `Runtime<f32>`, with overflow
//!   checks: no panic, every output within the actuator limits, every frame accounted
//!   ([`fuzz`]; a short seeded run is a unit test of this crate, so `cargo xtest` runs it).
//! - `cargo xtask loc [--check]`: the non-test Rust lines and their comment share
//!   ([`loc`]); `--check` fails above 42 000 lines or at 15 % comments.
//! - `cargo xtask mutants [--package P]... [--file GLOB]... [--shard K/N] [--out DIR]`
//!   (or `--summary DIR...`): cargo-mutants over the device crates, each against its own
//!   tests; prints caught / missed / unviable / timed out per crate against the whole
//!   list ([`mutants`]).
//! - `cargo xtask qemu-cmd [ELF] [--machine M --cpu C] [--tcp PORT] [-- QEMU ARGS]`:
//!   prints the QEMU command line of every project run (`wheelset_targets::qemu::cmd`,
//!   the harness's launcher's) for `ELF`, UART0 to null or to a TCP server, with the extra
//!   arguments appended (`scripts/tick-profile.py --record` runs it).
//! - `cargo xtask readme [--check] [--dev]`: reruns the commands of the generated blocks
//!   of the README and the book (`docs/`) and rewrites them and the figures they draw;
//!   `--check` fails naming the drifted ones and every broken relative link or image
//!   (`--links`: only that check); `cargo xtask readme --commands [--long]` runs the
//!   pages' board-free commands against their stated exit codes ([`readme`]; `cargo
//!   xtest` runs the check and the short commands after the tests).

/// `print!` for the tasks' output: a closed standard output (`cargo xtask ... | head`)
/// ends the task quietly with exit code 0, as Unix tools do, instead of panicking; another
/// write error ends it with 1 and the reason.
macro_rules! out {
    ($($t:tt)*) => {
        $crate::write_stdout(format_args!($($t)*))
    };
}

/// `println!` through [`out!`].
macro_rules! outln {
    () => {
        $crate::write_stdout(format_args!("\n"))
    };
    ($($t:tt)*) => {
        $crate::write_stdout(format_args!("{}\n", format_args!($($t)*)))
    };
}

mod bench;
mod features;
mod fuzz;
mod loc;
mod mutants;
mod readme;
mod size;

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

// The QEMU command line, defined once (the harness's launcher uses it too).
use wheelset_targets::qemu::cmd as qemu_cmd;

/// The `no_std` crates that must build for every MCU target.
const NO_STD_CRATES: &[&str] = &["wheelset-control", "wheelset-proto", "wheelset-runtime"];
/// Cortex-M4F (the board and QEMU's mps2-an386) and Cortex-M0 (no FPU).
const MCU_TARGETS: &[&str] = &["thumbv7em-none-eabihf", "thumbv6m-none-eabi"];
/// The firmware's target.
const FW_TARGET: &str = "thumbv7em-none-eabihf";
/// The Cortex-M3 (no FPU) of QEMU's mps2-an385: the fixed-point build where it matters.
const M3_TARGET: &str = "thumbv7m-none-eabi";
/// One firmware binary: cargo bin name, features, the name it gets in `target/fw`, the
/// target it is built for, its board (the `board-<name>` feature's module, whose memory
/// map [`size::check_sizes`] holds the ELF to) and whether it links with flip-link.
struct Firmware {
    bin: &'static str,
    features: &'static str,
    elf: &'static str,
    target: &'static str,
    board: &'static str,
    flip_link: bool,
}

/// The firmware binary of every board build.
const FW_BIN: &str = "wheelset-fw";

const FIRMWARE: &[Firmware] = &[
    Firmware {
        bin: FW_BIN,
        features: "board-nucleo",
        elf: "wheelset-nucleo.elf",
        target: FW_TARGET,
        board: "nucleo",
        flip_link: true,
    },
    // The Nucleo frame-clocked (lock-step over the ST-LINK VCP; feature `frame-clock`).
    Firmware {
        bin: FW_BIN,
        features: "frame-clock",
        elf: "wheelset-nucleo-frame.elf",
        target: FW_TARGET,
        board: "nucleo",
        flip_link: true,
    },
    // The Nucleo-G474RE: LPUART1 on the ST-LINK V3 virtual COM port, free-running.
    Firmware {
        bin: FW_BIN,
        features: "board-nucleo-g474",
        elf: "wheelset-nucleo-g474.elf",
        target: FW_TARGET,
        board: "nucleo_g474",
        flip_link: true,
    },
    Firmware {
        bin: FW_BIN,
        features: "board-qemu",
        elf: "wheelset-qemu.elf",
        target: FW_TARGET,
        board: "qemu",
        flip_link: false,
    },
    // QEMU free-running: the tick from TIMER0, QEMU without -icount, paced in real
    // time (`hil run --target qemu-free`).
    Firmware {
        bin: FW_BIN,
        features: "free-run",
        elf: "wheelset-qemu-free.elf",
        target: FW_TARGET,
        board: "qemu",
        flip_link: false,
    },
    // The same QEMU firmware for the Cortex-M3 of mps2-an385 (same memory map, CMSDK
    // UART0 and interrupts; no FPU): `hil run --target qemu --machine mps2-an385`.
    Firmware {
        bin: FW_BIN,
        features: "board-qemu",
        elf: "wheelset-qemu-m3.elf",
        target: M3_TARGET,
        board: "qemu",
        flip_link: false,
    },
];

const FIRMWARE_F32: &[Firmware] = &[
    Firmware {
        bin: FW_BIN,
        features: "board-nucleo,f32",
        elf: "wheelset-nucleo-f32.elf",
        target: FW_TARGET,
        board: "nucleo",
        flip_link: true,
    },
    Firmware {
        bin: FW_BIN,
        features: "board-qemu,f32",
        elf: "wheelset-qemu-f32.elf",
        target: FW_TARGET,
        board: "qemu",
        flip_link: false,
    },
];

fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

fn target_dir() -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map(PathBuf::from)
        .unwrap_or_else(|| workspace_root().join("target"))
}

/// Runs a command, echoing it; an error names the command.
/// A command as a user would type it: the program's name and its arguments, without the
/// environment the task sets (`Command`'s `Debug` prints that too, e.g. the whole
/// `CARGO_ENCODED_RUSTFLAGS`).
fn shown(cmd: &Command) -> String {
    let program = Path::new(cmd.get_program());
    std::iter::once(program.file_name().unwrap_or(program.as_os_str()))
        .chain(cmd.get_args())
        .map(|s| s.to_string_lossy().into_owned())
        .collect::<Vec<_>>()
        .join(" ")
}

/// Runs `cmd`, saying first what it is (`xtask: cargo build ...`); its own output (cargo's
/// progress) goes straight to the terminal.
fn run(cmd: &mut Command) -> Result<(), String> {
    run_as(&shown(cmd), cmd)
}

/// Runs `cmd` after one line that says `what` it does, in words.
fn run_as(what: &str, cmd: &mut Command) -> Result<(), String> {
    eprintln!("xtask: {what}");
    let status = cmd
        .status()
        .map_err(|e| format!("cannot start `{}`: {e}", shown(cmd)))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`{}` failed with {status}", shown(cmd)))
    }
}

/// Installs the MCU targets if the toolchain lacks them (rust-toolchain.toml lists them,
/// but a toolchain installed before that file existed may not have them).
fn ensure_targets() -> Result<(), String> {
    let out = Command::new("rustup")
        .args(["target", "list", "--installed"])
        .output();
    let installed = match out {
        Ok(o) if o.status.success() => String::from_utf8_lossy(&o.stdout).into_owned(),
        // No rustup: trust the toolchain; the build below says what is missing.
        _ => return Ok(()),
    };
    let missing: Vec<&str> = MCU_TARGETS
        .iter()
        .copied()
        .chain([M3_TARGET])
        .filter(|t| !installed.lines().any(|l| l.trim() == *t))
        .collect();
    if missing.is_empty() {
        return Ok(());
    }
    run(Command::new("rustup")
        .arg("target")
        .arg("add")
        .args(&missing))
}

/// Builds the `no_std` crates for every MCU target.
fn check_no_std() -> Result<(), String> {
    for target in MCU_TARGETS {
        let mut cmd = cargo();
        cmd.args(["build", "--release", "--target", target]);
        for krate in NO_STD_CRATES {
            cmd.args(["-p", krate]);
        }
        run(&mut cmd)?;
    }
    Ok(())
}

/// `--remap-path-prefix` flags that shorten the source paths the firmware carries for its
/// panic locations (`/home/me/.cargo/registry/src/index.crates.io-<hash>/embassy-stm32-
/// 0.6.0/src/..` becomes `embassy-stm32-0.6.0/src/..`): about 1 KiB of flash. The
/// workspace's own paths are relative already.
fn remap_flags() -> Vec<String> {
    let home = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")));
    let Some(home) = home else {
        return Vec::new();
    };
    let mut flags = Vec::new();
    let src = home.join("registry").join("src");
    if let Ok(dirs) = std::fs::read_dir(&src) {
        for d in dirs.flatten() {
            flags.push(format!("--remap-path-prefix={}/=", d.path().display()));
        }
    }
    flags.push(format!(
        "--remap-path-prefix={}/=",
        home.join("git").join("checkouts").display()
    ));
    flags
}

/// The cargo `--config` that links the board build with flip-link.
const FLIP_LINK_CONFIG: &str = "target.thumbv7em-none-eabihf.linker=\"flip-link\"";

/// Makes sure `flip-link` (the board build's linker) is installed: `cargo install
/// flip-link --locked` if it is not (3-5 minutes of build on two busy cores).
fn ensure_flip_link() -> Result<(), String> {
    let found = Command::new("flip-link")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .status()
        .is_ok();
    if found {
        return Ok(());
    }
    eprintln!("xtask: flip-link missing (the Nucleo build's linker): installing it");
    run(cargo().args(["install", "flip-link", "--locked"]))
}

/// Builds the given firmware binaries, one cargo invocation each (so no board's HAL can
/// reach another board's binary), and copies them to `target/fw/`.
fn build_firmware(list: &[Firmware]) -> Result<Vec<(PathBuf, &'static str)>, String> {
    let out_dir = target_dir().join("fw");
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| format!("cannot create {}: {e}", out_dir.display()))?;
    // The target's flags only (with `--target`, build scripts do not get them); any
    // flags already given are kept.
    let mut flags: Vec<String> = match std::env::var("CARGO_ENCODED_RUSTFLAGS") {
        Ok(f) if !f.is_empty() => f.split('\x1f').map(String::from).collect(),
        _ => std::env::var("RUSTFLAGS")
            .map(|f| f.split_whitespace().map(String::from).collect())
            .unwrap_or_default(),
    };
    flags.extend(remap_flags());
    let mut elfs = Vec::new();
    for fw in list {
        // An STM32 board build links with flip-link (stack below the static data: an overflow
        // faults instead of corrupting them), in its own target directory: a different
        // linker changes every unit's fingerprint, and sharing one directory with the
        // QEMU builds would rebuild everything at each switch.
        let flip = fw.flip_link;
        let dir = if flip {
            ensure_flip_link()?;
            target_dir().join("flip-link")
        } else {
            target_dir()
        };
        let mut cmd = cargo();
        cmd.env("CARGO_ENCODED_RUSTFLAGS", flags.join("\x1f"))
            .args([
                "build",
                "-p",
                "wheelset-fw",
                "--profile",
                "fw",
                "--target",
                fw.target,
                "--features",
                fw.features,
                "--bin",
                fw.bin,
            ])
            .arg("--target-dir")
            .arg(&dir);
        if flip {
            cmd.args(["--config", FLIP_LINK_CONFIG]);
        }
        run_as(
            &format!(
                "building {} ({}, {}{})...",
                fw.elf,
                fw.features,
                fw.target,
                if flip { ", linked with flip-link" } else { "" }
            ),
            &mut cmd,
        )?;
        let built = dir.join(fw.target).join("fw").join(fw.bin);
        let dest = out_dir.join(fw.elf);
        std::fs::copy(&built, &dest)
            .map_err(|e| format!("cannot copy {} to {}: {e}", built.display(), dest.display()))?;
        elfs.push((dest, fw.board));
    }
    Ok(elfs)
}

/// Prints flash and static RAM of each ELF; fails if a production (fixed-point) build is
/// over budget. The `-f32` variants are measurement builds (`cargo fw --f32`, the f32
/// column of the benchmarks): their overrun is printed, not enforced (the Nucleo's f32
/// build is ~0.4 KiB larger: the f32 control core plus its conversions).
fn have_qemu() -> bool {
    Command::new("qemu-system-arm")
        .arg("--version")
        .output()
        .is_ok_and(|o| o.status.success())
}

fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| String::from_utf8_lossy(&o.stdout).trim() == "0")
}

/// Makes sure `qemu-system-arm` is there: installs it with apt-get when running as root,
/// otherwise says how. Returns whether QEMU is available.
fn ensure_qemu() -> bool {
    if have_qemu() {
        return true;
    }
    if is_root() {
        eprintln!("xtask: qemu-system-arm missing: installing it with apt-get");
        let ok = run(Command::new("apt-get").args(["update", "-qq"])).is_ok()
            && run(Command::new("apt-get")
                .args(["install", "-y", "-qq", "qemu-system-arm"])
                .env("DEBIAN_FRONTEND", "noninteractive"))
            .is_ok();
        if ok && have_qemu() {
            return true;
        }
    }
    eprintln!(
        "xtask: qemu-system-arm is not installed, so the processor-in-the-loop test will \
         skip; install it with `sudo apt-get install qemu-system-arm`"
    );
    false
}

fn fw(args: &[String]) -> Result<Vec<(PathBuf, &'static str)>, String> {
    let mut list: Vec<&Firmware> = FIRMWARE.iter().collect();
    for a in args {
        match a.as_str() {
            "--f32" => list.extend(FIRMWARE_F32.iter()),
            other => {
                return Err(format!(
                    "cargo fw: unknown argument `{other}` (usage: cargo fw [--f32])"
                ))
            }
        }
    }
    ensure_targets()?;
    let mut elfs = Vec::new();
    for fw in list {
        elfs.extend(build_firmware(std::slice::from_ref(fw))?);
    }
    size::check_sizes(&elfs)?;
    Ok(elfs)
}

fn test(extra: &[String]) -> Result<(), String> {
    // Fast (cargo's resolution only): before anything is built.
    let boards: Vec<&Firmware> = FIRMWARE.iter().chain(FIRMWARE_F32).collect();
    features::check(&boards)?;
    ensure_targets()?;
    check_no_std()?;
    let elfs = build_firmware(FIRMWARE)?;
    let sizes = size::check_sizes(&elfs)?;
    size::readme_sizes(&sizes)?;
    let mut cmd = cargo();
    // Every test binary, so one failure does not hide the others behind it.
    cmd.args(["test", "--workspace", "--no-fail-fast"])
        .args(extra);
    if ensure_qemu() {
        cmd.env("REQUIRE_QEMU", "1");
    }
    if let Some((qemu_elf, _)) = elfs.iter().find(|(p, _)| p.ends_with("wheelset-qemu.elf")) {
        cmd.env("WHEELSET_QEMU_ELF", qemu_elf);
    }
    run(&mut cmd)?;
    // The device's crates with the firmware's features (no `std` in the wire crate).
    let mut device = cargo();
    device.args(["test", "--no-fail-fast"]);
    for p in features::DEVICE_TEST_PACKAGES {
        device.args(["-p", p]);
    }
    run(device.args(extra))?;
    // The runtime as the QEMU firmware builds it (`fault-inject`): the tests that only
    // this feature compiles (the fault injections honoured).
    let mut inject = cargo();
    inject.args([
        "test",
        "--no-fail-fast",
        "-p",
        "wheelset-runtime",
        "--features",
        "fault-inject",
    ]);
    run(inject.args(extra))?;
    // The benchmarks compile (criterion's; not run: timings are no tests). Built in the
    // test profile, beside the test binaries above.
    let mut benches = cargo();
    benches.args(["test", "--workspace", "--benches", "--no-run"]);
    run(&mut benches)?;
    // The pages' instruction counts and stack figures against the bench (under QEMU).
    if have_qemu() {
        bench::fw_bench(None, true)?;
    }
    // The README and the book: their generated blocks and figures against their
    // commands and their links, then their short board-free commands against their
    // stated exit codes (`cargo xtask readme`).
    if !readme::run(true, false)? {
        return Err(
            "the README or the book: generated blocks or figures drifted, or a link is broken \
             (`cargo xtask readme` rewrites the blocks and figures)"
                .into(),
        );
    }
    let failed = readme::run_commands(false, false)?;
    if failed.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "the README or the book: {} command(s) failed:\n{}",
            failed.len(),
            failed.join("\n")
        ))
    }
}

/// `cargo xtask qemu-cmd [ELF] [--machine M --cpu C] [--tcp PORT] [-- EXTRA...]`: prints
/// the QEMU command line of the project's runs (the harness's launcher's arguments) for
/// `ELF` (default `target/fw/wheelset-qemu-bench.elf`) on `M`/`C` (default mps2-an386 /
/// cortex-m4), UART0 to null or, with `--tcp PORT`, to a TCP server on 127.0.0.1:PORT as
/// the harness connects to it, with `EXTRA` appended: what `scripts/tick-profile.py
/// --record` runs.
fn qemu_cmd_line(args: &[String]) -> Result<(), String> {
    let usage = "qemu-cmd: usage: cargo xtask qemu-cmd [ELF] [--machine M --cpu C] \
                 [--tcp PORT] [-- QEMU ARGS]";
    let (own, extra) = match args.iter().position(|a| a == "--") {
        Some(i) => (&args[..i], args.get(i + 1..).unwrap_or(&[])),
        None => (args, &[][..]),
    };
    let mut elf = None;
    let mut serial = qemu_cmd::SerialTo::Null;
    let (mut machine, mut cpu) = (qemu_cmd::MACHINE.to_string(), qemu_cmd::CPU.to_string());
    let mut it = own.iter();
    while let Some(a) = it.next() {
        let mut value = || {
            it.next()
                .cloned()
                .ok_or_else(|| format!("{usage}: {a} needs a value"))
        };
        match a.as_str() {
            "--tcp" => {
                let p = value()?;
                let port = p
                    .parse::<u16>()
                    .ok()
                    .filter(|&p| p > 0)
                    .ok_or_else(|| format!("qemu-cmd: --tcp {p}: not a TCP port (1-65535)"))?;
                serial = qemu_cmd::SerialTo::Tcp(port);
            }
            "--machine" => machine = value()?,
            "--cpu" => cpu = value()?,
            e if !e.starts_with('-') && elf.is_none() => elf = Some(e.to_string()),
            other => return Err(format!("{usage}: unexpected `{other}`")),
        }
    }
    let elf = elf.unwrap_or_else(|| "target/fw/wheelset-qemu-bench.elf".to_string());
    let mut a = qemu_cmd::qemu_args(&machine, &cpu, &elf, serial);
    a.extend(extra.iter().cloned());
    outln!("{}", qemu_cmd::shell_line(&a));
    Ok(())
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("test") => test(&args[1..]),
        Some("fw") => fw(&args[1..]).map(|_| ()),
        Some("fw-bench") => match bench::parse_bench_args(&args[1..]) {
            Ok((json, check)) => bench::fw_bench(json, check),
            Err(e) => {
                eprintln!("xtask: {e}");
                return ExitCode::from(2);
            }
        },
        Some("fuzz") => return fuzz::main(&args[1..]),
        Some("loc") => match args.get(1).map(String::as_str) {
            None => loc::main(false),
            Some("--check") => loc::main(true),
            Some(other) => {
                eprintln!("xtask: loc: unexpected `{other}` (loc [--check])");
                return ExitCode::from(2);
            }
        },
        Some("mutants") => match mutants::main(&args[1..]) {
            Ok(true) => Ok(()),
            Ok(false) => return ExitCode::FAILURE,
            Err(e) => {
                eprintln!("xtask: {e}");
                return ExitCode::from(2);
            }
        },
        Some("readme") => return readme::main(&args[1..]),
        Some("qemu-cmd") => {
            if let Err(e) = qemu_cmd_line(&args[1..]) {
                eprintln!("xtask: {e}");
                return ExitCode::from(2);
            }
            Ok(())
        }
        _ => {
            eprintln!(
                "usage: cargo xtask <test [cargo test args]|fw [--f32]|fw-bench [--json FILE] [--check]|\
                 fuzz --frames N [--seed S]|loc [--check]|mutants [--package P] [--file GLOB] [--shard K/N] [--out DIR] | --summary DIR...|qemu-cmd [ELF] [--machine M --cpu C] [--tcp PORT] \
                 [-- QEMU ARGS]|readme [--check] [--dev] | --links | --commands [--long]>"
            );
            return ExitCode::from(2);
        }
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("xtask: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Writes to standard output for [`out!`] and [`outln!`].
fn write_stdout(args: std::fmt::Arguments<'_>) {
    use std::io::Write as _;
    let mut out = std::io::stdout().lock();
    if let Err(e) = out.write_fmt(args).and_then(|()| out.flush()) {
        if e.kind() == std::io::ErrorKind::BrokenPipe {
            std::process::exit(0);
        }
        eprintln!("xtask: error: cannot write to standard output: {e}");
        std::process::exit(1);
    }
}
