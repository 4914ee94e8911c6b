//! Project automation, run through cargo aliases (`.cargo/config.toml`):
//!
//! - `cargo xtest`: the test command. Does the set-up a fresh machine lacks (the MCU
//!   targets), checks that the `no_std` crates build for both Cortex-M targets, then
//!   runs `cargo test --workspace`.
//! - `cargo fw`: builds the board binaries for `thumbv7em-none-eabihf` in release.

use std::process::{Command, ExitCode};

/// The `no_std` crates that must build for every MCU target.
const NO_STD_CRATES: &[&str] = &["wheelset-control", "wheelset-proto", "wheelset-runtime"];
/// Cortex-M4F (the board and QEMU's mps2-an386) and Cortex-M0 (no FPU).
const MCU_TARGETS: &[&str] = &["thumbv7em-none-eabihf", "thumbv6m-none-eabi"];

fn cargo() -> Command {
    Command::new(std::env::var("CARGO").unwrap_or_else(|_| "cargo".into()))
}

/// Runs a command, echoing it; an error names the command.
fn run(cmd: &mut Command) -> Result<(), String> {
    eprintln!("xtask: {cmd:?}");
    let status = cmd
        .status()
        .map_err(|e| format!("cannot start {cmd:?}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("{cmd:?} failed with {status}"))
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

fn test(extra: &[String]) -> Result<(), String> {
    ensure_targets()?;
    check_no_std()?;
    run(cargo().args(["test", "--workspace"]).args(extra))
}

fn fw() -> Result<(), String> {
    ensure_targets()?;
    check_no_std()
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("test") => test(&args[1..]),
        Some("fw") => fw(),
        _ => {
            eprintln!("usage: cargo xtask <test [cargo test args]|fw>");
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
