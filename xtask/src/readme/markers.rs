//! The blocks' markers in the pages (the README and the book's chapters): finding them,
//! rewriting the text between them and the line diff of a drifted block.

use std::fmt::Write as _;

pub(super) fn open(name: &str) -> String {
    format!("<!-- generated:{name} -->")
}

pub(super) fn close(name: &str) -> String {
    format!("<!-- /generated:{name} -->")
}

/// The blocks of `readme` (the page `page`): `(name, byte range between the markers)`,
/// in order; a marker is a line of its own. Errors: an unclosed, nested or repeated block.
pub fn find_blocks(
    page: &str,
    readme: &str,
) -> Result<Vec<(String, std::ops::Range<usize>)>, String> {
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
                    "{page}:{}: block `{name}` inside block `{outer}` (opened at line {l})",
                    i + 1
                ));
            }
            if name.is_empty() || name.contains(char::is_whitespace) {
                return Err(format!("{page}:{}: a bad block name `{name}`", i + 1));
            }
            if found.iter().any(|(n, _)| *n == name) {
                return Err(format!("{page}:{}: block `{name}` appears twice", i + 1));
            }
            open_block = Some((name, at, i + 1));
        } else if let Some(name) = marker("<!-- /generated:") {
            match open_block.take() {
                Some((n, body, _)) if n == name => found.push((n, body..start)),
                Some((n, _, l)) => {
                    return Err(format!(
                        "{page}:{}: `{}` closes block `{n}` (opened at line {l})",
                        i + 1,
                        close(&name)
                    ))
                }
                None => {
                    return Err(format!(
                        "{page}:{}: `{}` without its opening marker",
                        i + 1,
                        close(&name)
                    ))
                }
            }
        }
    }
    if let Some((name, _, l)) = open_block {
        return Err(format!(
            "{page}:{l}: block `{name}` has no `{}`",
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

/// What [`update`] returns.
pub type Updated = (Vec<String>, Vec<(String, String)>);

/// Rewrites (or with `check`, compares) the blocks of `pages` with `fresh`, the new text
/// per block name; every block in exactly one page and in the table. Returns each page's
/// new text and the blocks that differ with their diffs.
pub fn update(pages: &[(String, String)], fresh: &[(&str, String)]) -> Result<Updated, String> {
    let mut found: Vec<(&str, String, std::ops::Range<usize>)> = Vec::new();
    for (page, text) in pages {
        for (name, range) in find_blocks(page, text)? {
            if let Some((other, _, _)) = found.iter().find(|f| f.1 == name) {
                return Err(format!(
                    "block `{name}` appears in {other} and in {page}: a block has one home"
                ));
            }
            if !fresh.iter().any(|(n, _)| *n == name) {
                return Err(format!(
                    "{page}: block `{name}` has no command in the table of xtask/src/readme/blocks.rs"
                ));
            }
            found.push((page.as_str(), name, range));
        }
    }
    for (name, _) in fresh {
        if !found.iter().any(|(_, n, _)| n == name) {
            return Err(format!(
                "no page holds block `{name}` (xtask/src/readme/blocks.rs lists it): add `{}` and `{}` \
                 to README.md or a chapter of docs/",
                open(name),
                close(name)
            ));
        }
    }
    let mut out = Vec::with_capacity(pages.len());
    let mut drifted = Vec::new();
    for (page, text) in pages {
        let mut new_text = String::with_capacity(text.len());
        let mut at = 0;
        for (_, name, range) in found.iter().filter(|(p, _, _)| *p == page.as_str()) {
            let new = fresh
                .iter()
                .find(|(n, _)| n == name)
                .map(|(_, t)| t.as_str())
                .unwrap_or_default();
            let old = &text[range.clone()];
            if old != new {
                drifted.push((name.clone(), diff(old, new)));
            }
            new_text.push_str(&text[at..range.start]);
            new_text.push_str(new);
            at = range.end;
        }
        new_text.push_str(&text[at..]);
        out.push(new_text);
    }
    Ok((out, drifted))
}

/// The pages whose prose quotes their generated blocks' figures: [`unquoted`] must find
/// none in them.
pub const QUOTING: &[&str] = &[
    "docs/reproduce.md",
    "docs/campaigns.md",
    "docs/audit.md",
    "docs/harness.md",
    "docs/closed-loop.md",
    "docs/monitor.md",
];

/// Figures of the prose that are budgets or constants, not a command's output: `(page, figure)`.
const CONSTANTS: &[(&str, &str)] = &[
    ("docs/harness.md", "0.85"),       // the `timing.link` fail share
    ("docs/harness.md", "5.75"),       // the core's current-reference slew time, ms
    ("docs/closed-loop.md", "5.3125"), // the Nucleo-G474 VCP's baud, Mbaud
    ("docs/monitor.md", "0.01"),       // a fault rate of a command line
    ("docs/monitor.md", "0.05"),       // a conicity and an outage of command lines
];

/// The decimal figures (two or more fraction digits) of `text` outside its generated
/// blocks that none of its blocks holds, but for [`CONSTANTS`]: a quoted figure that has
/// drifted from its command. Errors: as [`find_blocks`].
pub fn unquoted(page: &str, text: &str) -> Result<Vec<String>, String> {
    let blocks = find_blocks(page, text)?;
    let inside: String = blocks.iter().map(|(_, r)| &text[r.clone()]).collect();
    let mut prose = String::new();
    let mut at = 0;
    for (_, r) in &blocks {
        prose.push_str(&text[at..r.start]);
        at = r.end;
    }
    prose.push_str(&text[at..]);
    let word = |c: char| c.is_ascii_alphanumeric() || c == '.' || c == '_';
    let mut out = Vec::new();
    for tok in prose.split(|c: char| !word(c)) {
        let t = tok.trim_end_matches('.');
        let figure = t.split_once('.').is_some_and(|(i, f)| {
            !i.is_empty()
                && f.len() >= 2
                && i.chars().all(|c| c.is_ascii_digit())
                && f.chars().all(|c| c.is_ascii_digit())
        });
        let constant = CONSTANTS.iter().any(|&(p, f)| p == page && f == t);
        if figure && !constant && !inside.contains(t) && !out.iter().any(|o| o == t) {
            out.push(t.to_string());
        }
    }
    Ok(out)
}
