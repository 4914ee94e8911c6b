//! Project automation, run through cargo aliases (`.cargo/config.toml`): `cargo xtest`,
//! `cargo fw [--f32]` and `cargo xtask fw-bench`, `fuzz`, `loc`, `mutants`, `qemu-cmd` and
//! `readme` (their steps in `test` and `fw`, or their module's docs; the usage line in `main`).

/// `print!` for the tasks' output: a closed standard output ends the task quietly with
/// exit code 0; another write error ends it with 1 and the reason.
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

use wheelset_targets::qemu::cmd as qemu_cmd;

/// The device crates (`no_std`; their features and mutants checked: [`features`], [`mutants`]).
const DEVICE_CRATES: [&str; 3] = ["wheelset-control", "wheelset-proto", "wheelset-runtime"];
/// Cortex-M4F (the board and QEMU's mps2-an386) and Cortex-M0 (no FPU).
const MCU_TARGETS: &[&str] = &["thumbv7em-none-eabihf", "thumbv6m-none-eabi"];
const FW_TARGET: &str = "thumbv7em-none-eabihf";
/// The Cortex-M3 (no FPU) of QEMU's mps2-an385: the fixed-point build where it matters.
const M3_TARGET: &str = "thumbv7m-none-eabi";
/// One firmware binary: its name in `target/fw`, and its board (the `board-<name>`
/// feature's module, whose memory map [`size::check_sizes`] holds the ELF to).
struct Firmware {
    bin: &'static str,
    features: &'static str,
    elf: &'static str,
    target: &'static str,
    board: &'static str,
}

impl Firmware {
    fn flip_link(&self) -> bool {
        self.board.starts_with("nucleo")
    }
}

const FW_BIN: &str = "wheelset-fw";

/// [`Firmware`] rows of [`FW_BIN`]: `features, elf, target, board;`.
macro_rules! firmware {
    ($($features:literal, $elf:literal, $target:ident, $board:literal;)*) => {
        &[$(Firmware { bin: FW_BIN, features: $features, elf: $elf, target: $target, board: $board }),*]
    };
}

/// The board builds: the Nucleo (free-running, and frame-clocked over the ST-LINK VCP),
/// the Nucleo-G474RE (LPUART1), QEMU (`-icount`, and free-running on TIMER0 paced in real
/// time), and the QEMU firmware for the Cortex-M3 of mps2-an385.
const FIRMWARE: &[Firmware] = firmware![
    "board-nucleo", "wheelset-nucleo.elf", FW_TARGET, "nucleo";
    "frame-clock", "wheelset-nucleo-frame.elf", FW_TARGET, "nucleo";
    "board-nucleo-g474", "wheelset-nucleo-g474.elf", FW_TARGET, "nucleo_g474";
    "board-qemu", "wheelset-qemu.elf", FW_TARGET, "qemu";
    "free-run", "wheelset-qemu-free.elf", FW_TARGET, "qemu";
    "board-qemu", "wheelset-qemu-m3.elf", M3_TARGET, "qemu";
];

/// The f32 measurement builds (`cargo fw --f32`): sizes printed, not enforced.
const FIRMWARE_F32: &[Firmware] = firmware![
    "board-nucleo,f32", "wheelset-nucleo-f32.elf", FW_TARGET, "nucleo";
    "board-qemu,f32", "wheelset-qemu-f32.elf", FW_TARGET, "qemu";
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

/// The `*.ext` files under `dir` into `out`, each folder in name order, `skip` left out.
fn files_under(dir: &Path, ext: &str, skip: &Path, out: &mut Vec<PathBuf>) -> Result<(), String> {
    let read = std::fs::read_dir(dir).map_err(|e| format!("cannot read {}: {e}", dir.display()))?;
    let mut entries: Vec<PathBuf> = read.filter_map(|e| Some(e.ok()?.path())).collect();
    entries.sort();
    for p in entries {
        if p.is_dir() && p != skip {
            files_under(&p, ext, skip, out)?;
        } else if p.extension().is_some_and(|x| x == ext) {
            out.push(p);
        }
    }
    Ok(())
}

/// A command as a user would type it (without the environment the task sets).
fn shown(cmd: &Command) -> String {
    let program = Path::new(cmd.get_program());
    std::iter::once(program.file_name().unwrap_or(program.as_os_str()))
        .chain(cmd.get_args())
        .map(|s| s.to_string_lossy().into_owned())
        .collect::<Vec<_>>()
        .join(" ")
}

/// Runs `cmd`, saying first what it is (`xtask: cargo build ...`).
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

fn check_no_std() -> Result<(), String> {
    for target in MCU_TARGETS {
        let crates = DEVICE_CRATES.iter().flat_map(|k| ["-p", k]);
        run(cargo()
            .args(["build", "--release", "--target", target])
            .args(crates))?;
    }
    Ok(())
}

/// `--remap-path-prefix` flags: shorter registry paths in the panic locations (~1 KiB).
fn remap_flags() -> Vec<String> {
    let home = std::env::var_os("CARGO_HOME")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cargo")));
    let Some(home) = home else {
        return Vec::new();
    };
    let registries = std::fs::read_dir(home.join("registry").join("src"));
    let registries = registries.into_iter().flatten().flatten().map(|d| d.path());
    registries
        .chain([home.join("git").join("checkouts")])
        .map(|p| format!("--remap-path-prefix={}/=", p.display()))
        .collect()
}

const FLIP_LINK_CONFIG: &str = "target.thumbv7em-none-eabihf.linker=\"flip-link\"";

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

/// Builds the given firmware binaries, one cargo invocation each (no board's HAL can
/// reach another board's binary), and copies them to `target/fw/`.
fn build_firmware<'a>(
    list: impl IntoIterator<Item = &'a Firmware>,
) -> Result<Vec<(PathBuf, &'static str)>, String> {
    let out_dir = target_dir().join("fw");
    std::fs::create_dir_all(&out_dir)
        .map_err(|e| format!("cannot create {}: {e}", out_dir.display()))?;
    // The target's flags only (with `--target`, build scripts do not get them).
    let mut flags: Vec<String> = match std::env::var("CARGO_ENCODED_RUSTFLAGS") {
        Ok(f) if !f.is_empty() => f.split('\x1f').map(String::from).collect(),
        _ => std::env::var("RUSTFLAGS")
            .map(|f| f.split_whitespace().map(String::from).collect())
            .unwrap_or_default(),
    };
    flags.extend(remap_flags());
    let mut elfs = Vec::new();
    for fw in list {
        // flip-link (stack below the static data: an overflow faults instead of corrupting
        // them), in its own target directory: another linker changes every fingerprint.
        let flip = fw.flip_link();
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

/// Makes sure `qemu-system-arm` is there (apt-get when root); whether it is.
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
    if let Some(other) = args.iter().find(|a| *a != "--f32") {
        return Err(format!(
            "cargo fw: unknown argument `{other}` (usage: cargo fw [--f32])"
        ));
    }
    let f32 = FIRMWARE_F32.iter().filter(|_| !args.is_empty());
    ensure_targets()?;
    let elfs = build_firmware(FIRMWARE.iter().chain(f32))?;
    size::check_sizes(&elfs)?;
    Ok(elfs)
}

fn test(extra: &[String]) -> Result<(), String> {
    // Fast (cargo's resolution and a line count): before anything is built.
    let boards: Vec<&Firmware> = FIRMWARE.iter().chain(FIRMWARE_F32).collect();
    features::check(&boards)?;
    loc::main(true)?;
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
    // The device's crates with the firmware's features (no `std` in the wire crate), then
    // the runtime as the QEMU firmware builds it (`fault-inject`).
    let device = features::DEVICE_TEST_PACKAGES
        .iter()
        .flat_map(|p| ["-p", p]);
    let inject = ["-p", "wheelset-runtime", "--features", "fault-inject"];
    for packages in [device.collect(), inject.to_vec()] {
        run(cargo()
            .args(["test", "--no-fail-fast"])
            .args(packages)
            .args(extra))?;
    }
    // The benchmarks compile (not run: timings are no tests).
    run(cargo().args(["test", "--workspace", "--benches", "--no-run"]))?;
    // The pages' instruction counts and stack figures against the bench (under QEMU).
    if have_qemu() {
        bench::fw_bench(None, true)?;
    }
    // The README and the book: generated blocks, figures and links, then their short
    // board-free commands against their stated exit codes.
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
/// the QEMU command line of the harness's launcher for `ELF` (default
/// `target/fw/wheelset-qemu-bench.elf`), UART0 to null or to a TCP server on 127.0.0.1.
fn qemu_cmd_line(args: &[String]) -> Result<(), String> {
    let usage = "qemu-cmd: usage: cargo xtask qemu-cmd [ELF] [--machine M --cpu C] \
                 [--tcp PORT] [-- QEMU ARGS]";
    let (own, extra) = match args.iter().position(|a| a == "--") {
        Some(i) => (&args[..i], args.get(i + 1..).unwrap_or(&[])),
        None => (args, &[][..]),
    };
    let mut elf = None;
    let mut serial = qemu_cmd::SerialTo::Null;
    let m = wheelset_targets::qemu::Machine::default();
    let (mut machine, mut cpu) = (m.name().to_string(), m.cpu().to_string());
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
            Err(e) => return usage_error(e),
        },
        Some("fuzz") => match fuzz::parse_args(&args[1..]) {
            Ok(a) => fuzz::fuzz(a),
            Err(e) => return usage_error(e),
        },
        Some("loc") => match args.get(1).map(String::as_str) {
            None => loc::main(false),
            Some("--check") => loc::main(true),
            Some(other) => {
                return usage_error(format!("loc: unexpected `{other}` (loc [--check])"))
            }
        },
        Some("mutants") => match mutants::main(&args[1..]) {
            Ok(true) => Ok(()),
            Ok(false) => return ExitCode::FAILURE,
            Err(e) => return usage_error(e),
        },
        Some("readme") => return readme::main(&args[1..]),
        Some("qemu-cmd") => {
            return qemu_cmd_line(&args[1..]).map_or_else(usage_error, |()| ExitCode::SUCCESS)
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

/// A usage error: the message, then exit code 2.
fn usage_error(e: impl std::fmt::Display) -> ExitCode {
    eprintln!("xtask: {e}");
    ExitCode::from(2)
}

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
