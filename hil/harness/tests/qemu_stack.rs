//! The board's stack high-water mark under QEMU: the `wheelset-qemu` firmware
//! paints its stack at the control task's start and reads the mark every
//! `SCAN_TICKS` ticks into `Status.stack_peak` (`firmware/app/src/stack.rs`). Skips
//! when QEMU or the ELF is missing, unless `REQUIRE_QEMU=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::{exchange, sensor, status};
use wheelset_targets::qemu::QemuConfig;

/// `firmware/app/src/stack.rs`: the mark is read every this many ticks.
const SCAN_TICKS: u16 = 1024;
/// `firmware/app/src/stack.rs`: bytes painted below the stack pointer.
const WINDOW: u32 = 16 * 1024;

#[test]
fn the_qemu_board_reports_its_stack_high_water_mark() {
    let Some(mut q) = common::start_cfg_or_skip("stack peak", &QemuConfig::new()) else {
        return;
    };
    for k in 1..=5 {
        exchange(&mut q, &sensor(k), 1);
    }
    // Before the first scan the Status has no mark yet.
    assert_eq!(status(&mut q).stack_peak, 0);
    for k in 7..SCAN_TICKS + 16 {
        exchange(&mut q, &sensor(k), 1);
    }
    let peak = status(&mut q).stack_peak;
    // Measured (the ticks ran on the painted stack) and inside the painted window (a
    // mark at the window's size would mean the stack went deeper than the paint).
    assert!(peak > 0, "stack peak {peak} B");
    assert!(
        peak < WINDOW,
        "stack peak {peak} B: the stack reached the window's bottom"
    );
    eprintln!("stack peak after {} ticks: {peak} B", SCAN_TICKS + 16);
}
