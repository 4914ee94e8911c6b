//! Two of the monitor's alarms rising on the same tick are both counted: the hunting
//! alarm and the actuator alarm, made to rise together, each add one to their counters
//! and the first alarm's tick is theirs.
//!
//! The signal: `y'` ramped slowly (no band-passed energy to speak of) to a drift of
//! -40 mm/s, which the actuator check counts as growth at every block end (drift level
//! 25 mm/s) until its alarm rises at a block end `T`; then, a few monitor steps before
//! `T`, a jump to +0.9 m/s, whose band-passed energy raises the hunting alarm within a
//! few steps. The jump's tick is searched (one monitor step, 10 ticks, at a time) for
//! the one whose hunting alarm rises on `T` itself.

use wheelset_control::Fx;
use wheelset_proto::*;
use wheelset_runtime::*;

mod common;
use common::{frame, frames, vel};

/// Ticks of the ramp to the drift (0.5 s at 5 kHz).
const RAMP: u32 = 2_500;
const DRIFT_UM_S: f64 = -40_000.0;
const JUMP_UM_S: i32 = 900_000;

/// `y'` at tick `k` with the jump at `jump` (if any).
fn y(k: u32, jump: Option<u32>) -> i32 {
    match jump {
        Some(j) if k >= j => JUMP_UM_S,
        _ => (DRIFT_UM_S * f64::from(k.min(RAMP)) / f64::from(RAMP)) as i32,
    }
}

/// The first ticks flagged HUNTING and ACTUATOR_FAULT within `n` ticks, and the Status
/// after the last.
fn run(jump: Option<u32>, n: u32) -> (Option<u32>, Option<u32>, Status) {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("the default runs");
    let (mut hunting, mut actuator) = (None, None);
    let mut status = None;
    for k in 1..=n {
        if k == n {
            r.receive(&frame(&Message::Command(Command::RequestStatus)));
        }
        r.receive(&vel(k as u16, y(k, jump)));
        let out = frames(r.tick(0));
        let Some(Message::Actuation(a)) = out.first() else {
            panic!("expected an actuation frame first, got {out:?}");
        };
        if a.flags.has(Flags::HUNTING) {
            hunting.get_or_insert(k);
        }
        if a.flags.has(Flags::ACTUATOR_FAULT) {
            actuator.get_or_insert(k);
        }
        if let Some(Message::Status(s)) = out.get(1) {
            status = Some(*s);
        }
    }
    (hunting, actuator, status.expect("requested"))
}

#[test]
fn a_hunting_and_an_actuator_alarm_on_one_tick_are_both_counted() {
    // The drift alone: the actuator alarm at T, no hunting alarm.
    let (h, a, _) = run(None, 10_000);
    assert_eq!(h, None, "the ramp has no band-passed energy to speak of");
    let t = a.expect("the drift raises the actuator alarm");
    // The jump: a few monitor steps before T, found step by step.
    let together = (1..=30).map(|steps| t - 10 * steps).find_map(|jump| {
        let (h, a, s) = run(Some(jump), t + 1);
        (h == Some(t) && a == Some(t)).then_some(s)
    });
    let s = together.expect("a jump whose hunting alarm rises on the actuator alarm's tick");
    assert_eq!((s.hunt_alarms, s.act_alarms, s.drive_alarms), (1, 1, 0));
    assert_eq!(s.first_alarm_tick, t);
    assert!(s.flags.has(Flags::FAULT_LATCHED));
}
