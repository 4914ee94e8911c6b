//! The generated blocks' machinery and the README command classifier.

use super::blocks::MACHINE_DEPENDENT;
use super::commands::{classify, commands, Class};
use super::markers::{diff, find_blocks};
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
    assert_eq!(
        classify("FR=0.5,0.6 cargo run --release -p sim-host --example adh_modes -- low lead 1"),
        Class::Short
    );
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
