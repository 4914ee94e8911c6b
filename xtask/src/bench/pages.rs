//! The pages' `fw-bench` figures (the performance chapter's table between
//! `<!-- fw-bench -->` markers, the README's tick row), written from the bench's output:
//! `cargo xtask fw-bench` rewrites them, `--check` fails naming each that differs.

use crate::size::grouped;

/// The block's markers, each a line of its own.
pub const OPEN: &str = "<!-- fw-bench -->";
pub const CLOSE: &str = "<!-- /fw-bench -->";
/// The README's row of the tick's cost: the line starting with it is rewritten whole.
pub const README_ROW: &str =
    "| cost of one tick on a Cortex-M4 (exact instruction counts under QEMU) |";

/// One measurement line of the bench: `LABEL [BUILD]: min A mean B max C instructions
/// (...)` or `LABEL [BUILD]: N bytes (...)`, as `(label, cell)`.
pub fn parse_line(line: &str) -> Option<(String, String)> {
    let (head, value) = line.split_once("]: ")?;
    let (label, _build) = head.rsplit_once(" [")?;
    let w: Vec<&str> = value.split_whitespace().collect();
    let cell = match w.as_slice() {
        ["min", a, "mean", b, "max", c, "instructions", ..] => {
            let n = |s: &str| s.parse::<u64>().ok().map(grouped);
            format!("{} ({}-{})", n(b)?, n(a)?, n(c)?)
        }
        [n, "bytes", ..] => format!("{} B", grouped(n.parse().ok()?)),
        _ => return None,
    };
    Some((label.trim().to_string(), cell))
}

/// The Markdown table of every measurement (rows) of every build (columns, `heads`),
/// from each build's human-readable output.
pub fn table(heads: &[String], outputs: &[String]) -> String {
    let mut rows: Vec<(String, Vec<String>)> = Vec::new();
    for (col, out) in outputs.iter().enumerate() {
        for (label, cell) in out.lines().filter_map(parse_line) {
            let i = match rows.iter().position(|(l, _)| *l == label) {
                Some(i) => i,
                None => {
                    rows.push((label, vec!["-".to_string(); outputs.len()]));
                    rows.len() - 1
                }
            };
            if let Some(c) = rows[i].1.get_mut(col) {
                *c = cell;
            }
        }
    }
    let mut t = format!(
        "| `cargo xtask fw-bench`: instructions, mean (min-max) | {} |\n|---|{}\n",
        heads.join(" | "),
        "---|".repeat(heads.len())
    );
    for (label, cells) in rows {
        t.push_str(&format!("| {label} | {} |\n", cells.join(" | ")));
    }
    t
}

/// The README's row: the law's and the whole tick's means of the flashed build.
pub fn readme_row(law_mean: u64, tick_mean: u64, budget: u64) -> String {
    format!(
        "{README_ROW} control law {} instructions, whole tick (decode, control, monitor with \
         the drive check, encode) {} on the mean (budget {}) | `cargo xtask fw-bench` |",
        grouped(law_mean),
        grouped(tick_mean),
        grouped(budget)
    )
}

/// `pages` with the block and the row replaced (`Err` when not exactly one page has the
/// block, or none the row); the new texts and the names of what changed.
pub fn update(
    pages: &[(String, String)],
    block: &str,
    row: &str,
) -> Result<(Vec<String>, Vec<String>), String> {
    let mut out = Vec::new();
    let mut changed = Vec::new();
    let (mut blocks, mut rows) = (0, 0);
    for (path, text) in pages {
        let mut new = String::new();
        let mut inside = false;
        for line in text.split_inclusive('\n') {
            let t = line.trim_end();
            if inside {
                if t == CLOSE {
                    inside = false;
                    new.push_str(line);
                }
                continue;
            }
            if t == OPEN {
                blocks += 1;
                inside = true;
                new.push_str(line);
                new.push_str(block);
            } else if t == CLOSE {
                return Err(format!("{path}: `{CLOSE}` without `{OPEN}`"));
            } else if t.starts_with(README_ROW) {
                rows += 1;
                new.push_str(row);
                new.push_str(&line[t.len()..]);
            } else {
                new.push_str(line);
            }
        }
        if inside {
            return Err(format!("{path}: `{OPEN}` without `{CLOSE}`"));
        }
        if new != *text {
            changed.push(path.clone());
        }
        out.push(new);
    }
    if blocks != 1 {
        return Err(format!(
            "the pages hold {blocks} `{OPEN}` blocks; exactly one page must hold one"
        ));
    }
    if rows == 0 {
        return Err(format!("no page has the row `{README_ROW}`"));
    }
    Ok((out, changed))
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn the_bench_lines_become_a_table() {
        let m4 = "law step [fixed point]: min 104 mean 105 max 316 instructions (n = 2000)\n\
                  whole tick [fixed point]: min 1152 mean 1194 max 1543 instructions (n = 2000)\n\
                  stack high-water mark [fixed point]: 6584 bytes (painted window 16384 bytes)\n\
                  a line of prose\n";
        let m3 = "law step [f32]: min 1 mean 2 max 3 instructions (n = 1)\n";
        let t = table(&["M4".into(), "M3".into()], &[m4.into(), m3.into()]);
        assert_eq!(
            t,
            "| `cargo xtask fw-bench`: instructions, mean (min-max) | M4 | M3 |\n|---|---|---|\n\
             | law step | 105 (104-316) | 2 (1-3) |\n\
             | whole tick | 1 194 (1 152-1 543) | - |\n\
             | stack high-water mark | 6 584 B | - |\n"
        );
    }

    #[test]
    fn the_block_and_the_row_are_rewritten_and_a_stale_one_is_named() {
        let row = readme_row(105, 1194, 2500);
        let page = |b: &str, r: &str| {
            format!("text\n{OPEN}\n{b}{CLOSE}\nmore\n") + &format!("| what | figure |\n{r}\n")
        };
        let fresh = page("| t |\n", &row);
        let pages = vec![("docs/p.md".to_string(), fresh.clone())];
        let (new, changed) = update(&pages, "| t |\n", &row).unwrap();
        assert_eq!((new[0].as_str(), changed.len()), (fresh.as_str(), 0));
        let stale = page("| old |\n", &readme_row(105, 1100, 2500));
        let pages = vec![("docs/p.md".to_string(), stale)];
        let (new, changed) = update(&pages, "| t |\n", &row).unwrap();
        assert_eq!(new[0], fresh);
        assert_eq!(changed, vec!["docs/p.md".to_string()]);
        assert!(row.contains("whole tick (decode, control, monitor with the drive check, encode) 1 194 on the mean (budget 2 500)"));
        let none = vec![("README.md".to_string(), "no block\n".to_string())];
        assert!(update(&none, "", &row)
            .unwrap_err()
            .contains("0 `<!-- fw-bench -->`"));
        let open = vec![("a.md".to_string(), format!("{OPEN}\n{row}\n"))];
        assert!(update(&open, "", &row).unwrap_err().contains("without"));
    }
}
