//! The counters across their 32-bit wrap (started near it with
//! `Runtime::preset_counters`, as `hil soak` starts them): every counter keeps counting
//! modulo 2^32, and a first-alarm tick, whose 0 means "none", never reads 0.

use wheelset_control::Fx;
use wheelset_proto::*;
use wheelset_runtime::*;

mod common;
use common::{frames, sample, sensor_frame};

/// A Sensor frame whose armature current swings by 1.5 kA at 0.186 of the rate around
/// 115 A (a current-loop limit cycle: the drive alarm), tick `k`.
fn limit_cycle(k: u32) -> Vec<u8> {
    let i = 115_000.0 + 1_500_000.0 * (2.0 * std::f64::consts::PI * 0.186 * f64::from(k)).sin();
    sensor_frame(Sensor {
        i_a_ma: i as i32,
        ..sample(k as u16, Lateral::Velocity(0))
    })
}

/// Runs ticks 1..=n on [`limit_cycle`] (after presetting the counters at `start`); the
/// first tick (1-based) whose actuation has the drive alarm, and the closing Status.
fn run(start: Option<&Status>, n: u32) -> (Option<u32>, Status) {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    if let Some(s) = start {
        r.preset_counters(s);
    }
    let mut first = None;
    for k in 1..=n {
        r.receive(&limit_cycle(k));
        let out = frames(r.tick(0));
        if let Some(Message::Actuation(a)) = out.first() {
            if a.flags.has(Flags::DRIVE_OSC) && first.is_none() {
                first = Some(k);
            }
        }
    }
    let cmd = encode_vec(&Message::Command(Command::RequestStatus)).expect("fits");
    r.receive(&cmd);
    r.receive(&limit_cycle(n + 1));
    match frames(r.tick(0)).as_slice() {
        [Message::Actuation(_), Message::Status(s)] => (first, *s),
        other => panic!("expected an actuation and a status, got {other:?}"),
    }
}

#[test]
fn an_alarm_on_the_tick_the_count_wraps_to_zero_is_recorded_as_one() {
    let (first, s) = run(None, 400);
    let first = first.expect("the limit cycle raises the drive alarm");
    assert_eq!(s.first_alarm_tick, first);
    // Started so that the alarm's tick is the one whose count wraps to 0.
    let start = Status {
        ticks: 0u32.wrapping_sub(first),
        ..Status::default()
    };
    let (again, s) = run(Some(&start), 400);
    assert_eq!(again, Some(first), "the counters do not change the control");
    assert_eq!(
        (s.first_alarm_tick, s.first_drive_alarm_tick),
        (1, 1),
        "{s:?}"
    );
    assert_eq!(s.drive_alarms, 1);
    assert_eq!(s.ticks, 401u32.wrapping_sub(first));
}

#[test]
fn every_counter_counts_on_across_the_wrap() {
    let near = u32::MAX - 100;
    let start = Status {
        ticks: near,
        rx_ok: near,
        held_ticks: near,
        ..Status::default()
    };
    let (_, s) = run(Some(&start), 400);
    // 401 ticks, 402 valid frames (401 Sensor, 1 Command), counted on from the start.
    assert_eq!(s.ticks, near.wrapping_add(401));
    assert_eq!(s.rx_ok, near.wrapping_add(402));
    assert_eq!(s.held_ticks, near, "no tick held");
    assert_eq!(s.seq_gaps, 0);
}
