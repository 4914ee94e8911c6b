//! The QEMU firmware at designed points other than its own (`hil run --target qemu
//! --rate-hz R [--delay-ticks D]`): the harness configures the rate over the wire (the
//! Config frame's Rates, which the device checks against its table of designs, bit for
//! bit), the 20 s `curve` passes every check against the f64 core at the same rate and
//! delay, and the trajectory is the in-process device's record for record. Skips when QEMU
//! or the firmware ELF is missing, unless `REQUIRE_QEMU=1` (`cargo xtest`).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use hil::run::{run, RunOptions, Target};
use wheelset_report::Verdict;
use wheelset_targets::qemu::{Channel, QemuConfig};

#[test]
fn the_qemu_firmware_runs_two_other_designed_points_as_the_in_process_device() {
    if !common::can_run("qemu_rates", &QemuConfig::new()) {
        return;
    }
    for (hz, d) in [(1_000, 1), (2_000, 2)] {
        let at = RunOptions {
            rate_hz: Some(hz),
            delay_ticks: d,
            ..RunOptions::default()
        };
        let qemu = run(&RunOptions {
            target: Target::Qemu,
            qemu_link: Channel::Bulk,
            ..at.clone()
        })
        .expect("the QEMU run is made");
        let r = &qemu.report;
        assert_eq!(
            r.verdict,
            Verdict::Pass,
            "{hz} Hz, {d} ticks: {}",
            serde_json::to_string_pretty(r).unwrap()
        );
        assert!(r.frames.adds_up, "{:?}", r.frames);
        assert_eq!(r.timing.missed_ticks, 0);
        let inproc = run(&at).expect("the in-process run is made");
        assert_eq!(
            qemu.trajectory.records.len(),
            inproc.trajectory.records.len()
        );
        let first_difference = qemu
            .trajectory
            .records
            .iter()
            .zip(&inproc.trajectory.records)
            .position(|(a, b)| a != b);
        assert_eq!(first_difference, None, "{hz} Hz, {d} ticks");
    }
}
