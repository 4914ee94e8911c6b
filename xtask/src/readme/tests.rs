//! The generated blocks' machinery over the pages, the link check and the command
//! classifier.

use super::blocks::MACHINE_DEPENDENT;
use super::commands::{classify, commands, Class};
use super::links::{check, links};
use super::markers::{diff, find_blocks};
use super::*;

/// One page named `p.md` holding `text`.
fn page(text: &str) -> Vec<(String, String)> {
    vec![("p.md".to_string(), text.to_string())]
}

const DOC: &str = "intro\n<!-- generated:a -->\nold a\n<!-- /generated:a -->\nmid\n\
                   <!-- generated:b -->\nsame\n<!-- /generated:b -->\nend\n";

#[test]
fn rewrites_only_between_the_markers_and_names_the_drifted() {
    let fresh = [("a", "new a\n".to_string()), ("b", "same\n".to_string())];
    let (out, drifted) = update(&page(DOC), &fresh).expect("update");
    let out = out[0].clone();
    assert_eq!(
        out,
        "intro\n<!-- generated:a -->\nnew a\n<!-- /generated:a -->\nmid\n\
         <!-- generated:b -->\nsame\n<!-- /generated:b -->\nend\n"
    );
    assert_eq!(drifted.len(), 1);
    assert_eq!(drifted[0].0, "a");
    assert_eq!(drifted[0].1, "- old a\n+ new a\n");
    // Rewritten, nothing drifts any more.
    let (again, none) = update(&page(&out), &fresh).expect("update");
    assert_eq!(again[0], out);
    assert!(none.is_empty());
}

#[test]
fn unknown_missing_unclosed_and_repeated_blocks_are_errors() {
    let only_a = [("a", String::new())];
    let e = update(&page(DOC), &only_a).expect_err("b has no command");
    assert!(e.contains("p.md: block `b` has no command"), "{e}");
    let abc = [
        ("a", String::new()),
        ("b", String::new()),
        ("c", String::new()),
    ];
    let e = update(&page(DOC), &abc).expect_err("c is in no page");
    assert!(e.contains("no page holds block `c`"), "{e}");
    let e = find_blocks("p.md", "<!-- generated:x -->\nbody\n").expect_err("unclosed");
    assert!(e.starts_with("p.md:1:"), "{e}");
    assert!(e.contains("block `x` has no"), "{e}");
    let twice = format!("{DOC}<!-- generated:a -->\n<!-- /generated:a -->\n");
    let e = find_blocks("p.md", &twice).expect_err("twice");
    assert!(e.contains("appears twice"), "{e}");
    // A marker quoted in a line of text is not a marker.
    let quoted =
        "see `<!-- generated:NAME -->` here\n<!-- generated:a -->\nx\n<!-- /generated:a -->\n";
    let f = find_blocks("p.md", quoted).expect("quoted");
    assert_eq!(f.len(), 1);
    assert_eq!(&quoted[f[0].1.clone()], "x\n");
}

#[test]
fn diff_marks_removed_added_and_common_lines() {
    let d = diff("x\ny\nz\n", "x\nY\nz\nw\n");
    assert_eq!(d, "  x\n- y\n+ Y\n  z\n+ w\n");
}

#[test]
fn blocks_are_rewritten_in_the_page_that_holds_them_and_have_one_home() {
    let pages = vec![
        (
            "README.md".to_string(),
            "top\n<!-- generated:a -->\nold\n<!-- /generated:a -->\n".to_string(),
        ),
        (
            "docs/c.md".to_string(),
            "# C\n<!-- generated:b -->\nold\n<!-- /generated:b -->\n".to_string(),
        ),
    ];
    let fresh = [("a", "A\n".to_string()), ("b", "B\n".to_string())];
    let (out, drifted) = update(&pages, &fresh).expect("update");
    assert_eq!(
        out[0],
        "top\n<!-- generated:a -->\nA\n<!-- /generated:a -->\n"
    );
    assert_eq!(
        out[1],
        "# C\n<!-- generated:b -->\nB\n<!-- /generated:b -->\n"
    );
    assert_eq!(drifted.len(), 2);
    // A block in two pages is refused, naming both.
    let mut two = pages.clone();
    two[1]
        .1
        .push_str("<!-- generated:a -->\n<!-- /generated:a -->\n");
    let e = update(&two, &fresh).expect_err("a twice");
    assert!(e.contains("README.md") && e.contains("docs/c.md"), "{e}");
    // A block moved out of every page is missed, naming it.
    let gone = vec![pages[0].clone()];
    let e = update(&gone, &fresh).expect_err("b in no page");
    assert!(e.contains("no page holds block `b`"), "{e}");
}

#[test]
fn every_block_of_the_table_is_in_one_page_once() {
    let pages = pages(&crate::workspace_root()).expect("pages");
    let mut found = Vec::new();
    for (p, text) in &pages {
        for (n, _) in find_blocks(p, text).expect("blocks") {
            found.push(n);
        }
    }
    for b in BLOCKS {
        assert_eq!(
            found.iter().filter(|n| *n == b.name).count(),
            1,
            "block {}",
            b.name
        );
    }
    assert_eq!(found.len(), BLOCKS.len(), "a block without a command");
}

#[test]
fn links_and_images_are_found_outside_code() {
    let doc = "see [model](model.md#params) and ![fig](figures/a.svg \"t\")\n\
               `[not](a link)` <img src=\"figures/b.svg\" alt=\"b\">\n\
               ```text\n[no](nope.md)\n```\n[web](https://example.org)\n";
    let got: Vec<(String, bool, usize)> = links(doc)
        .into_iter()
        .map(|l| (l.target, l.image, l.line))
        .collect();
    assert_eq!(
        got,
        [
            ("model.md#params".to_string(), false, 1),
            ("figures/a.svg".to_string(), true, 1),
            ("figures/b.svg".to_string(), true, 2),
            ("https://example.org".to_string(), false, 6),
        ]
    );
}

#[test]
fn a_broken_link_and_an_unlisted_image_are_found() {
    let root = crate::workspace_root();
    let pages = vec![(
        "docs/x.md".to_string(),
        "[ok](architecture.md#layout) [up](../README.md) [gone](missing.md)\n\
         ![listed](figures/low-adhesion.svg) ![unlisted](figures/actuator-fault-monitor.svg)\n\
         [out](../../../etc/passwd) [web](https://example.org) [here](#top)\n"
            .to_string(),
    )];
    let bad = check(&root, &pages, &["docs/figures/low-adhesion.svg"]);
    assert_eq!(bad.len(), 4, "{bad:?}");
    assert!(
        bad[0].contains("docs/x.md:1: `../README.md` leaves the book"),
        "{bad:?}"
    );
    assert!(
        bad[1].contains("docs/x.md:1: `missing.md` does not exist"),
        "{bad:?}"
    );
    assert!(
        bad[2].contains("docs/x.md:2: image `figures/actuator-fault-monitor.svg` is not drawn"),
        "{bad:?}"
    );
    assert!(bad[3].contains("leads out of the repository"), "{bad:?}");
    // The README may link anywhere in the repository.
    let readme = vec![("README.md".to_string(), "[slurm](hil/slurm/)\n".to_string())];
    assert!(check(&root, &readme, &[]).is_empty());
}

#[test]
fn the_pages_links_resolve_and_every_figure_has_its_block() {
    let root = crate::workspace_root();
    let bad = check_links(&root).expect("pages");
    assert!(bad.is_empty(), "{}", bad.join("\n"));
    for f in FIGURES {
        assert!(
            BLOCKS.iter().any(|b| b.name == f.block),
            "figure {} names no block `{}`",
            f.path,
            f.block
        );
        assert!(
            root.join(f.path).is_file(),
            "figure {} is not committed",
            f.path
        );
    }
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
    assert_eq!(
        classify("FR=0.5,0.6 cargo run --release -p sim-host --example adh_modes -- low lead 1"),
        Class::Short
    );
}

#[test]
fn the_pages_clippy_line_is_the_one_ci_runs() {
    let root = crate::workspace_root();
    let ci = std::fs::read_to_string(root.join(".ci/run")).expect(".ci/run");
    let clippy: Vec<String> = pages(&root)
        .expect("pages")
        .iter()
        .flat_map(|(_, text)| commands(text))
        .filter(|c| c.text.starts_with("cargo clippy"))
        .map(|c| c.text)
        .collect();
    assert!(!clippy.is_empty(), "no page names the clippy command");
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

#[test]
fn a_quoted_figure_not_in_the_blocks_is_named() {
    let text = "y 0.6846 mm, 12.5 %, 3 of 4, v1.2.3, x 0.70.\n<!-- generated:a -->\ny = 0.6846\n\
                <!-- /generated:a -->\nthen 0.70 and 1.25\n";
    let u = super::markers::unquoted("p.md", text).expect("blocks");
    assert_eq!(u, vec!["0.70".to_string(), "1.25".to_string()]);
}

#[test]
fn the_quoting_pages_quote_only_their_blocks() {
    let root = crate::workspace_root();
    for page in super::markers::QUOTING {
        let text = std::fs::read_to_string(root.join(page)).expect(page);
        let u = super::markers::unquoted(page, &text).expect("blocks");
        assert!(u.is_empty(), "{page}: figures in none of its blocks: {u:?}");
    }
}
