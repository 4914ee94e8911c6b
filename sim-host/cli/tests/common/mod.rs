//! What the CLI tests share: run `sim-host` with arguments and read the JSON it wrote.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

use std::path::Path;

/// Runs `sim-host args... --json JSON`, asserting it succeeds (its stderr in the
/// failure), then reads the document it wrote.
pub fn run_json(args: &[&str], json: &Path) -> serde_json::Value {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(args)
        .arg("--json")
        .arg(json)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_str(&std::fs::read_to_string(json).unwrap()).unwrap()
}
