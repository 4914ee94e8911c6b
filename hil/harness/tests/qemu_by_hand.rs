//! The README's by-hand QEMU run: QEMU started from the project's command line
//! (`cargo xtask qemu-cmd ELF --tcp PORT`, here [`qemu_args`]) waits for a client on
//! its TCP port, and `hil run --target qemu:PORT` is that client: the same closed loop,
//! bit for bit, as the in-process run; the defmt log goes where the shell sends QEMU's
//! stdout. Skips when QEMU or the firmware ELF is missing, unless `REQUIRE_QEMU=1`.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::process::Stdio;

use hil::run::{run, RunOptions, Target};
use wheelset_report::Verdict;
use wheelset_targets::qemu::cmd::{qemu_args, SerialTo};
use wheelset_targets::qemu::{Machine, QemuConfig, QEMU_BIN};

#[test]
fn hil_run_target_qemu_port_is_the_client_of_a_qemu_started_by_hand() {
    let cfg = QemuConfig::new();
    if let Err(e) = cfg.check() {
        if std::env::var("REQUIRE_QEMU").as_deref() == Ok("1") {
            panic!("REQUIRE_QEMU=1 but the emulated device cannot run: {e}");
        }
        eprintln!("SKIPPED: {e}");
        return;
    }
    let port = std::net::TcpListener::bind(("127.0.0.1", 0))
        .and_then(|l| l.local_addr())
        .map(|a| a.port())
        .expect("a free port");
    let log = std::env::temp_dir().join(format!("qemu-by-hand-{}.bin", std::process::id()));
    let (m, elf) = (Machine::default(), cfg.elf.to_string_lossy());
    let mut qemu = std::process::Command::new(QEMU_BIN)
        .args(qemu_args(m.name(), m.cpu(), &elf, SerialTo::Tcp(port)))
        .stdin(Stdio::null())
        .stdout(std::fs::File::create(&log).expect("log file"))
        .stderr(Stdio::null())
        .spawn()
        .expect("QEMU starts");
    let short = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short.toml").to_string();
    let by_hand = run(&RunOptions {
        target: Target::QemuAt(port),
        scenario: short.clone(),
        ..RunOptions::default()
    });
    let _ = qemu.kill();
    let _ = qemu.wait();
    let by_hand = by_hand.expect("the run against the QEMU started by hand");
    let r = &by_hand.report;
    assert_eq!(r.target, "qemu"); // the transport: the firmware under QEMU
    assert_eq!(r.verdict, Verdict::Pass);
    assert_eq!(r.frames.source, "device-status");
    assert_eq!(r.frames.up.received, r.frames.up.sent);
    let inproc = run(&RunOptions {
        scenario: short,
        ..RunOptions::default()
    })
    .expect("in process");
    assert_eq!(by_hand.trajectory.records, inproc.trajectory.records);
    // The firmware's defmt log reached the file the shell redirected stdout to.
    let bytes = std::fs::metadata(&log).map(|m| m.len()).unwrap_or(0);
    let _ = std::fs::remove_file(&log);
    assert!(bytes > 0, "no defmt log in {}", log.display());
}

#[test]
fn qemu_port_targets_parse_and_bad_ports_are_named() {
    assert_eq!("qemu:4444".parse::<Target>(), Ok(Target::QemuAt(4444)));
    assert_eq!(Target::QemuAt(4444).to_string(), "qemu:4444");
    for bad in ["qemu:", "qemu:0", "qemu:70000", "qemu:x"] {
        let e = bad.parse::<Target>().expect_err(bad);
        assert!(e.contains("not a TCP port"), "{bad}: {e}");
    }
}
