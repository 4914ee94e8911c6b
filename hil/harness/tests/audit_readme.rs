//! The README's generated audit block is exactly what `hil audit --no-target
//! --readme-block` prints: a change that moves an audit figure fails here until the
//! README follows (regenerate the block with that command).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::Command;

use wheelset_audit::readme_block;

#[test]
fn the_readme_audit_block_is_the_tools_output() {
    let out = Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(["audit", "--no-target", "--readme-block"])
        .output()
        .unwrap();
    let printed = String::from_utf8(out.stdout).unwrap();
    assert!(printed.contains("Verdict: **"), "{printed}");
    let md =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/../../README.md")).unwrap();
    let block = readme_block::extract(&md).expect("README has the generated audit block");
    assert!(
        block == printed,
        "README's audit block differs from `{}`; regenerate it.\n--- tool ---\n{printed}",
        readme_block::COMMAND
    );
}
