//! The QEMU target closes the loop (`hil run --target qemu`) and runs the golden vectors
//! (`hil golden --target qemu`). Skips when QEMU or the firmware ELF is missing, unless
//! `REQUIRE_QEMU=1` (set by `cargo xtest` after building the firmware): then it fails.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use hil::golden::{compare, run_host, run_target, vectors};
use hil::run::{run, RunOptions, Target, DEFAULT_CPU_HZ};
use wheelset_report::Verdict;
use wheelset_runtime::RuntimeConfig;
use wheelset_targets::qemu::target::QemuTarget;
use wheelset_targets::qemu::QemuConfig;

fn available(test: &str) -> bool {
    common::can_run(test, &QemuConfig::new())
}

fn short() -> String {
    concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short.toml").to_string()
}

#[test]
fn the_qemu_target_closes_the_loop_bit_identical_to_the_in_process_one() {
    if !available("hil run --target qemu") {
        return;
    }
    let qemu = run(&RunOptions {
        target: Target::Qemu,
        scenario: short(),
        ..RunOptions::default()
    })
    .expect("the QEMU run is made");
    let r = &qemu.report;
    assert_eq!(r.target, "qemu");
    assert_eq!(
        r.verdict,
        Verdict::Pass,
        "{}",
        serde_json::to_string_pretty(r).unwrap()
    );
    // Accounted from the firmware's own Status frame: nothing lost.
    assert_eq!(r.frames.source, "device-status");
    assert!(r.frames.adds_up);
    // Up: the run's Config (its first frame: wsp and monitor_safe), one Sensor frame per
    // period (15 000) and the closing Status request.
    assert_eq!(r.frames.up.received, 15_000 + 2);
    assert_eq!(r.frames.down.received, r.frames.down.sent);
    // Execution time in instructions, measured on the emulated Cortex-M4.
    let t = &r.timing;
    assert_eq!(t.exec_unit, "instructions");
    assert!(
        t.exec_units.min > 100.0 && t.exec_units.max < 100_000.0,
        "{:?}",
        t.exec_units
    );
    assert!((t.exec_ns_per_unit - 1e9 / DEFAULT_CPU_HZ).abs() < 1e-12);
    assert!(t.latency_modelled && t.jitter_max_ns.is_none());
    assert_eq!(t.missed_ticks, 0);
    // The same fixed-point runtime in process, same inputs: the closed loops agree bit for
    // bit (every record, every column).
    let inproc = run(&RunOptions {
        scenario: short(),
        ..RunOptions::default()
    })
    .unwrap();
    assert_eq!(qemu.trajectory.records, inproc.trajectory.records);
    assert_eq!(qemu.report.numerics, inproc.report.numerics);
}

#[test]
fn golden_vectors_agree_bit_for_bit_between_host_and_qemu() {
    if !available("hil golden --target qemu") {
        return;
    }
    for v in vectors().unwrap() {
        let host = run_host(&v, RuntimeConfig::default()).unwrap();
        let mut q = QemuTarget::start_with(
            wheelset_targets::qemu::Machine::default(),
            wheelset_targets::qemu::Channel::Uart,
            wheelset_loop::sim_link::DEFAULT_BAUD,
            DEFAULT_CPU_HZ,
            std::time::Duration::from_secs(10),
        )
        .expect("QEMU starts");
        let target = run_target(&v, &mut q, 200_000).unwrap();
        let c = compare(&v, &host, &target);
        assert!(c.identical, "{}: {c:?}", v.name);
    }
}

#[test]
fn a_missing_elf_is_a_clear_target_error() {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(["run", "--target", "qemu", "--quiet"])
        .env("WHEELSET_QEMU_ELF", "/nonexistent/wheelset-qemu.elf")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.contains("cargo fw") || err.contains("apt-get install qemu-system-arm"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}
