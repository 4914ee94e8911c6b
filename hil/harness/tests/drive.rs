//! The drive check in the closed loop, in process: a plant whose armature inductance is
//! a third of the design or less makes the current loop unstable at 5 kHz; the harness
//! expects the drive alarm from the sampled-data analysis, the device raises it first and
//! by the deadline, and a silent device would fail. The normal scenarios (`curve`, the
//! wheel-slip protection acting on `low-adhesion`, `beating` with the lead, a faulty
//! link with outages and safe-state ramps) raise no drive alarm.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use hil::check::alarms::{judge_drive, DriveReport};
use hil::run::{run, Law, RunOptions, RunOutcome};
use wheelset_plant::params::Params;
use wheelset_report::Verdict;

fn short() -> String {
    concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short.toml").to_string()
}

fn with_l_a(l_a: f64) -> RunOutcome {
    run(&RunOptions {
        scenario: short(),
        params: Params {
            l_a,
            ..Params::default()
        },
        progress: false,
        ..RunOptions::default()
    })
    .unwrap()
}

/// The drive alarm of a run with the armature inductance at `l_a`: expected, first, by
/// the deadline; the same report without the device's alarms fails.
fn inductance_fault_alarms(l_a: f64) {
    let out = with_l_a(l_a);
    let m = &out.report.monitor;
    let d = &m.drive;
    println!("{}", serde_json::to_string(m).unwrap());
    assert!(d.current_radius.unwrap() > 1.0, "{d:?}");
    // The pair near 1 kHz (a fifth of the rate and above).
    assert!((900.0..1100.0).contains(&d.mode_hz.unwrap()), "{d:?}");
    assert_eq!(d.expect, "alarm");
    let (t, due) = (d.first_alarm_s.unwrap(), d.deadline_s.unwrap());
    assert!(t <= due, "drive alarm {t} s, deadline {due} s");
    assert_eq!(m.alarms[0].kind, "drive", "{:?}", m.alarms);
    assert_eq!(m.verdict, Verdict::Pass, "{}", m.reason);
    // The device's Status: the first drive alarm's tick, at the flag's period.
    let tick = d
        .device_first_alarm_tick
        .expect("Status.first_drive_alarm_tick");
    let t_tick = f64::from(tick) * out.period_ns as f64 * 1e-9;
    assert!(
        (t_tick - t).abs() < 1e-3,
        "tick {tick} ({t_tick} s) vs flag {t} s"
    );
    let st = out.report.device_status.unwrap();
    assert!(
        st.drive_alarms >= 1 && st.first_alarm_tick == tick,
        "{st:?}"
    );
    // A device that said nothing would fail.
    let mut silent = m.clone();
    silent.alarms.clear();
    silent.verdict = Verdict::Pass;
    let expect = DriveReport {
        first_alarm_s: None,
        ..d.clone()
    };
    judge_drive(&mut silent, expect, 3.0);
    assert_eq!(silent.verdict, Verdict::Fail);
    assert!(
        silent.reason.contains("no drive alarm"),
        "{}",
        silent.reason
    );
}

#[test]
fn a_third_of_the_armature_inductance_alarms() {
    // 1.2e-4 H: 30 % of the design's 4e-4 H.
    inductance_fault_alarms(1.2e-4);
}

#[test]
fn a_quarter_of_the_armature_inductance_alarms() {
    inductance_fault_alarms(1.0e-4);
}

/// The run of `opts` raises no drive alarm and the harness expects none.
fn no_drive_alarm(opts: RunOptions) -> RunOutcome {
    let out = run(&RunOptions {
        progress: false,
        ..opts
    })
    .unwrap();
    let m = &out.report.monitor;
    println!("{}", serde_json::to_string(&m.drive).unwrap());
    assert!(m.drive.current_radius.unwrap() < 1.0, "{:?}", m.drive);
    assert_eq!(m.drive.expect, "none");
    assert!(
        !m.alarms.iter().any(|a| a.kind == "drive"),
        "{:?}",
        m.alarms
    );
    assert_eq!(out.report.device_status.unwrap().drive_alarms, 0);
    // A drive alarm here would have failed the run.
    let mut false_alarm = m.clone();
    false_alarm.verdict = Verdict::Pass;
    false_alarm.alarms.insert(
        0,
        hil::check::alarms::Alarm {
            kind: "drive",
            t_s: 1.0,
        },
    );
    judge_drive(&mut false_alarm, m.drive.clone(), 20.0);
    assert_eq!(false_alarm.verdict, Verdict::Fail);
    out
}

fn scenario(name: &str, control: Law) -> RunOptions {
    RunOptions {
        scenario: name.into(),
        control,
        ..RunOptions::default()
    }
}

#[test]
fn curve_raises_no_drive_alarm() {
    let out = no_drive_alarm(scenario("curve", Law::Lead));
    assert_eq!(out.report.monitor.verdict, Verdict::Pass);
}

#[test]
fn low_adhesion_with_the_protection_acting_raises_no_drive_alarm() {
    let out = no_drive_alarm(scenario("low-adhesion", Law::Lead));
    // The protection cut the traction (steps of the reference the check rides out).
    assert!(out.report.device_status.unwrap().wsp_events >= 1);
}

#[test]
fn beating_with_the_lead_raises_no_drive_alarm() {
    no_drive_alarm(scenario("beating", Law::Lead));
}

#[test]
fn a_faulty_link_with_outages_raises_no_drive_alarm() {
    let out = no_drive_alarm(RunOptions {
        link: wheelset_loop::sim_link::LinkConfig {
            faults: "ber=1e-4,drop=0.01,outage=8:0.05".parse().unwrap(),
            seed: 5,
            ..Default::default()
        },
        ..scenario("curve", Law::Lead)
    });
    // The outages took the device to the safe state and back (the ramps).
    let st = out.report.device_status.unwrap();
    assert!(st.safe_entries >= 1 && st.safe_exits >= 1, "{st:?}");
}
