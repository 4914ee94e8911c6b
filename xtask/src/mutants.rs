//! `cargo xtask mutants [--package P]... [--file GLOB]... [--shard K/N] [--out DIR]` (or
//! `--summary DIR...`): cargo-mutants over the device crates, each against its own tests,
//! into `DIR/P[-K-of-N]` (default `target/mutants`); prints per package the mutants
//! caught, missed, unviable and timed out against the whole list (`docs/mutants.md`).
//! Exit 1 when a mutant is missed or times out.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::DEVICE_CRATES;

/// `cargo mutants` on `package` with its tests' features (the others only add derives).
fn cargo_mutants(package: &str) -> Command {
    let mut c = Command::new("cargo");
    c.args(["mutants", "--package", package]);
    match package {
        "wheelset-proto" => c.args(["--features", "std"]),
        "wheelset-runtime" => c.args(["--features", "fault-inject"]),
        _ => &mut c,
    };
    c
}

/// The outcomes cargo-mutants writes, one mutant per line, in its `mutants.out`.
const OUTCOMES: [&str; 4] = ["caught", "missed", "unviable", "timeout"];

/// Mutant counts of one package (over one or more output directories).
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Counts {
    /// A test failed with the mutant.
    pub caught: u64,
    /// No test failed.
    pub missed: u64,
    /// The mutant did not build.
    pub unviable: u64,
    /// The tests ran past the timeout.
    pub timeout: u64,
}

impl Counts {
    /// Adds the counts of `mutants.out` under `dir` (absent files count 0).
    pub fn add_dir(&mut self, dir: &Path) -> Result<(), String> {
        let out = dir.join("mutants.out");
        if !out.is_dir() {
            return Err(format!("{}: no cargo-mutants output there", out.display()));
        }
        for name in OUTCOMES {
            let f = out.join(format!("{name}.txt"));
            let n = match std::fs::read_to_string(&f) {
                Ok(t) => t.lines().filter(|l| !l.trim().is_empty()).count() as u64,
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => 0,
                Err(e) => return Err(format!("{}: {e}", f.display())),
            };
            match name {
                "caught" => self.caught += n,
                "missed" => self.missed += n,
                "unviable" => self.unviable += n,
                _ => self.timeout += n,
            }
        }
        Ok(())
    }

    /// Mutants run.
    #[must_use]
    pub fn tested(&self) -> u64 {
        self.caught + self.missed + self.unviable + self.timeout
    }

    /// The line printed for `package` with `listed` mutants in its whole list (unviable
    /// ones left out, every other one not caught counts against).
    #[must_use]
    pub fn line(&self, package: &str, listed: Option<u64>) -> String {
        let viable = listed.map_or(self.tested(), |l| l.max(self.tested())) - self.unviable;
        let share = if viable == 0 {
            "-".to_string()
        } else {
            format!("{:.1} %", 100.0 * self.caught as f64 / viable as f64)
        };
        let listed = listed.map_or("-".to_string(), |l| l.to_string());
        format!(
            "{package:<18} listed {listed:>5}  tested {:>5}  caught {:>5}  missed {:>4}  unviable {:>4}  timeout {:>3}  caught of viable {share}",
            self.tested(),
            self.caught,
            self.missed,
            self.unviable,
            self.timeout
        )
    }
}

fn listed(package: &str) -> Result<u64, String> {
    let out = cargo_mutants(package).arg("--list").output().map_err(|e| {
        format!("cargo mutants --list: {e} (install: cargo install cargo-mutants --locked)")
    })?;
    if !out.status.success() {
        return Err(format!(
            "cargo mutants --list --package {package}: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        ));
    }
    Ok(String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter(|l| !l.trim().is_empty())
        .count() as u64)
}

/// A shard `K/N` (0 <= K < N).
fn parse_shard(s: &str) -> Result<(u32, u32), String> {
    let bad = || format!("--shard {s}: expected K/N with 0 <= K < N");
    let (k, n) = s.split_once('/').ok_or_else(bad)?;
    let (k, n) = (
        k.parse::<u32>().map_err(|_| bad())?,
        n.parse::<u32>().map_err(|_| bad())?,
    );
    if n == 0 || k >= n {
        return Err(bad());
    }
    Ok((k, n))
}

#[derive(Debug, Default, PartialEq)]
struct Args {
    packages: Vec<String>,
    files: Vec<String>,
    shard: Option<(u32, u32)>,
    out: Option<PathBuf>,
    summary: Vec<PathBuf>,
}

fn parse(args: &[String]) -> Result<Args, String> {
    let mut a = Args::default();
    let mut it = args.iter();
    while let Some(flag) = it.next() {
        let mut value = || {
            it.next()
                .cloned()
                .ok_or_else(|| format!("mutants: {flag} needs a value"))
        };
        match flag.as_str() {
            "--package" | "-p" => {
                let p = value()?;
                if !DEVICE_CRATES.contains(&p.as_str()) {
                    return Err(format!(
                        "mutants: --package {p}: one of {}",
                        DEVICE_CRATES.join(", ")
                    ));
                }
                a.packages.push(p);
            }
            "--file" | "-f" => a.files.push(value()?),
            "--shard" => a.shard = Some(parse_shard(&value()?)?),
            "--out" => a.out = Some(PathBuf::from(value()?)),
            "--summary" => {
                a.summary.push(PathBuf::from(value()?));
                a.summary.extend(it.by_ref().map(PathBuf::from));
            }
            other => return Err(format!("mutants: unexpected `{other}`")),
        }
    }
    if !a.summary.is_empty() && (a.shard.is_some() || !a.files.is_empty()) {
        return Err("mutants: --summary reads earlier runs; it takes no --shard or --file".into());
    }
    if a.packages.is_empty() {
        a.packages = DEVICE_CRATES.iter().map(|s| (*s).to_string()).collect();
    }
    Ok(a)
}

/// The package an output directory holds (its name up to the shard suffix).
fn package_of(dir: &Path) -> Option<&'static str> {
    let name = dir.file_name()?.to_str()?;
    DEVICE_CRATES
        .iter()
        .copied()
        .find(|p| name == *p || name.starts_with(&format!("{p}-")))
}

/// Runs the task; `Ok(false)` when a mutant was missed or timed out.
pub fn main(args: &[String]) -> Result<bool, String> {
    let a = parse(args)?;
    if !a.summary.is_empty() {
        let mut clean = true;
        for p in DEVICE_CRATES {
            let dirs: Vec<&PathBuf> = a
                .summary
                .iter()
                .filter(|d| package_of(d) == Some(p))
                .collect();
            if dirs.is_empty() {
                continue;
            }
            let mut c = Counts::default();
            for d in dirs {
                c.add_dir(d)?;
            }
            clean &= c.missed + c.timeout == 0;
            outln!("{}", c.line(p, listed(p).ok()));
        }
        return Ok(clean);
    }
    let root = a
        .out
        .clone()
        .unwrap_or_else(|| PathBuf::from("target/mutants"));
    let mut clean = true;
    let mut lines = Vec::new();
    for p in &a.packages {
        let dir = match a.shard {
            Some((k, n)) => root.join(format!("{p}-{k}-of-{n}")),
            None => root.join(p),
        };
        std::fs::create_dir_all(&dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let mut c = cargo_mutants(p);
        c.args(["--no-shuffle", "--output"]).arg(&dir);
        for f in &a.files {
            c.args(["--file", f]);
        }
        if let Some((k, n)) = a.shard {
            c.args(["--shard", &format!("{k}/{n}")]);
        }
        outln!("xtask mutants: {p} -> {}", dir.display());
        let status = c.status().map_err(|e| {
            format!("cargo mutants: {e} (install: cargo install cargo-mutants --locked)")
        })?;
        // 0: all caught; 2: some missed; 3: some timed out; anything else a failed run.
        match status.code() {
            Some(0 | 2 | 3) => {}
            other => return Err(format!("cargo mutants --package {p} ended with {other:?}")),
        }
        let mut counts = Counts::default();
        counts.add_dir(&dir)?;
        clean &= counts.missed + counts.timeout == 0;
        // The denominator: the whole list, unless the run was a part of it by choice.
        let whole = if a.shard.is_none() && a.files.is_empty() {
            Some(listed(p)?)
        } else {
            None
        };
        lines.push(counts.line(p, whole));
    }
    for l in lines {
        outln!("{l}");
    }
    Ok(clean)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn s(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| (*s).to_string()).collect()
    }

    #[test]
    fn the_command_line_is_parsed_and_bad_input_refused() {
        let a = parse(&s(&["--package", "wheelset-proto", "--shard", "1/4"])).expect("valid");
        assert_eq!(a.packages, ["wheelset-proto"]);
        assert_eq!(a.shard, Some((1, 4)));
        assert_eq!(parse(&[]).expect("valid").packages.len(), 3);
        for (bad, why) in [
            (&["--shard", "4/4"][..], "0 <= K < N"),
            (&["--shard", "x"], "K/N"),
            (&["--package", "hil"], "one of"),
            (&["--bogus"], "unexpected"),
            (&["--file"], "needs a value"),
            (&["--shard", "0/2", "--summary", "d"], "takes no"),
        ] {
            let e = parse(&s(bad)).expect_err("refused");
            assert!(e.contains(why), "{bad:?}: {e}");
        }
    }

    #[test]
    fn the_counts_are_read_from_the_outcome_files_and_shares_judged_on_the_list() {
        let dir = std::env::temp_dir().join(format!("xtask-mutants-{}", std::process::id()));
        let out = dir.join("wheelset-proto-0-of-2").join("mutants.out");
        std::fs::create_dir_all(&out).expect("temp dir");
        std::fs::write(out.join("caught.txt"), "a\nb\nc\n\n").expect("write");
        std::fs::write(out.join("missed.txt"), "d\n").expect("write");
        std::fs::write(out.join("unviable.txt"), "e\n").expect("write");
        let mut c = Counts::default();
        c.add_dir(&dir.join("wheelset-proto-0-of-2")).expect("read");
        assert_eq!(
            c,
            Counts {
                caught: 3,
                missed: 1,
                unviable: 1,
                timeout: 0
            }
        );
        // 3 caught of 4 viable run; of a list of 9 (8 viable), 3 of 8.
        assert!(
            c.line("p", None).ends_with("75.0 %"),
            "{}",
            c.line("p", None)
        );
        assert!(
            c.line("p", Some(9)).ends_with("37.5 %"),
            "{}",
            c.line("p", Some(9))
        );
        assert_eq!(
            package_of(&dir.join("wheelset-proto-0-of-2")),
            Some("wheelset-proto")
        );
        assert!(Counts::default().add_dir(&dir).is_err());
        let _ = std::fs::remove_dir_all(&dir);
    }
}
