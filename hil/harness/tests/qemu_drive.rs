//! The drive check end to end under QEMU: `hil run --target qemu --params` a plant whose
//! armature inductance is 30 % of the design (`l_a = 1.2e-4`) on the `short` scenario,
//! over the semihosting bulk channel. The current loop is unstable at 5 kHz; the
//! firmware's own `DRIVE_OSC` flag is the run's first alarm, by the deadline the
//! sampled-data analysis states, at the same tick as the in-process device's, and its
//! Status counts it. Skips when QEMU or the ELF is missing, unless `REQUIRE_QEMU=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use hil::run::{run, RunOptions, Target};
use wheelset_plant::params::Params;
use wheelset_report::Verdict;
use wheelset_targets::qemu::{Channel, QemuConfig};

#[test]
fn the_firmware_names_the_drive_when_the_armature_inductance_is_a_third() {
    let cfg = QemuConfig {
        channel: Channel::Bulk,
        ..QemuConfig::new()
    };
    if !common::can_run("hil run --target qemu --params l_a = 1.2e-4", &cfg) {
        return;
    }
    let opts = |target| RunOptions {
        target,
        scenario: concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short.toml").into(),
        params: Params {
            l_a: 1.2e-4,
            ..Params::default()
        },
        qemu_link: Channel::Bulk,
        progress: false,
        ..RunOptions::default()
    };
    let q = run(&opts(Target::Qemu)).expect("the QEMU run is made");
    let m = &q.report.monitor;
    println!("{}", serde_json::to_string(m).unwrap());
    assert_eq!(q.report.target, "qemu");
    assert_eq!(m.drive.expect, "alarm");
    assert!(m.drive.current_radius.unwrap() > 1.0);
    assert_eq!(m.alarms[0].kind, "drive", "{:?}", m.alarms);
    let (t, due) = (m.drive.first_alarm_s.unwrap(), m.drive.deadline_s.unwrap());
    assert!(t <= due, "drive alarm {t} s, deadline {due} s");
    assert_eq!(m.verdict, Verdict::Pass, "{}", m.reason);
    let st = q.report.device_status.unwrap();
    assert!(st.drive_alarms >= 1, "{st:?}");
    // The same fixed-point core in process: the first drive alarm on the same sample
    // (the flags' arrival times differ by the transports' latencies).
    let p = run(&opts(Target::InProc)).expect("the in-process run is made");
    let pm = &p.report.monitor;
    assert_eq!(pm.alarms[0].kind, "drive");
    assert_eq!(pm.device_first_alarm_s, m.device_first_alarm_s);
    // The lock-step device got its Config one tick before the first sample.
    assert_eq!(
        m.drive.device_first_alarm_tick,
        pm.drive.device_first_alarm_tick.map(|n| n + 1)
    );
}
