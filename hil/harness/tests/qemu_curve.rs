//! The README's main job through the real firmware: the whole 20 s `curve` (lead) closed
//! through the QEMU device (`hil run --target qemu --qemu-link bulk`: the semihosting
//! bulk channel, the same frames as UART0 and ~8x faster, `hil/harness/tests/qemu_bulk.rs`) gives
//! the in-process run's trajectory record for record, passes every check and keeps the
//! firmware tick's maximum within its budget (`wheelset_targets::qemu::TICK_MAX_BUDGET_INSTRUCTIONS`),
//! and holds the performance chapter's rows of that tick and the stack to the run. Skips when
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
    let e = &r.timing.exec_units;
    let status = r.device_status.as_ref().expect("the firmware's Status");
    check_the_performance_rows((e.min, e.mean, e.max), status.stack_peak);
}

/// `25464` as the pages write it: `25 464`.
fn grouped(n: u64) -> String {
    let d = n.to_string();
    let mut out = String::new();
    for (i, c) in d.chars().enumerate() {
        if i > 0 && (d.len() - i).is_multiple_of(3) {
            out.push(' ');
        }
        out.push(c);
    }
    out
}

/// The performance chapter's rows of the firmware's tick and stack over the curve must
/// state this run's figures: a change of the tick's cost fails here until the page says it.
fn check_the_performance_rows(exec: (f64, f64, f64), stack_peak: u32) {
    let page = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/performance.md");
    let text = std::fs::read_to_string(&page).expect("docs/performance.md");
    let row = |prefix: &str| {
        text.lines()
            .find(|l| l.starts_with(prefix))
            .unwrap_or_else(|| panic!("{}: no row `{prefix}`", page.display()))
    };
    let (min, mean, max) = exec;
    let want = format!(
        "min {}, mean {}, max {} instructions",
        grouped(min as u64),
        grouped(mean.round() as u64),
        grouped(max as u64)
    );
    let tick = row("| tick in the firmware");
    assert!(
        tick.contains(&want),
        "docs/performance.md's tick row must say `{want}`: {tick}"
    );
    let want = format!("| {} B on the Cortex-M4", grouped(u64::from(stack_peak)));
    let stack = row("| stack high-water mark of the firmware");
    assert!(
        stack.contains(&want),
        "docs/performance.md's stack row must say `{want}`: {stack}"
    );
}
