//! `cargo xtask ... | head`: when the reader closes the pipe, the task ends quietly with
//! exit code 0, as Unix tools do. The standard output here is a pipe whose reading end
//! is closed before the task starts, so its first write fails with `EPIPE`.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::{Command, Stdio};

#[test]
fn a_closed_stdout_ends_the_task_quietly_with_success() {
    let (reader, writer) = std::io::pipe().expect("pipe");
    drop(reader);
    // `qemu-cmd` only prints (the QEMU command line of an ELF; nothing is built or run).
    let out = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(["qemu-cmd", "some.elf"])
        .stdout(writer)
        .stderr(Stdio::piped())
        .output()
        .expect("runs");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{:?}, stderr: {stderr}", out.status);
    assert!(stderr.is_empty(), "said {stderr:?}");
    // The same task into a pipe that is read prints the line: the test above is not
    // passing because nothing was written.
    let out = Command::new(env!("CARGO_BIN_EXE_xtask"))
        .args(["qemu-cmd", "some.elf"])
        .output()
        .expect("runs");
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("some.elf"));
}
