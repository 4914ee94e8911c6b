//! `cargo xtask readme [--check] [--dev]`: the README's generated blocks.
//!
//! Every deterministic figure of `README.md` (fixed-seed fault runs, modes, golden
//! vectors, frame counts, the rate analysis's grid counts, ...) sits between
//!
//! ```text
//! <!-- generated:NAME -->
//! ...
//! <!-- /generated:NAME -->
//! ```
//!
//! and the text between the two markers is the output of one command of [`BLOCKS`], the
//! one table of them: the command as a user types it (`$ cargo sim ...`, `$ cargo hil
//! ...`) followed by the lines of its standard output (of its standard error for a
//! refusal's message) the block keeps, in a `text`
//! code block. `cargo xtask readme` reruns every command and rewrites the blocks;
//! `--check` rewrites nothing and exits 1 naming each block that drifted, with a line
//! diff (`-` the README, `+` the command). A marker without a table entry, an entry
//! without its markers, a command that does not start or that exits with another code
//! than its entry states are errors too. `cargo xtest` runs the check after the tests.
//!
//! The commands run the binaries that the cargo aliases run (`cargo sim` = `sim-host`,
//! `cargo hil` = `hil`), built first with `cargo build --release -p sim-host -p hil`
//! (`--dev`: the dev profile, which `cargo test` has built already; the figures are the
//! same: no fast-math in Rust, so every profile computes the same floating-point
//! results), from the workspace root, so the paths they write (`out/...`) are the
//! README's.

use std::fmt::Write as _;
use std::path::Path;
use std::process::{Command, ExitCode};

mod blocks;
mod commands;
mod markers;
#[cfg(test)]
mod tests;

pub use blocks::{Block, Keep, BLOCKS};
pub use commands::run_commands;
pub use markers::update;

/// A run of every block's command: the block's new text, or why it could not be made.
fn generate(root: &Path, bin_dir: &Path, b: &Block) -> Result<String, String> {
    let exe = bin_dir.join(b.bin.file());
    let shown = b.shown();
    let out = Command::new(&exe)
        .args(b.argv())
        .current_dir(root)
        .output()
        .map_err(|e| format!("block `{}`: cannot run {}: {e}", b.name, exe.display()))?;
    let code = out.status.code().unwrap_or(-1);
    if code != b.exit {
        return Err(format!(
            "block `{}`: `{shown}` exited with {code}, the table expects {}; its stderr:\n{}",
            b.name,
            b.exit,
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let stdout = String::from_utf8_lossy(if b.stderr { &out.stderr } else { &out.stdout });
    if let Keep::Markdown = b.keep {
        return Ok(stdout.into_owned());
    }
    let mut text = String::new();
    let _ = writeln!(text, "```text");
    let _ = writeln!(text, "$ {shown}");
    if b.exit != 0 {
        let _ = writeln!(text, "(exit {})", b.exit);
    }
    for line in stdout.lines().filter(|l| b.keep.keeps(l)) {
        let _ = writeln!(text, "{}", line.trim_end());
    }
    let _ = writeln!(text, "```");
    Ok(text)
}

/// `cargo xtask readme [--check] [--dev] [--commands [--long] [--list]]` (the arguments
/// after `readme`; `--list` prints each command's class without running any).
pub fn main(args: &[String]) -> ExitCode {
    let mut check = false;
    let mut dev = false;
    let mut cmds = false;
    let mut long = false;
    let mut list = false;
    for a in args {
        match a.as_str() {
            "--check" => check = true,
            "--dev" => dev = true,
            "--commands" => cmds = true,
            "--long" => long = true,
            "--list" => list = true,
            other => {
                eprintln!(
                    "xtask readme: unknown argument `{other}` (usage: cargo xtask readme \
                     [--check] [--dev] | --commands [--long] [--list])"
                );
                return ExitCode::from(2);
            }
        }
    }
    if cmds {
        return match run_commands(long, list) {
            Ok(f) if f.is_empty() => ExitCode::SUCCESS,
            Ok(f) => {
                for e in &f {
                    eprintln!("xtask readme: {e}");
                }
                eprintln!("xtask readme: {} README command(s) failed", f.len());
                ExitCode::FAILURE
            }
            Err(e) => {
                eprintln!("xtask readme: {e}");
                ExitCode::FAILURE
            }
        };
    }
    match run(check, dev) {
        Ok(true) => ExitCode::SUCCESS,
        Ok(false) => ExitCode::FAILURE,
        Err(e) => {
            eprintln!("xtask readme: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Builds the binaries, runs every block's command and rewrites or checks the README.
/// `Ok(false)`: `check` found drifted blocks (named on stderr with their diffs).
pub fn run(check: bool, dev: bool) -> Result<bool, String> {
    let root = crate::workspace_root();
    let mut build = crate::cargo();
    build.args(["build", "-p", "sim-host", "-p", "hil", "--bins"]);
    if !dev {
        build.arg("--release");
    }
    crate::run(&mut build)?;
    let bin_dir = crate::target_dir().join(if dev { "debug" } else { "release" });
    let path = root.join("README.md");
    let readme = std::fs::read_to_string(&path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let mut fresh = Vec::new();
    for b in BLOCKS {
        eprintln!("xtask readme: {}", b.shown());
        fresh.push((b.name, generate(&root, &bin_dir, b)?));
    }
    let (new, drifted) = update(&readme, &fresh)?;
    if check {
        for (name, d) in &drifted {
            eprintln!("xtask readme: block `{name}` drifted from its command:\n{d}");
        }
        if drifted.is_empty() {
            eprintln!("xtask readme: {} blocks match their commands", BLOCKS.len());
            return Ok(true);
        }
        eprintln!(
            "xtask readme: {} of {} blocks drifted ({}); `cargo xtask readme` rewrites them",
            drifted.len(),
            BLOCKS.len(),
            drifted
                .iter()
                .map(|(n, _)| n.as_str())
                .collect::<Vec<_>>()
                .join(", ")
        );
        return Ok(false);
    }
    if new != readme {
        std::fs::write(&path, new).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
    }
    eprintln!(
        "xtask readme: {} blocks written, {} changed{}",
        BLOCKS.len(),
        drifted.len(),
        if drifted.is_empty() {
            String::new()
        } else {
            format!(
                " ({})",
                drifted
                    .iter()
                    .map(|(n, _)| n.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            )
        }
    );
    Ok(true)
}
