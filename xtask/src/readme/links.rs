//! The pages' links: every relative link and image path of the README and the book
//! resolves to a file or folder of the repository (anchors and links with a scheme are
//! not checked), every image is a figure of [`super::figures::FIGURES`], and a chapter
//! under `docs/` links only inside `docs/` (mdBook renders that folder alone).

use std::path::{Component, Path, PathBuf};

/// One link of a page: its target as written, whether it is an image, and its line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Link {
    /// The target as written (`docs/model.md#parameters`, `figures/x.svg`).
    pub target: String,
    /// `![alt](target)` or `<img src="target">`.
    pub image: bool,
    /// 1-based line in its page.
    pub line: usize,
}

/// The inline links and images of `text` (`[text](target)`, `![alt](target)`,
/// `<img src="target">`), outside code blocks and inline code spans.
pub fn links(text: &str) -> Vec<Link> {
    let mut out = Vec::new();
    let mut fence = false;
    for (i, line) in text.lines().enumerate() {
        if line.trim_start().starts_with("```") {
            fence = !fence;
            continue;
        }
        if fence {
            continue;
        }
        // Inline code spans blanked, so a link quoted in code is not one.
        let mut plain = String::with_capacity(line.len());
        let mut in_code = false;
        for c in line.chars() {
            if c == '`' {
                in_code = !in_code;
                plain.push(' ');
            } else {
                plain.push(if in_code { ' ' } else { c });
            }
        }
        let b = plain.as_bytes();
        let mut at = 0;
        while let Some(k) = plain[at..].find("](") {
            let open = at + k + 2;
            let Some(close) = plain[open..].find(')') else {
                break;
            };
            let target = plain[open..open + close].trim();
            // An image when the `[` that this `]` closes follows a `!`.
            let image = plain[..at + k]
                .rfind('[')
                .is_some_and(|s| s > 0 && b[s - 1] == b'!');
            // `[text](target "title")`: the title is not part of the target.
            let target = target.split_whitespace().next().unwrap_or_default();
            if !target.is_empty() {
                out.push(Link {
                    target: target.to_string(),
                    image,
                    line: i + 1,
                });
            }
            at = open + close;
        }
        let mut at = 0;
        while let Some(k) = plain[at..].find("<img ") {
            let tag = &plain[at + k..];
            let end = tag.find('>').unwrap_or(tag.len());
            if let Some(s) = tag[..end].find("src=\"") {
                let v = &tag[s + 5..end];
                if let Some(q) = v.find('"') {
                    out.push(Link {
                        target: v[..q].to_string(),
                        image: true,
                        line: i + 1,
                    });
                }
            }
            at += k + end.max(1);
        }
    }
    out
}

/// `base/rel` with `.` and `..` resolved lexically; `None` above the root.
fn resolve(base: &Path, rel: &str) -> Option<PathBuf> {
    let mut parts: Vec<Component> = base.components().collect();
    for c in Path::new(rel).components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => {
                parts.pop()?;
            }
            other => parts.push(other),
        }
    }
    Some(parts.iter().collect())
}

/// Checks the links of `pages` (`(path, text)`) against the files under `root` and the
/// images against `figures`: one message per broken link.
pub fn check(root: &Path, pages: &[(String, String)], figures: &[&str]) -> Vec<String> {
    let mut bad = Vec::new();
    for (page, text) in pages {
        let dir = Path::new(page).parent().unwrap_or(Path::new(""));
        for l in links(text) {
            let t = l.target.as_str();
            if t.starts_with('#') || t.contains("://") || t.starts_with("mailto:") {
                continue;
            }
            let file = t.split('#').next().unwrap_or_default();
            let Some(rel) = resolve(dir, file) else {
                bad.push(format!(
                    "{page}:{}: `{t}` leads out of the repository",
                    l.line
                ));
                continue;
            };
            if !root.join(&rel).exists() {
                bad.push(format!(
                    "{page}:{}: `{t}` does not exist ({})",
                    l.line,
                    rel.display()
                ));
                continue;
            }
            if page.starts_with("docs/") && !rel.starts_with("docs") {
                bad.push(format!(
                    "{page}:{}: `{t}` leaves the book (mdBook renders docs/ alone): name \
                     the file in code instead",
                    l.line
                ));
                continue;
            }
            if l.image && !figures.iter().any(|f| Path::new(f) == rel) {
                bad.push(format!(
                    "{page}:{}: image `{t}` is not drawn by a listed command (add it to \
                     FIGURES in xtask/src/readme/figures.rs)",
                    l.line
                ));
            }
        }
    }
    bad
}
