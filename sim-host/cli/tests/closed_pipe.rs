//! `sim-host ... | head`: when the reader closes the pipe, the command ends quietly with
//! exit code 0, as Unix tools do (it used to panic with exit code 101). The standard
//! output here is a pipe whose reading end is closed before the command starts, so its
//! first write fails with `EPIPE` whatever the timing.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::{Command, Stdio};

#[test]
fn a_closed_stdout_ends_the_command_quietly_with_success() {
    for args in [
        &["rates"][..],
        &["run", "--scenario", "beating", "--control", "passive"],
    ] {
        let (reader, writer) = std::io::pipe().expect("pipe");
        drop(reader);
        let out = Command::new(env!("CARGO_BIN_EXE_sim-host"))
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
