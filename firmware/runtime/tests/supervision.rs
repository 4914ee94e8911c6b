//! Wire version 2 on the device: the stability monitor's alarms, the latched fault and
//! `Config.monitor_safe`, the wheel-slip protection's flag and counters, the refusal
//! reason and the board's fields in the Status.

use wheelset_control::Fx;
use wheelset_proto::*;
use wheelset_runtime::*;

mod common;
use common::{act, frames, sample, sensor_frame};

fn sensor(seq: u16, y_um_s: i32, omega_mrad_s: i32, v_ref_mm_s: i32) -> Vec<u8> {
    sensor_frame(Sensor {
        omega_m_mrad_s: omega_mrad_s,
        v_ref_mm_s,
        ..sample(seq, Lateral::Velocity(y_um_s))
    })
}

fn config(mode: YawMode, wsp: bool, monitor_safe: bool, hold_ticks: u16) -> Vec<u8> {
    encode_vec(&Message::Config(Config {
        mode,
        traction: true,
        enable: true,
        hold_ticks,
        wsp,
        monitor_safe,
        rates: None,
    }))
    .expect("fits")
    .to_vec()
}

fn command(c: Command) -> Vec<u8> {
    encode_vec(&Message::Command(c)).expect("fits").to_vec()
}

fn status(r: &mut Runtime<Fx>, seq: u16) -> Status {
    status_on(r, &sensor(seq, 0, 925_600, 0)).1
}

/// The tick on `frame` with a Status requested: its actuation and the Status.
fn status_on(r: &mut Runtime<Fx>, frame: &[u8]) -> (Actuation, Status) {
    r.receive(&command(Command::RequestStatus));
    r.receive(frame);
    match frames(r.tick(0)).as_slice() {
        [Message::Actuation(a), Message::Status(s)] => (*a, *s),
        other => panic!("expected an actuation and a status frame, got {other:?}"),
    }
}

/// `y'` of an 8 Hz oscillation of `amp` um/s at tick `k` of 5 kHz.
fn hunting(k: u32, amp: f64) -> i32 {
    (amp * (2.0 * std::f64::consts::PI * 8.0 * f64::from(k) / 5_000.0).sin()) as i32
}

/// Runs `n` ticks of an 8 Hz `y'` of 0.1 m/s amplitude; returns the first tick flagged
/// HUNTING and the last actuation.
fn hunt(r: &mut Runtime<Fx>, from: u32, n: u32) -> (Option<u32>, Actuation) {
    let mut first = None;
    let mut last = None;
    for k in from..from + n {
        r.receive(&sensor(k as u16, hunting(k, 100_000.0), 925_600, 0));
        let a = act(r.tick(0));
        if a.flags.has(Flags::HUNTING) && first.is_none() {
            first = Some(k);
        }
        last = Some(a);
    }
    (first, last.expect("ticks ran"))
}

#[test]
fn a_hunting_oscillation_raises_the_alarm_and_latches_the_fault() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    // A quiet start: no alarm, nothing latched.
    for k in 1..=2_000u32 {
        r.receive(&sensor(k as u16, hunting(k, 1_000.0), 925_600, 0));
        let a = act(r.tick(0));
        assert!(
            !a.flags.has(Flags::HUNTING) && !a.flags.has(Flags::FAULT_LATCHED),
            "tick {k}"
        );
    }
    let (first, last) = hunt(&mut r, 2_001, 10_000);
    let first = first.expect("0.1 m/s at 8 Hz (RMS 71 mm/s) is above the 30 mm/s threshold");
    assert!(last.flags.has(Flags::FAULT_LATCHED));
    // Reported only (monitor_safe off): the outputs stay active.
    assert!(!last.flags.has(Flags::SAFE));
    let s = status(&mut r, 12_001);
    assert!(s.hunt_alarms >= 1);
    // The first alarm (the actuator check may see the growth first) is the runtime's
    // tick count at its rising edge: after the quiet start, at the latest HUNTING's.
    assert!(
        s.first_alarm_tick > 2_000 && s.first_alarm_tick <= first,
        "{s:?}"
    );
    // ClearFaults clears the latch; the oscillation gone, it stays clear.
    r.receive(&command(Command::ClearFaults));
    for k in 12_002..=20_000u32 {
        r.receive(&sensor(k as u16, 0, 925_600, 0));
        let _ = r.tick(0);
    }
    assert!(!r.fault_latched());
    let s = status(&mut r, 20_001);
    assert!(!s.flags.has(Flags::HUNTING) && !s.flags.has(Flags::FAULT_LATCHED));
}

#[test]
fn monitor_safe_holds_the_safe_state_until_clear_faults() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    r.receive(&config(YawMode::Lead, false, true, DEFAULT_HOLD_TICKS));
    let (first, last) = hunt(&mut r, 1, 10_000);
    assert!(first.is_some(), "alarm");
    assert!(
        last.flags.has(Flags::SAFE),
        "the alarm holds the safe state"
    );
    // Fresh frames keep coming, and the state is still held.
    for k in 10_001..=15_000u32 {
        r.receive(&sensor(k as u16, 0, 925_600, 0));
        let a = act(r.tick(0));
        assert!(
            a.flags.has(Flags::SAFE) && !a.flags.has(Flags::HOLDING),
            "tick {k}"
        );
        assert_eq!(a.t_psi_dnm, 0, "the torque limit has ramped to zero");
    }
    let s = status(&mut r, 15_001);
    assert_eq!((s.safe_entries, s.safe_exits), (1, 0));
    // Safe from the tick after the first alarm through the status tick, every tick.
    assert!(s.first_alarm_tick > 0);
    assert_eq!(s.safe_ticks, 15_001 - s.first_alarm_tick, "{s:?}");
    r.receive(&command(Command::ClearFaults));
    r.receive(&sensor(15_002, 0, 925_600, 0));
    let a = act(r.tick(0));
    assert!(!a.flags.has(Flags::SAFE) && !a.flags.has(Flags::FAULT_LATCHED));
    assert_eq!(status(&mut r, 15_003).safe_exits, 1);
}

/// Wheel 83.3 m/s (925.6 rad/s at the motor) against a reference of 70 m/s: a slip of
/// 13 m/s, far above any threshold.
fn slipping(r: &mut Runtime<Fx>, ticks: u32) -> u32 {
    let mut flagged = 0;
    for k in 1..=ticks {
        r.receive(&sensor(k as u16, 0, 925_600, 70_000));
        flagged += u32::from(act(r.tick(0)).flags.has(Flags::WHEEL_SLIP));
    }
    flagged
}

#[test]
fn the_wheel_slip_protection_is_switched_by_the_config_and_reported() {
    let mut off = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    assert_eq!(slipping(&mut off, 2_000), 0, "off by default");
    assert_eq!(status(&mut off, 2_001).wsp_ticks, 0);

    let mut on = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    on.receive(&config(YawMode::Lead, true, false, DEFAULT_HOLD_TICKS));
    let flagged = slipping(&mut on, 2_000);
    assert!(flagged > 0, "a 13 m/s slip is flagged");
    let (a, s) = status_on(&mut on, &sensor(2_001, 0, 925_600, 70_000));
    let flagged = flagged + u32::from(a.flags.has(Flags::WHEEL_SLIP));
    // The counters are the flag's: one tick per flagged tick, at least one entry.
    assert_eq!(s.wsp_ticks, flagged);
    assert!(s.wsp_events >= 1 && s.wsp_events <= s.wsp_ticks);
    assert_eq!(s.cmd_refused, 0);
}

#[test]
fn the_status_carries_the_refusal_reason_and_the_board_fields() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    r.set_boot(7, reset_cause::WATCHDOG);
    r.set_stack_peak(3_152);
    r.note_board(2, 1, 5, 3);
    r.note_board(1, 0, 0, 0);
    // 65 535 ticks of hold = 13 s on a stale sample: refused, the reason reported.
    r.receive(&config(YawMode::Lead, false, false, u16::MAX));
    r.receive(&sensor(1, 0, 925_600, 0));
    let a = act(r.tick(0));
    assert!(a.flags.has(Flags::CMD_REFUSED));
    assert!(
        a.flags.has(Flags::FAULT_LATCHED),
        "a watchdog reset latches the fault"
    );
    let s = status(&mut r, 2);
    assert_eq!(s.refuse_reason, RefuseReason::HoldTicks.code());
    assert_eq!(
        (s.boot_count, s.reset_cause, s.stack_peak),
        (7, reset_cause::WATCHDOG, 3_152)
    );
    assert_eq!(
        (s.ticks_late, s.ticks_missed, s.rx_overrun, s.tx_dropped),
        (3, 1, 5, 3)
    );
    // ResetCounters zeroes the counters and the reason, not the boot record.
    r.receive(&command(Command::ResetCounters));
    let s = status(&mut r, 3);
    assert_eq!((s.refuse_reason, s.cmd_refused, s.ticks_late), (0, 0, 0));
    assert_eq!(
        (s.boot_count, s.reset_cause, s.stack_peak),
        (7, reset_cause::WATCHDOG, 3_152)
    );
}

/// Without the `fault-inject` feature (every build but the QEMU firmware) the fault
/// injections are refused as Unsupported and nothing is handed to the board.
#[cfg(not(feature = "fault-inject"))]
#[test]
fn fault_injection_is_refused_without_the_feature() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    for (k, c) in [Command::InjectStall, Command::InjectHardFault]
        .into_iter()
        .enumerate()
    {
        r.receive(&command(c));
        let a = act(r.tick(0));
        assert!(a.flags.has(Flags::CMD_REFUSED), "{c:?}: {:?}", a.flags);
        assert_eq!(r.take_injected(), None);
        let s = status(&mut r, 10 + k as u16);
        assert_eq!(s.cmd_refused, k as u32 + 1);
        assert_eq!(s.refuse_reason, RefuseReason::Unsupported.code());
    }
}

/// The reference speed of the frames received while the protection is off (the device
/// converts it only while it is on) reaches the core when a Config switches it on: the
/// latest one, as the core would have held it; and a Config with new rates, which
/// restarts the core, leaves the new core without one (0) until the next Sensor frame.
#[test]
fn the_reference_speed_received_while_the_protection_is_off_is_the_one_it_starts_on() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    let mut last = 0;
    for k in 1..=20u16 {
        last = 70_000 + 300 * i32::from(k);
        r.receive(&sensor(k, 0, 925_600, last));
        r.tick(0);
    }
    // The core as it would be had it converted every frame's code (the last one holds).
    let mut expected = r.core().clone();
    expected.set_v_ref_code(last);
    let want = expected.wsp_state().w_ref;
    assert_ne!(want, Fx::ZERO, "a reference of 76 m/s is not 0");
    r.receive(&config(YawMode::Lead, true, false, DEFAULT_HOLD_TICKS));
    assert_eq!(r.core().wsp_state().w_ref, want);
    // Off again, a new frame, on again: the new frame's reference.
    r.receive(&config(YawMode::Lead, false, false, DEFAULT_HOLD_TICKS));
    r.receive(&sensor(21, 0, 925_600, 60_000));
    r.tick(0);
    r.receive(&config(YawMode::Lead, true, false, DEFAULT_HOLD_TICKS));
    expected.set_v_ref_code(60_000);
    assert_eq!(r.core().wsp_state().w_ref, expected.wsp_state().w_ref);
    assert_ne!(expected.wsp_state().w_ref, want);

    // Off, a frame, then a Config with rates and the protection on: a fresh core.
    let mut cfg = RuntimeConfig::default();
    let mut q = Runtime::<Fx>::try_new(cfg).expect("valid");
    q.receive(&sensor(1, 0, 925_600, 70_000));
    q.tick(0);
    cfg.control.base_rate_hz = 4_000;
    let with_rates = encode_vec(&Message::Config(Config {
        mode: YawMode::Lead,
        traction: true,
        enable: true,
        hold_ticks: DEFAULT_HOLD_TICKS,
        wsp: true,
        monitor_safe: false,
        rates: Some(rates_for::<Fx>(&cfg).expect("valid rates")),
    }))
    .expect("fits");
    q.receive(&with_rates);
    assert_eq!(q.refuse_reason(), RefuseReason::None, "the rates are taken");
    assert_eq!(q.base_rate_hz(), 4_000);
    assert!(q.core().wsp_enabled());
    assert_eq!(q.core().wsp_state().w_ref, Fx::ZERO);
    // The next frame's reference is converted at once (the protection is on).
    q.receive(&sensor(2, 0, 925_600, 70_000));
    let mut e = q.core().clone();
    e.set_v_ref_code(70_000);
    assert_eq!(q.core().wsp_state().w_ref, e.wsp_state().w_ref);
    assert_ne!(q.core().wsp_state().w_ref, Fx::ZERO);
}
