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

/// The binaries the README's aliases run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Bin {
    /// `cargo sim` (`sim-host`).
    Sim,
    /// `cargo hil` (`hil`).
    Hil,
}

impl Bin {
    /// The cargo alias a reader types.
    fn alias(self) -> &'static str {
        match self {
            Bin::Sim => "cargo sim",
            Bin::Hil => "cargo hil",
        }
    }
    /// The binary's file name.
    fn file(self) -> &'static str {
        match self {
            Bin::Sim => "sim-host",
            Bin::Hil => "hil",
        }
    }
}

/// Which lines of a command's standard output a block keeps.
#[derive(Debug, Clone, Copy)]
pub enum Keep {
    /// Every line.
    All,
    /// Every line but those containing one of these (figures that depend on the
    /// machine: wall times, host nanoseconds).
    AllBut(&'static [&'static str]),
    /// Only the lines starting with one of these (a long report's summary lines).
    Starting(&'static [&'static str]),
    /// The output is Markdown: the block is the output verbatim, no text fence and no
    /// command line (the block says its command itself).
    Markdown,
}

impl Keep {
    fn keeps(self, line: &str) -> bool {
        match self {
            Keep::All | Keep::Markdown => true,
            Keep::Starting(p) => p.iter().any(|p| line.starts_with(p)),
            Keep::AllBut(p) => !p.iter().any(|p| line.contains(p)),
        }
    }
}

/// One generated block: its name in the markers, the command and what it keeps.
#[derive(Debug, Clone, Copy)]
pub struct Block {
    /// The name in `<!-- generated:NAME -->`.
    pub name: &'static str,
    /// The binary.
    pub bin: Bin,
    /// Its arguments (the README shows `alias args...`).
    pub args: &'static [&'static str],
    /// The exit code the command is expected to end with.
    pub exit: i32,
    /// The lines of standard output kept.
    pub keep: Keep,
    /// Quote standard error instead of standard output (a refusal's message).
    pub stderr: bool,
}

impl Block {
    /// The command as the README shows it: the alias and the arguments.
    pub fn shown(&self) -> String {
        std::iter::once(self.bin.alias())
            .chain(self.args.iter().copied())
            .collect::<Vec<_>>()
            .join(" ")
    }
}

/// Lines whose figures depend on the machine or its load.
const MACHINE_DEPENDENT: &[&str] = &["wall", "host_tick", "host time", "exchanges/s"];

/// Every generated block of the README.
pub const BLOCKS: &[Block] = &[
    // Plant simulator: Figs. 2-5, 6-8, 9.
    Block {
        name: "modes",
        bin: Bin::Sim,
        args: &["modes", "--json", "out/modes.json", "--plot", "out/modes"],
        exit: 0,
        keep: Keep::All,
        stderr: false,
    },
    Block {
        name: "fig6-8",
        bin: Bin::Sim,
        args: &[
            "run",
            "--scenario",
            "curve",
            "--control",
            "lead",
            "--compare",
            "passive",
            "--csv",
            "out/curve.csv",
            "--plot",
            "out/fig6-8",
            "--at",
            "4.9",
            "--at",
            "11.9",
        ],
        exit: 0,
        keep: Keep::All,
        stderr: false,
    },
    Block {
        name: "fig9",
        bin: Bin::Sim,
        args: &[
            "run",
            "--scenario",
            "beating",
            "--control",
            "passive",
            "--csv",
            "out/beating.csv",
            "--plot",
            "out/fig9",
        ],
        exit: 0,
        keep: Keep::All,
        stderr: false,
    },
    Block {
        name: "fig9-lead",
        bin: Bin::Sim,
        args: &["run", "--scenario", "beating", "--control", "lead"],
        exit: 0,
        keep: Keep::All,
        stderr: false,
    },
    // Adhesion-limited traction.
    Block {
        name: "adhesion-dry",
        bin: Bin::Sim,
        args: &[
            "adhesion",
            "--condition",
            "dry",
            "--json",
            "out/adh-dry.json",
            "--plot",
            "out/adh",
        ],
        exit: 0,
        keep: Keep::All,
        stderr: false,
    },
    Block {
        name: "adhesion-wet",
        bin: Bin::Sim,
        args: &[
            "adhesion",
            "--condition",
            "wet",
            "--json",
            "out/adh-wet.json",
            "--plot",
            "out/adh",
        ],
        exit: 0,
        keep: Keep::All,
        stderr: false,
    },
    Block {
        name: "adhesion-low",
        bin: Bin::Sim,
        args: &[
            "adhesion",
            "--condition",
            "low",
            "--json",
            "out/adh-low.json",
            "--plot",
            "out/adh",
        ],
        exit: 0,
        keep: Keep::All,
        stderr: false,
    },
    Block {
        name: "low-adhesion-on",
        bin: Bin::Sim,
        args: &[
            "run",
            "--scenario",
            "low-adhesion",
            "--control",
            "lead",
            "--loop",
            "core",
            "--wsp",
            "on",
            "--json",
            "out/low-on.json",
            "--csv",
            "out/low-on.csv",
            "--plot",
            "out/low",
        ],
        exit: 0,
        keep: Keep::All,
        stderr: false,
    },
    Block {
        name: "low-adhesion-off",
        bin: Bin::Sim,
        args: &[
            "run",
            "--scenario",
            "low-adhesion",
            "--control",
            "lead",
            "--loop",
            "core",
            "--wsp",
            "off",
            "--json",
            "out/low-off.json",
        ],
        exit: 0,
        keep: Keep::All,
        stderr: false,
    },
    Block {
        name: "actuator-fault",
        bin: Bin::Hil,
        args: &["run", "--scenario", "actuator-fault", "--report", "out/af"],
        exit: 0,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    // The closed loop over the simulated link.
    Block {
        name: "device-clean",
        bin: Bin::Sim,
        args: &[
            "run",
            "--scenario",
            "curve",
            "--control",
            "lead",
            "--loop",
            "device",
            "--csv",
            "out/device.csv",
        ],
        exit: 0,
        keep: Keep::All,
        stderr: false,
    },
    Block {
        name: "device-faults-seed1",
        bin: Bin::Sim,
        args: &[
            "run",
            "--scenario",
            "curve",
            "--control",
            "lead",
            "--loop",
            "device",
            "--faults",
            "ber=1e-3,drop=0.1,outage=8.0:0.05",
            "--seed",
            "1",
        ],
        exit: 0,
        keep: Keep::All,
        stderr: false,
    },
    Block {
        name: "device-acceleration",
        bin: Bin::Sim,
        args: &[
            "run",
            "--scenario",
            "curve",
            "--control",
            "lead",
            "--loop",
            "device",
            "--lateral",
            "acceleration",
        ],
        exit: 0,
        keep: Keep::Starting(&["vs continuous reference"]),
        stderr: false,
    },
    Block {
        name: "device-baud-refused",
        bin: Bin::Sim,
        args: &[
            "run",
            "--scenario",
            "curve",
            "--control",
            "lead",
            "--loop",
            "device",
            "--baud",
            "115200",
        ],
        exit: 2,
        keep: Keep::All,
        stderr: true,
    },
    Block {
        name: "rates",
        bin: Bin::Sim,
        args: &["rates"],
        exit: 0,
        keep: Keep::All,
        stderr: false,
    },
    // The fixed-point audit (Markdown: `hil::audit::readme`).
    Block {
        name: "audit",
        bin: Bin::Hil,
        args: &["audit", "--no-target", "--readme-block"],
        exit: 0,
        keep: Keep::Markdown,
        stderr: false,
    },
    // The harness, in process.
    Block {
        name: "hil",
        bin: Bin::Hil,
        args: &[],
        exit: 0,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    Block {
        name: "hil-faults",
        bin: Bin::Hil,
        args: &["run", "--faults", "ber=1e-4,drop=0.01"],
        exit: 1,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    Block {
        name: "hil-wrong-sign",
        bin: Bin::Hil,
        args: &["run", "--device-fault", "wrong-sign"],
        exit: 1,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    Block {
        name: "hil-slow",
        bin: Bin::Hil,
        args: &["run", "--device-fault", "slow:300"],
        exit: 1,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    Block {
        name: "hil-jitter",
        bin: Bin::Hil,
        args: &["run", "--device-fault", "jitter:40"],
        exit: 1,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    Block {
        name: "hil-corrupt",
        bin: Bin::Hil,
        args: &["run", "--device-fault", "corrupt:10"],
        exit: 1,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    Block {
        name: "hil-gain",
        bin: Bin::Hil,
        args: &["run", "--control", "gain"],
        exit: 0,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    Block {
        name: "hil-beating",
        bin: Bin::Hil,
        args: &["run", "--scenario", "beating"],
        exit: 1,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    Block {
        name: "hil-short",
        bin: Bin::Hil,
        args: &["run", "--scenario", "hil/tests/data/short.toml"],
        exit: 0,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    Block {
        name: "golden",
        bin: Bin::Hil,
        args: &["golden"],
        exit: 0,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    // Any operating point and campaigns over the envelope (issue 15).
    Block {
        name: "hil-params-3mn",
        bin: Bin::Hil,
        args: &["run", "--params", "sim-host/params/creep-3mn.toml"],
        exit: 0,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    Block {
        name: "hil-params-conicity",
        bin: Bin::Hil,
        args: &["run", "--params", "sim-host/params/conicity-0.4.toml"],
        exit: 0,
        keep: Keep::AllBut(MACHINE_DEPENDENT),
        stderr: false,
    },
    Block {
        name: "hil-sweep",
        bin: Bin::Hil,
        args: &[
            "sweep",
            "--param",
            "f11=1e6..1e7:5",
            "--param",
            "lambda=0.05..0.4:4",
            "--json",
            "out/sweep.json",
            "--report",
            "out/sweep",
        ],
        exit: 1,
        keep: Keep::All,
        stderr: false,
    },
];

/// A run of every block's command: the block's new text, or why it could not be made.
fn generate(root: &Path, bin_dir: &Path, b: &Block) -> Result<String, String> {
    let exe = bin_dir.join(b.bin.file());
    let shown = b.shown();
    let out = Command::new(&exe)
        .args(b.args)
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

fn open(name: &str) -> String {
    format!("<!-- generated:{name} -->")
}

fn close(name: &str) -> String {
    format!("<!-- /generated:{name} -->")
}

/// The blocks of `readme`: `(name, byte range of the text between the markers)`, in
/// order. A marker is a line of its own (a marker quoted inside a line of text is not
/// one); an error for a marker without its close, a nested or a repeated block.
pub fn find_blocks(readme: &str) -> Result<Vec<(String, std::ops::Range<usize>)>, String> {
    let mut found: Vec<(String, std::ops::Range<usize>)> = Vec::new();
    // (name, body start, line number) of the open block.
    let mut open_block: Option<(String, usize, usize)> = None;
    let mut at = 0;
    for (i, line) in readme.split_inclusive('\n').enumerate() {
        let start = at;
        at += line.len();
        let t = line.trim();
        let marker = |prefix: &str| {
            t.strip_prefix(prefix)
                .and_then(|r| r.strip_suffix(" -->"))
                .map(str::to_string)
        };
        if let Some(name) = marker("<!-- generated:") {
            if let Some((outer, _, l)) = &open_block {
                return Err(format!(
                    "README.md:{}: block `{name}` inside block `{outer}` (opened at line {l})",
                    i + 1
                ));
            }
            if name.is_empty() || name.contains(char::is_whitespace) {
                return Err(format!("README.md:{}: a bad block name `{name}`", i + 1));
            }
            if found.iter().any(|(n, _)| *n == name) {
                return Err(format!("README.md:{}: block `{name}` appears twice", i + 1));
            }
            open_block = Some((name, at, i + 1));
        } else if let Some(name) = marker("<!-- /generated:") {
            match open_block.take() {
                Some((n, body, _)) if n == name => found.push((n, body..start)),
                Some((n, _, l)) => {
                    return Err(format!(
                        "README.md:{}: `{}` closes block `{n}` (opened at line {l})",
                        i + 1,
                        close(&name)
                    ))
                }
                None => {
                    return Err(format!(
                        "README.md:{}: `{}` without its opening marker",
                        i + 1,
                        close(&name)
                    ))
                }
            }
        }
    }
    if let Some((name, _, l)) = open_block {
        return Err(format!(
            "README.md:{l}: block `{name}` has no `{}`",
            close(&name)
        ));
    }
    Ok(found)
}

/// A line diff of `old` and `new` (longest common subsequence): `-` lines only in
/// `old`, `+` lines only in `new`, two-space lines common to both.
pub fn diff(old: &str, new: &str) -> String {
    let a: Vec<&str> = old.lines().collect();
    let b: Vec<&str> = new.lines().collect();
    let (n, m) = (a.len(), b.len());
    // lcs[i][j]: the longest common subsequence of a[i..] and b[j..].
    let mut lcs = vec![vec![0usize; m + 1]; n + 1];
    for i in (0..n).rev() {
        for j in (0..m).rev() {
            lcs[i][j] = if a[i] == b[j] {
                lcs[i + 1][j + 1] + 1
            } else {
                lcs[i + 1][j].max(lcs[i][j + 1])
            };
        }
    }
    let mut s = String::new();
    let (mut i, mut j) = (0, 0);
    while i < n || j < m {
        if i < n && j < m && a[i] == b[j] {
            let _ = writeln!(s, "  {}", a[i]);
            i += 1;
            j += 1;
        } else if i < n && (j == m || lcs[i + 1][j] >= lcs[i][j + 1]) {
            let _ = writeln!(s, "- {}", a[i]);
            i += 1;
        } else {
            let _ = writeln!(s, "+ {}", b[j]);
            j += 1;
        }
    }
    s
}

/// Rewrites (or with `check`, compares) the blocks of `readme` with `fresh`, the new
/// text per block name. Returns the new README and the names of the blocks that
/// differ, with their diffs.
pub fn update(
    readme: &str,
    fresh: &[(&str, String)],
) -> Result<(String, Vec<(String, String)>), String> {
    let found = find_blocks(readme)?;
    for (name, _) in &found {
        if !fresh.iter().any(|(n, _)| n == name) {
            return Err(format!(
                "README.md: block `{name}` has no command in the table of xtask/src/readme.rs"
            ));
        }
    }
    for (name, _) in fresh {
        if !found.iter().any(|(n, _)| n == name) {
            return Err(format!(
                "README.md: no block `{name}` (xtask/src/readme.rs lists it): add `{}` and `{}`",
                open(name),
                close(name)
            ));
        }
    }
    let mut out = String::with_capacity(readme.len());
    let mut drifted = Vec::new();
    let mut at = 0;
    for (name, range) in &found {
        let new = &fresh
            .iter()
            .find(|(n, _)| n == name)
            .map(|(_, t)| t.as_str())
            .unwrap_or_default();
        let old = &readme[range.clone()];
        if old != *new {
            drifted.push((name.clone(), diff(old, new)));
        }
        out.push_str(&readme[at..range.start]);
        out.push_str(new);
        at = range.end;
    }
    out.push_str(&readme[at..]);
    Ok((out, drifted))
}

/// How the README's commands are run by [`run_commands`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Class {
    /// Run in every `cargo xtest` (seconds each).
    Short,
    /// Run with `--long` only (CI: `.ci/run`): QEMU runs, benchmarks, the firmware
    /// builds, the test suites, lints.
    Long,
    /// Never run here: it needs a board, installs software, runs until killed, is the
    /// test command itself, or is a form with placeholders.
    Skip(&'static str),
}

/// The rules of [`classify`], first match wins: `(substring, class)`.
const RULES: &[(&str, Class)] = &[
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
    ("--condition C ", Class::Skip("a form with placeholders")),
    ("defmt-print", Class::Skip("needs defmt-print installed")),
    (
        "--frames 10000000",
        Class::Skip("a 3-minute run (its seeded short form is a test)"),
    ),
    (
        "--target qemu:",
        Class::Skip("needs a QEMU started by hand (hil/tests/qemu_by_hand.rs runs the pair)"),
    ),
    ("--target qemu", Class::Long),
    ("cargo fw", Class::Long),
    ("fw-bench", Class::Long),
    ("qemu-cmd", Class::Long),
    ("cargo bench", Class::Long),
    ("cargo test", Class::Long),
    ("cargo clippy", Class::Long),
    ("cargo fmt", Class::Long),
    (" audit", Class::Long),
    ("cargo sim", Class::Short),
    ("cargo hil", Class::Short),
    ("cargo xtask fuzz", Class::Short),
];

/// The class of a README command ([`RULES`]; anything else is skipped as unknown).
pub fn classify(cmd: &str) -> Class {
    RULES
        .iter()
        .find(|(k, _)| cmd.contains(k))
        .map_or(Class::Skip("not a project command"), |&(_, c)| c)
}

/// One command of the README: the text, the exit code the README states for it (`exit N`
/// after it on its line; 0 otherwise) and its line number.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReadmeCommand {
    /// The command as written.
    pub text: String,
    /// The exit code stated, 0 if none.
    pub exit: i32,
    /// 1-based line in README.md.
    pub line: usize,
}

/// `exit N` in `s` (the first), if any.
fn stated_exit(s: &str) -> Option<i32> {
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
    let mut in_sh = false;
    let mut in_other = false;
    for (i, l) in readme.lines().enumerate() {
        let t = l.trim_start();
        if t.starts_with("```") {
            if in_sh || in_other {
                in_sh = false;
                in_other = false;
            } else if t == "```sh" {
                in_sh = true;
            } else {
                in_other = true;
            }
            continue;
        }
        if in_other {
            continue;
        }
        if in_sh {
            let (cmd, comment) = l.split_once('#').unwrap_or((l, ""));
            push(cmd, comment, i + 1);
            continue;
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

/// Runs the README's commands (`long`: also the long ones) from the workspace root with
/// `sh -c`, each checked against its stated exit code. Prints one line per command;
/// returns the failures.
pub fn run_commands(long: bool) -> Result<Vec<String>, String> {
    let root = crate::workspace_root();
    let path = root.join("README.md");
    let readme = std::fs::read_to_string(&path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let mut failures = Vec::new();
    for c in commands(&readme) {
        let class = classify(&c.text);
        match class {
            Class::Skip(why) => {
                eprintln!(
                    "xtask readme: skip  README.md:{} `{}` ({why})",
                    c.line, c.text
                );
                continue;
            }
            Class::Long if !long => {
                eprintln!(
                    "xtask readme: long  README.md:{} `{}` (with --long)",
                    c.line, c.text
                );
                continue;
            }
            _ => {}
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
            "xtask readme: {}  README.md:{} `{}` exit {code} (README: {}), {:.1} s",
            if ok { "ok  " } else { "FAIL" },
            c.line,
            c.text,
            c.exit,
            t0.elapsed().as_secs_f64()
        );
        if !ok {
            let err = String::from_utf8_lossy(&out.stderr);
            let tail: Vec<&str> = err.lines().rev().take(15).collect();
            failures.push(format!(
                "README.md:{} `{}`: exit {code}, the README states {}; stderr ends:\n{}",
                c.line,
                c.text,
                c.exit,
                tail.into_iter().rev().collect::<Vec<_>>().join("\n")
            ));
        }
    }
    Ok(failures)
}

/// `cargo xtask readme [--check] [--dev] [--commands [--long]]` (the arguments after
/// `readme`).
pub fn main(args: &[String]) -> ExitCode {
    let mut check = false;
    let mut dev = false;
    let mut cmds = false;
    let mut long = false;
    for a in args {
        match a.as_str() {
            "--check" => check = true,
            "--dev" => dev = true,
            "--commands" => cmds = true,
            "--long" => long = true,
            other => {
                eprintln!(
                    "xtask readme: unknown argument `{other}` (usage: cargo xtask readme \
                     [--check] [--dev] | --commands [--long])"
                );
                return ExitCode::from(2);
            }
        }
    }
    if cmds {
        return match run_commands(long) {
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

#[cfg(test)]
mod tests {
    use super::*;

    const DOC: &str = "intro\n<!-- generated:a -->\nold a\n<!-- /generated:a -->\nmid\n\
                       <!-- generated:b -->\nsame\n<!-- /generated:b -->\nend\n";

    #[test]
    fn rewrites_only_between_the_markers_and_names_the_drifted() {
        let fresh = [("a", "new a\n".to_string()), ("b", "same\n".to_string())];
        let (out, drifted) = update(DOC, &fresh).expect("update");
        assert_eq!(
            out,
            "intro\n<!-- generated:a -->\nnew a\n<!-- /generated:a -->\nmid\n\
             <!-- generated:b -->\nsame\n<!-- /generated:b -->\nend\n"
        );
        assert_eq!(drifted.len(), 1);
        assert_eq!(drifted[0].0, "a");
        assert_eq!(drifted[0].1, "- old a\n+ new a\n");
        // Rewritten, nothing drifts any more.
        let (again, none) = update(&out, &fresh).expect("update");
        assert_eq!(again, out);
        assert!(none.is_empty());
    }

    #[test]
    fn unknown_missing_unclosed_and_repeated_blocks_are_errors() {
        let only_a = [("a", String::new())];
        let e = update(DOC, &only_a).expect_err("b has no command");
        assert!(e.contains("block `b` has no command"), "{e}");
        let abc = [
            ("a", String::new()),
            ("b", String::new()),
            ("c", String::new()),
        ];
        let e = update(DOC, &abc).expect_err("c is not in the README");
        assert!(e.contains("no block `c`"), "{e}");
        let e = find_blocks("<!-- generated:x -->\nbody\n").expect_err("unclosed");
        assert!(e.contains("block `x` has no"), "{e}");
        let twice = format!("{DOC}<!-- generated:a -->\n<!-- /generated:a -->\n");
        let e = find_blocks(&twice).expect_err("twice");
        assert!(e.contains("appears twice"), "{e}");
        // A marker quoted in a line of text is not a marker.
        let quoted =
            "see `<!-- generated:NAME -->` here\n<!-- generated:a -->\nx\n<!-- /generated:a -->\n";
        let f = find_blocks(quoted).expect("quoted");
        assert_eq!(f.len(), 1);
        assert_eq!(&quoted[f[0].1.clone()], "x\n");
    }

    #[test]
    fn diff_marks_removed_added_and_common_lines() {
        let d = diff("x\ny\nz\n", "x\nY\nz\nw\n");
        assert_eq!(d, "  x\n- y\n+ Y\n  z\n+ w\n");
    }

    #[test]
    fn every_block_of_the_table_is_in_the_readme_once() {
        let readme =
            std::fs::read_to_string(crate::workspace_root().join("README.md")).expect("README.md");
        let found = find_blocks(&readme).expect("README's blocks");
        for b in BLOCKS {
            assert_eq!(
                found.iter().filter(|(n, _)| n == b.name).count(),
                1,
                "block {}",
                b.name
            );
        }
        assert_eq!(
            found.len(),
            BLOCKS.len(),
            "a README block without a command"
        );
    }

    #[test]
    fn commands_come_from_sh_blocks_and_inline_spans_with_their_exit_codes() {
        let doc = "text `cargo hil run --device-fault slow:300` | exit 1: late |\n\
                   ```sh\n# a comment\ncargo sim rates   # the table\n\
                   cargo hil run --faults ber=1e-4  # exit 1: frames\n```\n\
                   ```text\n$ cargo sim modes\n```\n`cargo sim rates` again, `ls`\n";
        let c = commands(doc);
        let got: Vec<(&str, i32, usize)> = c
            .iter()
            .map(|c| (c.text.as_str(), c.exit, c.line))
            .collect();
        assert_eq!(
            got,
            [
                ("cargo hil run --device-fault slow:300", 1, 1),
                ("cargo sim rates", 0, 4),
                ("cargo hil run --faults ber=1e-4", 1, 5),
            ]
        );
    }

    #[test]
    fn boards_and_forms_are_skipped_qemu_is_long() {
        assert!(matches!(
            classify("cargo hil run --target serial:/dev/ttyACM0 --baud 921600"),
            Class::Skip(_)
        ));
        assert!(matches!(classify("cargo xtest"), Class::Skip(_)));
        assert!(matches!(
            classify("cargo xtask fuzz --frames N [--seed S]"),
            Class::Skip(_)
        ));
        assert_eq!(classify("cargo hil run --target qemu"), Class::Long);
        assert!(matches!(
            classify("cargo hil run --target qemu:4444"),
            Class::Skip(_)
        ));
        assert_eq!(
            classify("cargo clippy --workspace --all-targets -- -D warnings"),
            Class::Long
        );
        assert_eq!(classify("cargo hil golden"), Class::Short);
        assert_eq!(classify("cargo sim rates"), Class::Short);
    }

    #[test]
    fn the_readme_clippy_line_is_the_one_ci_runs() {
        let root = crate::workspace_root();
        let readme = std::fs::read_to_string(root.join("README.md")).expect("README.md");
        let ci = std::fs::read_to_string(root.join(".ci/run")).expect(".ci/run");
        let clippy: Vec<String> = commands(&readme)
            .into_iter()
            .filter(|c| c.text.starts_with("cargo clippy"))
            .map(|c| c.text)
            .collect();
        assert!(!clippy.is_empty(), "the README names no clippy command");
        for c in clippy {
            assert!(
                ci.lines().any(|l| l.trim() == c),
                "`{c}` is not a line of .ci/run"
            );
        }
    }

    #[test]
    fn keep_filters() {
        assert!(Keep::All.keeps("anything"));
        assert!(Keep::Markdown.keeps("| a | b |"));
        assert!(Keep::Starting(&["  warn "]).keeps("  warn yaw_lead x"));
        assert!(!Keep::Starting(&["  warn "]).keeps("  pass yaw_lead x"));
        assert!(!Keep::AllBut(MACHINE_DEPENDENT).keeps("pass, 0.5 s wall"));
        assert!(Keep::AllBut(MACHINE_DEPENDENT).keeps("frames 200 005 sent"));
    }
}
