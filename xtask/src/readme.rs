//! `cargo xtask readme [--check] [--dev]`: the text between `<!-- generated:NAME -->`
//! and `<!-- /generated:NAME -->` in `README.md` and `docs/**.md` is the output of one
//! command of [`BLOCKS`]; `readme` reruns them (release builds, or `--dev`) and rewrites
//! the blocks and figures, `--check` exits 1 naming what drifted, each figure a page
//! quotes that its blocks lack ([`markers::unquoted`]) and each broken relative link
//! ([`links`]; `--links` checks only these).

use std::fmt::Write as _;
use std::path::Path;
use std::process::{Command, ExitCode};

mod blocks;
mod commands;
mod figures;
mod links;
mod markers;
#[cfg(test)]
mod tests;

pub use blocks::{Block, Keep, BLOCKS};
pub use commands::run_commands;
pub use figures::FIGURES;
pub use markers::update;

/// The pages: `README.md`, then every `.md` file under `docs/` (sorted, recursively; the
/// mdBook's build output `docs/book/` left out), as `(path from the root with `/`, text)`.
pub fn pages(root: &Path) -> Result<Vec<(String, String)>, String> {
    let mut files = vec![root.join("README.md")];
    let docs = root.join("docs");
    crate::files_under(&docs, "md", &docs.join("book"), &mut files)?;
    files
        .into_iter()
        .map(|p| {
            let name = p.strip_prefix(root).unwrap_or(&p).display().to_string();
            std::fs::read_to_string(&p)
                .map(|t| (name, t))
                .map_err(|e| format!("cannot read {}: {e}", p.display()))
        })
        .collect()
}

/// The link check of every page ([`links::check`]): one message per broken link.
pub fn check_links(root: &Path) -> Result<Vec<String>, String> {
    let pages = pages(root)?;
    let figures: Vec<&str> = FIGURES.iter().map(|f| f.path).collect();
    Ok(links::check(root, &pages, &figures))
}

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

/// `cargo xtask readme [--check] [--dev] | --links | --commands [--long] [--list]` (the
/// arguments after `readme`; `--list` prints each command's class without running any).
pub fn main(args: &[String]) -> ExitCode {
    const FLAGS: [&str; 6] = [
        "--check",
        "--dev",
        "--commands",
        "--long",
        "--list",
        "--links",
    ];
    if let Some(other) = args.iter().find(|a| !FLAGS.contains(&a.as_str())) {
        eprintln!(
            "xtask readme: unknown argument `{other}` (usage: cargo xtask readme \
             [--check] [--dev] | --links | --commands [--long] [--list])"
        );
        return ExitCode::from(2);
    }
    let has = |flag: &str| args.iter().any(|a| a == flag);
    let (check, dev, long, list) = (has("--check"), has("--dev"), has("--long"), has("--list"));
    if has("--links") {
        let bad = check_links(&crate::workspace_root());
        if bad.as_ref().is_ok_and(Vec::is_empty) {
            eprintln!("xtask readme: every link and image of the pages resolves");
        }
        return failures(bad, "broken link(s)");
    }
    if has("--commands") {
        return failures(run_commands(long, list), "command(s) of the pages failed");
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

/// Exit 0 when `r` names no failure; else each failure on stderr, then their count
/// with `what`, and exit 1.
fn failures(r: Result<Vec<String>, String>, what: &str) -> ExitCode {
    match r {
        Ok(f) if f.is_empty() => ExitCode::SUCCESS,
        Ok(f) => {
            for e in &f {
                eprintln!("xtask readme: {e}");
            }
            eprintln!("xtask readme: {} {what}", f.len());
            ExitCode::FAILURE
        }
        Err(e) => {
            eprintln!("xtask readme: {e}");
            ExitCode::FAILURE
        }
    }
}

/// Checks the pages' links, builds the binaries, runs every block's command and rewrites
/// or checks the blocks of every page and the committed figures. `Ok(false)`: `check`
/// found drifted blocks or figures, or (either way) broken links, named on stderr.
pub fn run(check: bool, dev: bool) -> Result<bool, String> {
    let root = crate::workspace_root();
    let broken = check_links(&root)?;
    for b in &broken {
        eprintln!("xtask readme: {b}");
    }
    let mut build = crate::cargo();
    build.args(["build", "-p", "sim-host", "-p", "hil", "--bins"]);
    if !dev {
        build.arg("--release");
    }
    crate::run(&mut build)?;
    let bin_dir = crate::target_dir().join(if dev { "debug" } else { "release" });
    let pages = pages(&root)?;
    let mut fresh = Vec::new();
    for b in BLOCKS {
        eprintln!("xtask readme: {}", b.shown());
        fresh.push((b.name, generate(&root, &bin_dir, b)?));
    }
    let (new, drifted) = update(&pages, &fresh)?;
    let mut unquoted = Vec::new();
    for ((page, _), text) in pages.iter().zip(&new) {
        if markers::QUOTING.contains(&page.as_str()) {
            for f in markers::unquoted(page, text)? {
                unquoted.push(format!("{page}: `{f}` is in none of its generated blocks"));
            }
        }
    }
    let figs = figures::sync(&root, check)?;
    let names = drifted
        .iter()
        .map(|(n, _)| n.as_str())
        .collect::<Vec<_>>()
        .join(", ");
    let listed = |s: &str| {
        if s.is_empty() {
            String::new()
        } else {
            format!(" ({s})")
        }
    };
    if check {
        for (name, d) in &drifted {
            eprintln!("xtask readme: block `{name}` drifted from its command:\n{d}");
        }
        for f in &figs {
            eprintln!("xtask readme: figure {f} differs from what its command draws");
        }
        for u in &unquoted {
            eprintln!("xtask readme: {u}");
        }
        if drifted.is_empty() && figs.is_empty() && broken.is_empty() && unquoted.is_empty() {
            eprintln!(
                "xtask readme: {} blocks and {} figures in {} pages match their commands; \
                 every link resolves; every figure quoted from them is in them",
                BLOCKS.len(),
                FIGURES.len(),
                pages.len()
            );
            return Ok(true);
        }
        if !drifted.is_empty() || !figs.is_empty() {
            eprintln!(
                "xtask readme: {} of {} blocks drifted ({}), {} of {} figures differ ({}); \
                 `cargo xtask readme` rewrites them",
                drifted.len(),
                BLOCKS.len(),
                names,
                figs.len(),
                FIGURES.len(),
                figs.join(", ")
            );
        }
        if !broken.is_empty() {
            eprintln!("xtask readme: {} broken link(s)", broken.len());
        }
        return Ok(false);
    }
    for ((path, old), new) in pages.iter().zip(&new) {
        if old != new {
            let p = root.join(path);
            std::fs::write(&p, new).map_err(|e| format!("cannot write {}: {e}", p.display()))?;
        }
    }
    eprintln!(
        "xtask readme: {} blocks written, {} changed{}; {} figures, {} changed{}",
        BLOCKS.len(),
        drifted.len(),
        listed(&names),
        FIGURES.len(),
        figs.len(),
        listed(&figs.join(", "))
    );
    for u in &unquoted {
        eprintln!("xtask readme: {u}");
    }
    Ok(broken.is_empty() && unquoted.is_empty())
}
