//! What a tick sends at its largest: an Actuation frame and a requested Status whose
//! counters all take their longest encoding go out whole (`TX_CAPACITY`, an Actuation
//! plus a Status frame); and `Runtime::preset_counters` starts every counter where it is
//! told but leaves the flags, which are the next tick's.

use wheelset_control::Fx;
use wheelset_proto::*;
use wheelset_runtime::*;

mod common;
use common::{frame, frames, vel};

/// Counters at `u32::MAX`: every one a 5-byte varint (`wheelset_proto::sizes`).
fn longest() -> Status {
    Status {
        ticks: u32::MAX,
        rx_ok: u32::MAX,
        rx_crc: u32::MAX,
        rx_cobs: u32::MAX,
        rx_version: u32::MAX,
        rx_length: u32::MAX,
        rx_postcard: u32::MAX,
        rx_unexpected: u32::MAX,
        seq_gaps: u32::MAX,
        held_ticks: u32::MAX,
        safe_ticks: u32::MAX,
        safe_entries: u32::MAX,
        safe_exits: u32::MAX,
        yaw_sat: u32::MAX,
        traction_sat: u32::MAX,
        input_clamped: u32::MAX,
        cmd_refused: u32::MAX,
        ticks_late: u32::MAX,
        ticks_missed: u32::MAX,
        rx_overrun: u32::MAX,
        tx_dropped: u32::MAX,
        wsp_ticks: u32::MAX,
        wsp_events: u32::MAX,
        hunt_alarms: u32::MAX,
        act_alarms: u32::MAX,
        first_alarm_tick: u32::MAX,
        drive_alarms: u32::MAX,
        first_drive_alarm_tick: u32::MAX,
        boot_count: u32::MAX,
        stack_peak: u32::MAX,
        refuse_reason: u8::MAX,
        reset_cause: u8::MAX,
        flags: Flags(u16::MAX),
    }
}

#[test]
fn the_largest_actuation_and_status_go_out_whole() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("the default runs");
    r.preset_counters(&longest());
    r.receive(&frame(&Message::Command(Command::RequestStatus)));
    r.receive(&vel(1, 0));
    let out = r.tick(u32::MAX).to_vec();
    // Longer than one frame's worst case: the buffer must hold two.
    assert!(out.len() > MAX_FRAME, "{} bytes", out.len());
    assert!(out.len() <= TX_CAPACITY);
    match frames(&out).as_slice() {
        [Message::Actuation(a), Message::Status(s)] => {
            assert_eq!(a.exec, u32::MAX);
            // The counters that moved wrapped: `ticks` on this tick, `rx_ok` on the two
            // frames (the request and the sample); the others are the preset ones.
            assert_eq!((s.ticks, s.rx_ok), (0, 1));
            assert_eq!(s.hunt_alarms, u32::MAX);
            assert_eq!(s.stack_peak, u32::MAX);
            assert_eq!(s.flags, a.flags);
        }
        other => panic!("expected an actuation and a status frame, got {other:?}"),
    }
}

#[test]
fn preset_counters_leaves_the_flags_to_the_next_tick() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("the default runs");
    r.receive(&vel(1, 0));
    let _ = r.tick(0);
    let before = r.counters().flags;
    assert!(before.has(Flags::ENABLED) && !before.has(Flags::SAFE));
    r.preset_counters(&longest());
    let c = r.counters();
    assert_eq!(
        c.flags, before,
        "the flags are the last tick's, not the preset's"
    );
    assert_eq!((c.ticks, c.held_ticks), (u32::MAX, u32::MAX));
}
