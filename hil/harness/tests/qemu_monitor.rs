//! The stability monitor end to end under QEMU: `hil run --target qemu
//! --scenario actuator-fault` over the semihosting bulk channel (the same frames as the
//! UART, bit for bit, `qemu_bulk.rs`; about ten times faster). The alarm comes from the
//! firmware's own `HUNTING` / `ACTUATOR_FAULT` flags and its Status (`first_alarm_tick`,
//! the alarm counters), within the stated deadline of the failure, and equals the
//! in-process device's. The run ends at the plant's divergence (|y| > 50 mm, about
//! 6.4 s: 32 000 exchanges). Skips when QEMU or the ELF is missing, unless
//! `REQUIRE_QEMU=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use hil::run::{run, RunOptions, Target};
use wheelset_report::Verdict;
use wheelset_targets::qemu::{Channel, QemuConfig};

fn available(test: &str) -> bool {
    let cfg = QemuConfig {
        channel: Channel::Bulk,
        ..QemuConfig::new()
    };
    common::can_run(test, &cfg)
}

#[test]
fn the_firmware_alarms_by_the_deadline_after_the_actuator_fails() {
    if !available("hil run --target qemu --scenario actuator-fault") {
        return;
    }
    let opts = |target| RunOptions {
        target,
        scenario: "actuator-fault".into(),
        qemu_link: Channel::Bulk,
        progress: false,
        ..RunOptions::default()
    };
    let t0 = std::time::Instant::now();
    let q = run(&opts(Target::Qemu)).expect("the QEMU run is made");
    eprintln!(
        "actuator-fault under QEMU (bulk): {:.1} s wall, {} periods",
        t0.elapsed().as_secs_f64(),
        q.trajectory.records.len()
    );
    let r = &q.report;
    let m = &r.monitor;
    println!("{}", serde_json::to_string(m).unwrap());
    assert_eq!(r.target, "qemu");
    assert_eq!(m.source, "device-flags");
    assert_eq!(m.expect, "alarm");
    assert_eq!(m.verdict, Verdict::Pass, "{}", m.reason);
    let (t_f, d, t) = (
        m.fault_s.unwrap(),
        m.deadline_s.unwrap(),
        m.first_alarm_s.unwrap(),
    );
    assert!(
        t > t_f && t <= d,
        "fault {t_f} s, alarm {t} s, deadline {d} s"
    );
    assert!(
        m.alarms.iter().any(|a| a.kind == "actuator"),
        "{:?}",
        m.alarms
    );
    // The firmware's Status: the first alarm's tick (its sample instant within one
    // period of the first flagged frame's arrival, 0.2 ms at 5 kHz) and the counters.
    let (tick, t_dev) = (
        m.device_first_alarm_tick.expect("Status.first_alarm_tick"),
        m.device_first_alarm_s.unwrap(),
    );
    assert!(
        tick > 0 && t_dev > t_f && t_dev <= d,
        "tick {tick}, {t_dev} s"
    );
    assert!(
        (t - t_dev).abs() <= 2e-4 + 1e-9,
        "flags {t} s, Status {t_dev} s"
    );
    let st = r.device_status.as_ref().expect("the device's Status");
    let count = |kind| m.alarms.iter().filter(|a| a.kind == kind).count() as u32;
    assert_eq!(st.act_alarms, count("actuator"), "{st:?}");
    assert_eq!(st.hunt_alarms, count("hunting"), "{st:?}");
    // The same fixed-point runtime in process: the same alarms, from the same sample
    // (the arrival times differ by the links' latencies, under one period; the ticks by
    // the lock-step device's Config frame, one tick before the first sample).
    let inproc = run(&opts(Target::InProc)).unwrap();
    let im = &inproc.report.monitor;
    assert_eq!(
        m.alarms.len(),
        im.alarms.len(),
        "{:?} vs {:?}",
        m.alarms,
        im.alarms
    );
    for (a, b) in m.alarms.iter().zip(&im.alarms) {
        assert_eq!(a.kind, b.kind);
        assert!((a.t_s - b.t_s).abs() < 2e-4, "{a:?} vs {b:?}");
    }
    assert_eq!(Some(t_dev), im.device_first_alarm_s);
}
