//! The README's main job through the real firmware: the whole 20 s `curve` (lead) closed
//! through the QEMU device (`hil run --target qemu --qemu-link bulk`: the semihosting
//! bulk channel, the same frames as UART0 and ~8x faster, `hil/harness/tests/qemu_bulk.rs`) gives
//! the in-process run's trajectory record for record, passes every check and keeps the
//! firmware tick's maximum within its budget (`wheelset_targets::qemu::TICK_MAX_BUDGET_INSTRUCTIONS`). Skips when
//! QEMU or the firmware ELF is missing, unless `REQUIRE_QEMU=1` (`cargo xtest`).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use hil::run::{run, RunOptions, Target};
use wheelset_report::Verdict;
use wheelset_targets::qemu::{Channel, QemuConfig, TICK_MAX_BUDGET_INSTRUCTIONS};

#[test]
fn the_20_s_curve_through_the_qemu_firmware_is_the_in_process_run() {
    if !common::can_run("qemu_curve", &QemuConfig::new()) {
        return;
    }
    let qemu = run(&RunOptions {
        target: Target::Qemu,
        qemu_link: Channel::Bulk,
        ..RunOptions::default()
    })
    .expect("the QEMU run is made");
    let inproc = run(&RunOptions::default()).expect("the in-process run is made");
    let r = &qemu.report;
    assert_eq!((r.target.as_str(), r.scenario.as_str()), ("qemu", "curve"));
    assert_eq!(
        r.verdict,
        Verdict::Pass,
        "{}",
        serde_json::to_string_pretty(r).unwrap()
    );
    // 20 s at 5 kHz: every exchange made, nothing lost, no tick missed.
    assert_eq!(
        qemu.trajectory.records.len(),
        inproc.trajectory.records.len()
    );
    assert!(qemu.trajectory.records.len() > 19_000);
    // The tick's budget: its maximum over the curve in the instructions QEMU counts.
    assert_eq!(r.timing.exec_unit, "instructions");
    assert!(
        r.timing.exec_units.max <= TICK_MAX_BUDGET_INSTRUCTIONS as f64,
        "firmware tick max {} instructions over the curve, budget {TICK_MAX_BUDGET_INSTRUCTIONS}",
        r.timing.exec_units.max
    );
    assert!(r.frames.adds_up, "{:?}", r.frames);
    assert_eq!(r.frames.up.dropped + r.frames.down.dropped, 0);
    assert_eq!(r.timing.missed_ticks, 0);
    // The same fixed-point runtime in process, same inputs: bit for bit.
    let first_difference = qemu
        .trajectory
        .records
        .iter()
        .zip(&inproc.trajectory.records)
        .position(|(a, b)| a != b);
    assert_eq!(
        first_difference, None,
        "the trajectories part at that record"
    );
    assert_eq!(qemu.report.numerics, inproc.report.numerics);
    assert_eq!(qemu.report.monitor.alarms, inproc.report.monitor.alarms);
}
