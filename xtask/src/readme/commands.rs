//! Every other command the README and the book show: classified (runs here, needs a
//! board, long), run with its stated exit code checked (`cargo xtest`, `--long`).

use std::process::Command;

/// How the pages' commands are run by [`run_commands`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Class {
    /// Run in every `cargo xtest` (seconds each).
    Short,
    /// Run with `--long` only (CI: `.ci/run`).
    Long,
    /// Never run here, for the reason given.
    Skip(&'static str),
}

/// The rules of [`classify`], first match wins: `(substring, class)`.
pub(super) const RULES: &[(&str, Class)] = &[
    ("serial:/dev/", Class::Skip("needs a board")),
    ("flash-board", Class::Skip("needs a board")),
    ("cargo install", Class::Skip("installs software")),
    ("hil serve", Class::Skip("runs until killed")),
    ("cargo xtest", Class::Skip("the test command itself")),
    (
        "cargo test --workspace",
        Class::Skip("the test command itself"),
    ),
    ("...", Class::Skip("a form, not a command")),
    ("[", Class::Skip("a form with optional parts")),
    ("$(", Class::Skip("starts QEMU waiting for a client")),
    ("--frames N", Class::Skip("a form with placeholders")),
    ("stall:T", Class::Skip("a form with placeholders")),
    ("--condition C ", Class::Skip("a form with placeholders")),
    ("defmt-print", Class::Skip("needs defmt-print installed")),
    (
        "--frames 10000000",
        Class::Skip("a 3-minute run (its seeded short form is a test)"),
    ),
    (
        "--target qemu:",
        Class::Skip(
            "needs a QEMU started by hand (hil/harness/tests/qemu_by_hand.rs runs the pair)",
        ),
    ),
    (
        "hil soak --hours 24",
        Class::Skip("a simulated day, 8 minutes (its hour is hil/harness/tests/soak.rs)"),
    ),
    (
        "hil soak --target qemu-free --minutes 60",
        Class::Skip("an hour of real time (its minute is hil/harness/tests/qemu_soak.rs)"),
    ),
    ("hil soak --minutes 30", Class::Long),
    ("--target qemu", Class::Long),
    ("cargo fw", Class::Long),
    ("fw-bench", Class::Long),
    ("qemu-cmd", Class::Long),
    ("cargo bench", Class::Long),
    ("cargo test", Class::Long),
    ("cargo clippy", Class::Long),
    ("cargo fmt", Class::Long),
    (" audit", Class::Long),
    // The adhesion chapter's modal example: milliseconds a run, on the release library
    // the `cargo sim` commands build.
    ("--example adh_modes", Class::Short),
    ("cargo sim", Class::Short),
    ("cargo hil", Class::Short),
    ("cargo xtask fuzz", Class::Short),
];

/// The class of a page's command ([`RULES`]; anything else is skipped as unknown).
pub fn classify(cmd: &str) -> Class {
    RULES
        .iter()
        .find(|(k, _)| cmd.contains(k))
        .map_or(Class::Skip("not a project command"), |&(_, c)| c)
}

/// One command of a page (its exit code: `exit N` after it on its line).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadmeCommand {
    /// The command as written.
    pub text: String,
    /// The exit code stated, 0 if none.
    pub exit: i32,
    /// 1-based line in its page.
    pub line: usize,
}

/// `exit N` in `s` (the first), if any.
pub(super) fn stated_exit(s: &str) -> Option<i32> {
    let i = s.find("exit ")?;
    let digits: String = s[i + 5..]
        .chars()
        .take_while(char::is_ascii_digit)
        .collect();
    digits.parse().ok()
}

/// Every command of `readme`: each line of a ```` ```sh ```` block (its `# comment`
/// removed; comment-only lines skipped) and every inline code span starting with
/// `cargo `; each once, in order of first appearance.
pub fn commands(readme: &str) -> Vec<ReadmeCommand> {
    let mut out: Vec<ReadmeCommand> = Vec::new();
    let mut push = |text: &str, rest: &str, line: usize| {
        let text = text.trim();
        if text.is_empty() || out.iter().any(|c| c.text == text) {
            return;
        }
        out.push(ReadmeCommand {
            text: text.to_string(),
            exit: stated_exit(rest).unwrap_or(0),
            line,
        });
    };
    // Inside a code block: whether it is a ```` ```sh ```` one.
    let mut fence: Option<bool> = None;
    for (i, l) in readme.lines().enumerate() {
        let t = l.trim_start();
        if t.starts_with("```") {
            fence = fence.xor(Some(t == "```sh"));
            continue;
        }
        match fence {
            Some(false) => continue,
            Some(true) => {
                let (cmd, comment) = l.split_once('#').unwrap_or((l, ""));
                push(cmd, comment, i + 1);
                continue;
            }
            None => {}
        }
        // Inline code spans.
        let mut rest = l;
        while let Some(a) = rest.find('`') {
            let after = &rest[a + 1..];
            let Some(b) = after.find('`') else { break };
            let span = &after[..b];
            let tail = &after[b + 1..];
            if span.starts_with("cargo ") {
                push(span, tail, i + 1);
            }
            rest = tail;
        }
    }
    out
}

/// Runs the pages' commands (`long`: also the long ones) from the workspace root with
/// `sh -c`, each once, checked against its stated exit code (`list`: printed with its
/// class, none run); returns the failures.
pub fn run_commands(long: bool, list: bool) -> Result<Vec<String>, String> {
    let root = crate::workspace_root();
    let mut failures = Vec::new();
    let mut seen: Vec<String> = Vec::new();
    for (page, text) in super::pages(&root)? {
        for c in commands(&text) {
            if seen.contains(&c.text) {
                continue;
            }
            seen.push(c.text.clone());
            let at = format!("{page}:{}", c.line);
            let class = classify(&c.text);
            match class {
                Class::Skip(why) => {
                    eprintln!("xtask readme: skip  {at} `{}` ({why})", c.text);
                    continue;
                }
                Class::Long if !long => {
                    eprintln!("xtask readme: long  {at} `{}` (with --long)", c.text);
                    continue;
                }
                _ => {}
            }
            if list {
                eprintln!(
                    "xtask readme: {}  {at} `{}` (exit {})",
                    if class == Class::Long { "long" } else { "run " },
                    c.text,
                    c.exit
                );
                continue;
            }
            let t0 = std::time::Instant::now();
            let out = Command::new("sh")
                .arg("-c")
                .arg(&c.text)
                .current_dir(&root)
                .output()
                .map_err(|e| format!("cannot start sh: {e}"))?;
            let code = out.status.code().unwrap_or(-1);
            let ok = code == c.exit;
            eprintln!(
                "xtask readme: {}  {at} `{}` exit {code} (the page: {}), {:.1} s",
                if ok { "ok  " } else { "FAIL" },
                c.text,
                c.exit,
                t0.elapsed().as_secs_f64()
            );
            if !ok {
                let err = String::from_utf8_lossy(&out.stderr);
                let tail: Vec<&str> = err.lines().rev().take(15).collect();
                failures.push(format!(
                    "{at} `{}`: exit {code}, the page states {}; stderr ends:\n{}",
                    c.text,
                    c.exit,
                    tail.into_iter().rev().collect::<Vec<_>>().join("\n")
                ));
            }
        }
    }
    Ok(failures)
}
