//! The firmware's size budget: flash and static RAM of each built ELF against the budget,
//! its placement against its own board's memory map ([`check_sizes`]), and the pages'
//! size rows against the build ([`readme_sizes`]).

use std::path::{Path, PathBuf};

use wheelset_targets::elf;

#[cfg(test)]
use crate::Firmware;

/// One region of a memory map, bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Region {
    pub origin: u64,
    pub length: u64,
}

impl Region {
    fn end(self) -> u64 {
        self.origin + self.length
    }

    fn holds(self, addr: u64, size: u64) -> bool {
        addr >= self.origin && addr + size <= self.end()
    }
}

/// A board's memory map: what cortex-m-rt's `link.x` needs of it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Map {
    pub flash: Region,
    pub ram: Region,
}

/// The memory map of `board`, as `firmware/app/build.rs` finds it: its board folder's
/// `memory.x`, else the top-level one (the Nucleo-F446RE's).
pub fn map_path(board: &str) -> PathBuf {
    let root = crate::workspace_root();
    let own = root
        .join("firmware/app/src/board")
        .join(board)
        .join("memory.x");
    if own.exists() {
        own
    } else {
        root.join("memory.x")
    }
}

/// `0x2000_0000`, `512K`, `4M`, `65536`.
fn number(s: &str) -> Option<u64> {
    let s = s.trim().replace('_', "");
    let (digits, scale) = [("K", 1024), ("M", 1024 * 1024)]
        .into_iter()
        .find_map(|(suffix, scale)| Some((s.strip_suffix(suffix)?, scale)))
        .unwrap_or((s.as_str(), 1));
    let v = match digits.strip_prefix("0x") {
        Some(h) => u64::from_str_radix(h, 16).ok()?,
        None => digits.parse().ok()?,
    };
    Some(v * scale)
}

/// The FLASH and RAM regions of a `memory.x` (lines `NAME : ORIGIN = a, LENGTH = l`).
pub fn parse_map(text: &str) -> Result<Map, String> {
    let field = |s: &str, key: &str| number(s.trim().strip_prefix(key)?.trim().strip_prefix('=')?);
    let region = |name: &str| {
        text.lines()
            .filter_map(|l| {
                let (n, rest) = l.split_once(':')?;
                if n.trim() != name {
                    return None;
                }
                let (origin, length) = rest.split_once(',')?;
                Some(Region {
                    origin: field(origin, "ORIGIN")?,
                    length: field(length, "LENGTH")?,
                })
            })
            .next()
            .ok_or_else(|| format!("no `{name} : ORIGIN = .., LENGTH = ..` line"))
    };
    Ok(Map {
        flash: region("FLASH")?,
        ram: region("RAM")?,
    })
}

/// How far below the RAM region's end the top of the used RAM may be: flip-link rounds
/// the flipped statics' start down to their alignment, so they may end a few bytes short.
const RAM_TOP_SLACK: u64 = 64;

/// The symbol a board's memory map defines (`__board_map_<board> = 1;`), which names the
/// map an image was linked with.
pub const MAP_MARK: &str = "__board_map_";

/// Whether `layout` was linked with `board`'s memory map `map`: only that map's
/// [`MAP_MARK`], every allocated section in its FLASH or RAM, and RAM used up to the
/// region's end (within [`RAM_TOP_SLACK`]: the stack's start or flip-link's statics).
pub fn check_layout(board: &str, map: &Map, layout: &elf::Layout) -> Result<(), String> {
    let mut wrong = Vec::new();
    let mark = format!("{MAP_MARK}{board}");
    let marks: Vec<&str> = layout
        .symbols
        .iter()
        .map(|(n, _)| n.as_str())
        .filter(|n| n.starts_with(MAP_MARK))
        .collect();
    if marks != [mark.as_str()] {
        wrong.push(format!("linked with the map(s) {marks:?}, not {mark}"));
    }
    let mut ram_top = 0;
    for s in layout.sections.iter().filter(|s| s.size > 0) {
        let (region, kind) = if s.write {
            ram_top = ram_top.max(s.addr + s.size);
            (map.ram, "RAM")
        } else {
            (map.flash, "FLASH")
        };
        if !region.holds(s.addr, s.size) {
            wrong.push(format!(
                "{} at {:#x}..{:#x} is outside {kind} {:#x}..{:#x}",
                s.name,
                s.addr,
                s.addr + s.size,
                region.origin,
                region.end()
            ));
        }
    }
    match layout.symbol("_stack_start") {
        Some(sp) if map.ram.holds(sp, 0) => ram_top = ram_top.max(sp),
        Some(sp) => wrong.push(format!("_stack_start {sp:#x} is outside RAM")),
        None => wrong.push("no _stack_start".into()),
    }
    if ram_top + RAM_TOP_SLACK <= map.ram.end() {
        wrong.push(format!(
            "RAM is used up to {ram_top:#x}, not to the map's end {:#x}",
            map.ram.end()
        ));
    }
    if wrong.is_empty() {
        Ok(())
    } else {
        Err(wrong.join("; "))
    }
}

/// [`check_layout`] of the ELF `bytes` against `board`'s own map.
fn check_board_map(board: &str, bytes: &[u8]) -> Result<(), String> {
    let path = map_path(board);
    let text = std::fs::read_to_string(&path)
        .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let map = parse_map(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    check_layout(board, &map, &elf::layout(bytes)?)
        .map_err(|e| format!("not linked with {}: {e}", path.display()))
}

/// Flash budget of each firmware binary, bytes (.vector_table + .text + .rodata + .data):
/// generous on purpose, it only catches a build that grows by accident.
pub const FLASH_BUDGET: u64 = 64 * 1024;
/// Static RAM budget of each firmware binary (.data + .bss + .uninit), bytes.
pub const RAM_BUDGET: u64 = 16 * 1024;

pub fn check_sizes(elfs: &[(PathBuf, &str)]) -> Result<Vec<(String, elf::Sizes)>, String> {
    let mut over = Vec::new();
    let mut all = Vec::new();
    outln!(
        "firmware size (budget: flash {FLASH_BUDGET} B, static RAM {RAM_BUDGET} B excluding \
         the stack; the build fails above either, or if an image is not placed by its own \
         board's memory map)"
    );
    for (path, board) in elfs {
        let bytes =
            std::fs::read(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
        let size = elf::sizes(&bytes).map_err(|e| format!("{}: {e}", path.display()))?;
        let name = path.file_name().map_or_else(
            || path.display().to_string(),
            |n| n.to_string_lossy().into_owned(),
        );
        if let Err(e) = check_board_map(board, &bytes) {
            over.push(format!("{name}: {e}"));
        }
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
        Err(format!(
            "over the size budget or misplaced: {}",
            over.join("; ")
        ))
    }
}

/// The pages' table row stating the flash / static RAM of the enforced build `elf`.
fn size_row(elf: &str) -> Option<String> {
    let boards = [
        ("wheelset-nucleo-g474", "Nucleo-G474"),
        ("wheelset-nucleo", "Nucleo"),
        ("wheelset-qemu", "QEMU"),
    ];
    let (_, board) = boards
        .iter()
        .find(|(prefix, _)| elf.starts_with(prefix) && !elf.contains("-f32"))?;
    Some(format!("| flash / static RAM, {board} |"))
}

/// `25464` as the pages write it: `25 464`.
pub(crate) fn grouped(n: u64) -> String {
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
        let Some(row) = size_row(name) else {
            continue;
        };
        let want = format!("{} B / {} B", grouped(size.flash), grouped(size.ram));
        // Every row of that name, in whichever page, states the build's figure.
        let rows: Vec<(&str, &str)> = pages
            .iter()
            .flat_map(|(page, text)| {
                text.lines()
                    .filter(|l| l.starts_with(&row))
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
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    fn section(name: &str, addr: u64, size: u64, write: bool) -> elf::Section {
        elf::Section {
            name: name.into(),
            addr,
            size,
            write,
        }
    }

    /// An image as cortex-m-rt (`flip: false`) or flip-link lays it out on `map`, with
    /// the mark of `board`'s map.
    fn image(map: &Map, board: &str, flip: bool) -> elf::Layout {
        let (flash, ram) = (map.flash.origin, map.ram.origin);
        let statics = if flip { map.ram.end() - 0x100 } else { ram };
        let stack = if flip { statics } else { map.ram.end() };
        elf::Layout {
            sections: vec![
                section(".vector_table", flash, 0x400, false),
                section(".text", flash + 0x400, 0x4000, false),
                section(".data", statics, 0x10, true),
                section(".bss", statics + 0x10, 0xF0, true),
            ],
            symbols: vec![
                ("_stack_start".into(), stack),
                (format!("{MAP_MARK}{board}"), 1),
            ],
        }
    }

    fn map(board: &str) -> Map {
        parse_map(&std::fs::read_to_string(map_path(board)).unwrap()).unwrap()
    }

    #[test]
    fn every_boards_map_is_read() {
        let kib = 1024;
        let f446 = map("nucleo");
        assert_eq!(
            f446.flash,
            Region {
                origin: 0x0800_0000,
                length: 512 * kib
            }
        );
        assert_eq!(
            f446.ram,
            Region {
                origin: 0x2000_0000,
                length: 128 * kib
            }
        );
        let qemu = map("qemu");
        assert_eq!(
            qemu.flash,
            Region {
                origin: 0,
                length: 4096 * kib
            }
        );
        assert!(map_path("qemu").ends_with("firmware/app/src/board/qemu/memory.x"));
        assert!(parse_map("MEMORY { }").is_err());
    }

    #[test]
    fn an_image_is_held_to_its_own_boards_map() {
        for (board, flip) in [("nucleo", true), ("qemu", false), ("nucleo", false)] {
            let m = map(board);
            assert_eq!(check_layout(board, &m, &image(&m, board, flip)), Ok(()));
        }
        let m = map("nucleo");
        // Linked with another board's map (its mark), though every address would fit.
        let e = check_layout("nucleo", &m, &image(&m, "other", true)).unwrap_err();
        assert!(e.contains("__board_map_other"), "{e}");
        // A smaller RAM than the image was laid out for: the statics beyond its end.
        let small = Map {
            ram: Region {
                length: 96 * 1024,
                ..m.ram
            },
            ..m
        };
        let e = check_layout("nucleo", &small, &image(&m, "nucleo", true)).unwrap_err();
        assert!(
            e.contains(".data at 0x2001ff00") && e.contains("outside RAM"),
            "{e}"
        );
        // RAM not used up to its end: the image was laid out for a smaller region.
        let e = check_layout("nucleo", &m, &image(&small, "nucleo", false)).unwrap_err();
        assert!(e.contains("not to the map's end 0x20020000"), "{e}");
        // Code outside the flash region.
        let e = check_layout("qemu", &map("qemu"), &image(&m, "qemu", false)).unwrap_err();
        assert!(e.contains(".text at 0x8000400"), "{e}");
    }

    /// The built images (`cargo fw`; `cargo xtest` builds them before the tests): each
    /// passes against its own board's map and fails against every other board's.
    #[test]
    fn a_built_image_fails_against_another_boards_map() {
        let dir = crate::target_dir().join("fw");
        let built: Vec<(&Firmware, Vec<u8>)> = crate::FIRMWARE
            .iter()
            .filter_map(|fw| Some((fw, std::fs::read(dir.join(fw.elf)).ok()?)))
            .collect();
        if built.is_empty() {
            eprintln!(
                "no firmware in {} (`cargo fw`): nothing to check",
                dir.display()
            );
            return;
        }
        let boards: std::collections::BTreeSet<&str> =
            crate::FIRMWARE.iter().map(|fw| fw.board).collect();
        for (fw, bytes) in &built {
            for board in &boards {
                let r = check_board_map(board, bytes);
                assert_eq!(
                    r.is_ok(),
                    *board == fw.board,
                    "{} as {board}: {r:?}",
                    fw.elf
                );
            }
        }
    }

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
