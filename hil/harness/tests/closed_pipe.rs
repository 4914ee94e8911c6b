//! `hil ... | head`: when the reader closes the pipe, the harness ends quietly with exit
//! code 0, as Unix tools do. The standard output here is a pipe whose reading end is
//! closed before the command starts, so its first write fails with `EPIPE`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::{Command, Stdio};

#[test]
fn a_closed_stdout_ends_the_harness_quietly_with_success() {
    let short = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short.toml");
    // The second exits 1 on a complete run (a check fails): the closed pipe ends it
    // first, with 0.
    for args in [
        &["run", "--scenario", short, "--quiet"][..],
        &[
            "run",
            "--scenario",
            short,
            "--quiet",
            "--device-fault",
            "wrong-sign",
        ],
        &["audit", "--no-target", "--readme-block"],
    ] {
        let (reader, writer) = std::io::pipe().expect("pipe");
        drop(reader);
        let out = Command::new(env!("CARGO_BIN_EXE_hil"))
            .args(args)
            .stdout(writer)
            .stderr(Stdio::piped())
            .output()
            .expect("runs");
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(
            out.status.success(),
            "{args:?}: {:?}, stderr: {stderr}",
            out.status
        );
        assert!(stderr.is_empty(), "{args:?}: said {stderr:?}");
    }
}
