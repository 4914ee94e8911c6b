//! The firmware's size budget: flash and static RAM of each built ELF against the
//! enforced budget and the target ([`check_sizes`], printed by `cargo fw` and `cargo
//! xtest`), and the size rows of the README and the book against the build
//! ([`readme_sizes`]).

use std::path::{Path, PathBuf};

use wheelset_targets::elf;

/// Flash budget of each firmware binary, bytes (.vector_table + .text + .rodata + .data).
/// Generous on purpose: the STM32F446RE has 512 KiB, and 64 KiB fits the smallest parts
/// of its family. A protection or a well-kept driver is never traded for bytes; the
/// budget only catches a build that grows by accident (a formatting machinery, a table
/// linked twice).
pub const FLASH_BUDGET: u64 = 64 * 1024;
/// Static RAM budget of each firmware binary (.data + .bss + .uninit; the stack is not a
/// section: cortex-m-rt puts it at the top of RAM), bytes. The F446RE has 128 KiB.
pub const RAM_BUDGET: u64 = 16 * 1024;

pub fn check_sizes(elfs: &[PathBuf]) -> Result<Vec<(String, elf::Sizes)>, String> {
    let mut over = Vec::new();
    let mut all = Vec::new();
    outln!(
        "firmware size (budget: flash {FLASH_BUDGET} B, static RAM {RAM_BUDGET} B excluding \
         the stack; the build fails above either)"
    );
    for path in elfs {
        let bytes =
            std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        let size = elf::sizes(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        outln!(
            "  {name:<26} flash {:>6} B ({:>5.1} KiB)   static RAM {:>5} B ({:>4.1} KiB)",
            size.flash,
            size.flash as f64 / 1024.0,
            size.ram,
            size.ram as f64 / 1024.0
        );
        let enforced = !name.contains("-f32");
        if size.flash > FLASH_BUDGET {
            outln!(
                "  {name:<26} OVER the flash budget by {} B{}",
                size.flash - FLASH_BUDGET,
                if enforced {
                    ""
                } else {
                    " (f32 measurement build: not enforced)"
                }
            );
            if enforced {
                over.push(format!("{name}: flash {} B > {FLASH_BUDGET} B", size.flash));
            }
        }
        if size.ram > RAM_BUDGET {
            over.push(format!(
                "{name}: static RAM {} B > {RAM_BUDGET} B",
                size.ram
            ));
        }
        all.push((name, size));
    }
    if over.is_empty() {
        Ok(all)
    } else {
        Err(format!("over the size budget: {}", over.join("; ")))
    }
}

/// The table rows (in the README or any chapter of the book: the performance chapter
/// holds them) that state each enforced build's flash / static RAM: the figures must be
/// what the build gives (`cargo fw` prints them), so they cannot drift.
const README_SIZE_ROWS: &[(&str, &str)] = &[
    ("wheelset-nucleo.elf", "| flash / static RAM, Nucleo |"),
    (
        "wheelset-nucleo-frame.elf",
        "| flash / static RAM, Nucleo |",
    ),
    ("wheelset-qemu.elf", "| flash / static RAM, QEMU |"),
    ("wheelset-qemu-m3.elf", "| flash / static RAM, QEMU |"),
    ("wheelset-qemu-free.elf", "| flash / static RAM, QEMU |"),
];

/// `25464` as the pages write it: `25 464`.
fn grouped(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

/// Checks that the pages' size rows hold `flash B / ram B` of every build they name.
pub fn readme_sizes(sizes: &[(String, elf::Sizes)]) -> Result<(), String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    sizes_in_pages(&crate::readme::pages(&root)?, sizes)
}

/// [`readme_sizes`] on `pages` (`(path, text)`).
fn sizes_in_pages(
    pages: &[(String, String)],
    sizes: &[(String, elf::Sizes)],
) -> Result<(), String> {
    let mut wrong = Vec::new();
    for (name, size) in sizes {
        let Some((_, row)) = README_SIZE_ROWS.iter().find(|(n, _)| n == name) else {
            continue;
        };
        let want = format!("{} B / {} B", grouped(size.flash), grouped(size.ram));
        // Every row of that name, in whichever page, states the build's figure.
        let rows: Vec<(&str, &str)> = pages
            .iter()
            .flat_map(|(page, text)| {
                text.lines()
                    .filter(|l| l.starts_with(row))
                    .map(move |l| (page.as_str(), l))
            })
            .collect();
        if rows.is_empty() {
            wrong.push(format!("{name}: no page has the row `{row}` saying {want}"));
        }
        for (page, _) in rows.iter().filter(|(_, l)| !l.contains(&want)) {
            wrong.push(format!("{name}: the row `{row}` of {page} must say {want}"));
        }
    }
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "the pages' firmware sizes drifted from the build (`cargo fw` prints them): {}",
            wrong.join("; ")
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn figures_are_grouped_as_the_readme_writes_them() {
        assert_eq!(grouped(7), "7");
        assert_eq!(grouped(999), "999");
        assert_eq!(grouped(1_000), "1 000");
        assert_eq!(grouped(25_464), "25 464");
        assert_eq!(grouped(1_234_567), "1 234 567");
    }

    #[test]
    fn the_readme_size_rows_are_checked_against_the_build() {
        let nucleo = |flash| {
            vec![(
                "wheelset-nucleo.elf".to_string(),
                elf::Sizes { flash, ram: 1 },
            )]
        };
        // A size no row states is caught, naming the row and the figure it wants.
        let e = readme_sizes(&nucleo(3)).expect_err("no row says 3 B / 1 B");
        assert!(
            e.contains("flash / static RAM, Nucleo") && e.contains("3 B / 1 B"),
            "{e}"
        );
        // A row that moved to a chapter is checked there; a stale copy in a second page is
        // caught too, naming the page.
        let page = |p: &str, t: &str| (p.to_string(), t.to_string());
        let row = "| flash / static RAM, Nucleo | 3 B / 1 B |";
        let sizes = nucleo(3);
        assert!(sizes_in_pages(&[page("docs/perf.md", row)], &sizes).is_ok());
        let stale = [
            page("docs/perf.md", row),
            page("README.md", "| flash / static RAM, Nucleo | 4 B / 1 B |"),
        ];
        let e = sizes_in_pages(&stale, &sizes).expect_err("README's row is stale");
        assert!(e.contains("of README.md must say 3 B / 1 B"), "{e}");
        let e = sizes_in_pages(&[page("README.md", "no rows")], &sizes).expect_err("no row");
        assert!(e.contains("no page has the row"), "{e}");
        // A build without a row is not checked.
        let other = vec![("x.elf".to_string(), elf::Sizes { flash: 3, ram: 1 })];
        assert!(readme_sizes(&other).is_ok());
    }
}
