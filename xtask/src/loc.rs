//! `cargo xtask loc [--check]`: the non-blank lines of the workspace's `.rs` files
//! outside `tests/`, `benches/`, `examples/`, `*tests.rs` and `#[cfg(test)]` items, and
//! of them the comment lines (starting with `//`); `--check` (run by `cargo xtest`) fails
//! above [`CEILING`] or at [`MAX_COMMENT_SHARE`].

use std::path::{Path, PathBuf};

/// The non-test lines the workspace may not grow past: the count when it was last
/// lowered (lower it as code goes).
pub const CEILING: u64 = 41_976;
/// Comment lines must stay under this share of the non-test lines.
pub const MAX_COMMENT_SHARE: f64 = 0.15;

const ROOTS: [&str; 4] = ["firmware", "sim-host", "hil", "xtask"];

/// Lines of one body of code.
#[derive(Debug, Default, Clone, Copy, PartialEq, Eq)]
pub struct Lines {
    /// Non-blank lines.
    pub code: u64,
    /// Of which comment lines.
    pub comments: u64,
}

impl std::ops::AddAssign for Lines {
    fn add_assign(&mut self, o: Self) {
        self.code += o.code;
        self.comments += o.comments;
    }
}

/// The non-test lines of one file's text (module docs).
#[must_use]
pub fn count(text: &str) -> Lines {
    let mut l = Lines::default();
    let mut skip_depth: Option<i64> = None;
    let mut pending_test = false;
    for line in text.lines() {
        let t = line.trim();
        if let Some(depth) = skip_depth.as_mut() {
            *depth += braces(t);
            if *depth <= 0 {
                skip_depth = None;
            }
            continue;
        }
        if t.is_empty() {
            continue;
        }
        if t.starts_with("#[cfg(test)]") {
            pending_test = true;
            continue;
        }
        if pending_test && !t.starts_with("#[") && !t.starts_with("//") {
            pending_test = false;
            let b = braces(t);
            if t.contains('{') && b > 0 {
                skip_depth = Some(b);
                continue;
            }
            if t.ends_with(';') {
                // `mod tests;`: the file is counted (or not) by its name.
                continue;
            }
        }
        l.code += 1;
        l.comments += u64::from(t.starts_with("//"));
    }
    l
}

/// Opening minus closing braces on a line (strings and comments not told apart: the
/// crates' test modules open and close on their own lines).
fn braces(t: &str) -> i64 {
    let code = t.split("//").next().unwrap_or("");
    code.matches('{').count() as i64 - code.matches('}').count() as i64
}

fn is_test_path(p: &Path) -> bool {
    p.components().any(|c| {
        matches!(
            c.as_os_str().to_str(),
            Some("tests" | "benches" | "examples" | "target")
        )
    }) || p
        .file_name()
        .and_then(|n| n.to_str())
        .is_some_and(|n| n.ends_with("tests.rs"))
}

/// The count per crate folder (`firmware/control`, `xtask`, ...) under `root`, largest first.
pub fn workspace(root: &Path) -> Result<Vec<(String, Lines)>, String> {
    let mut files = Vec::new();
    for r in ROOTS {
        crate::files_under(&root.join(r), "rs", &root.join("target"), &mut files)?;
    }
    let mut by_crate = std::collections::BTreeMap::<String, Lines>::new();
    for f in &files {
        let rel = f.strip_prefix(root).unwrap_or(f);
        if is_test_path(rel) {
            continue;
        }
        let text = std::fs::read_to_string(f).map_err(|e| format!("{}: {e}", f.display()))?;
        let parts: Vec<_> = rel.components().take(2).collect();
        let name = if parts.len() == 2 && rel.starts_with("xtask") {
            "xtask".to_string()
        } else {
            PathBuf::from_iter(parts).display().to_string()
        };
        *by_crate.entry(name).or_default() += count(&text);
    }
    let mut v: Vec<_> = by_crate.into_iter().collect();
    v.sort_by_key(|(_, l)| std::cmp::Reverse(l.code));
    Ok(v)
}

/// Runs the task: prints the count per crate and in all; `check` fails above the limits.
pub fn main(check: bool) -> Result<(), String> {
    let crates = workspace(Path::new("."))?;
    let mut l = Lines::default();
    for (name, c) in &crates {
        outln!(
            "{name:<22} {:>6} lines, {:>5} comment lines = {:.1} %",
            c.code,
            c.comments,
            100.0 * c.comments as f64 / c.code.max(1) as f64
        );
        l += *c;
    }
    let share = l.comments as f64 / l.code.max(1) as f64;
    outln!(
        "non-test Rust: {} lines (ceiling {CEILING}), {} comment lines = {:.2} % \
         (must be under {:.0} %)",
        l.code,
        l.comments,
        100.0 * share,
        100.0 * MAX_COMMENT_SHARE
    );
    if check && (l.code > CEILING || share >= MAX_COMMENT_SHARE) {
        return Err("loc: the non-test Rust is above its ceiling or its comment share".into());
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn test_modules_blank_lines_and_test_files_are_not_counted() {
        let text = "//! Docs.\n\nfn a() {}\n// why\n#[cfg(test)]\nmod tests {\n    fn b() {\n    }\n}\nfn c() {}\n#[cfg(test)]\nmod more;\n";
        assert_eq!(
            count(text),
            Lines {
                code: 4,
                comments: 2
            }
        );
        assert!(is_test_path(Path::new("firmware/proto/tests/x.rs")));
        assert!(is_test_path(Path::new(
            "sim-host/loop/src/exchange/reset_tests.rs"
        )));
        assert!(!is_test_path(Path::new("sim-host/loop/src/exchange.rs")));
    }
}
