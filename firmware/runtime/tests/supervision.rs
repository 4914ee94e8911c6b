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

/// Runs ticks `from..from + n` on the frames `frame(k)`; returns the first tick whose
/// actuation has `flag` and the last actuation.
fn first_flagged(
    r: &mut Runtime<Fx>,
    (from, n): (u32, u32),
    flag: u16,
    frame: impl Fn(u32) -> Vec<u8>,
) -> (Option<u32>, Actuation) {
    let mut first = None;
    let mut last = None;
    for k in from..from + n {
        r.receive(&frame(k));
        let a = act(r.tick(0));
        if a.flags.has(flag) && first.is_none() {
            first = Some(k);
        }
        last = Some(a);
    }
    (first, last.expect("ticks ran"))
}

/// Runs `n` ticks of an 8 Hz `y'` of 0.1 m/s amplitude; returns the first tick flagged
/// HUNTING and the last actuation.
fn hunt(r: &mut Runtime<Fx>, from: u32, n: u32) -> (Option<u32>, Actuation) {
    first_flagged(r, (from, n), Flags::HUNTING, |k| {
        sensor(k as u16, hunting(k, 100_000.0), 925_600, 0)
    })
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
    off.receive(&config(YawMode::Lead, false, false, DEFAULT_HOLD_TICKS));
    assert_eq!(slipping(&mut off, 2_000), 0, "switched off by the Config");
    assert_eq!(status(&mut off, 2_001).wsp_ticks, 0);

    // On at boot (the device's default), before any Config.
    let mut on = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    assert!(on.core().wsp_enabled(), "on by default");
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
    r.receive(&config(YawMode::Lead, false, false, DEFAULT_HOLD_TICKS));
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
    let mut q = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    q.receive(&config(YawMode::Lead, false, false, DEFAULT_HOLD_TICKS));
    q.receive(&sensor(1, 0, 925_600, 70_000));
    q.tick(0);
    let cfg = RuntimeConfig::default()
        .designed(2_500, 1)
        .expect("a design point");
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
    assert_eq!(q.base_rate_hz(), 2_500);
    assert!(q.core().wsp_enabled());
    assert_eq!(q.core().wsp_state().w_ref, Fx::ZERO);
    // The next frame's reference is converted at once (the protection is on).
    q.receive(&sensor(2, 0, 925_600, 70_000));
    let mut e = q.core().clone();
    e.set_v_ref_code(70_000);
    assert_eq!(q.core().wsp_state().w_ref, e.wsp_state().w_ref);
    assert_ne!(q.core().wsp_state().w_ref, Fx::ZERO);
}

/// A Sensor frame: `y'` 1 mm/s, the motor at 925.6 rad/s (83.3 m/s at the rim), a
/// demand of `demand_nm` and the reference speed `v_ref_mm_s`.
fn driving(seq: u16, demand_nm: i32, v_ref_mm_s: i32) -> Vec<u8> {
    sensor_frame(Sensor {
        omega_m_mrad_s: 925_600,
        demand_nm,
        v_ref_mm_s,
        ..sample(seq, Lateral::Velocity(1_000))
    })
}

#[test]
fn an_unknown_reference_speed_leaves_the_protection_idle() {
    // 925.6 rad/s, 5 000 N m, v_ref 0 (unknown): no WHEEL_SLIP, no cut: the outputs of
    // a device with the protection off, tick for tick. At 83 333 mm/s (the wheel
    // rolls) likewise; at 1 mm/s (a vehicle known to stand) the wheel slips.
    for v_ref in [0, 83_333] {
        let mut on = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
        let mut off = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
        off.receive(&config(YawMode::Lead, false, false, DEFAULT_HOLD_TICKS));
        for k in 1..=500u16 {
            on.receive(&driving(k, 5_000, v_ref));
            off.receive(&driving(k, 5_000, v_ref));
            let (a, b) = (act(on.tick(0)), act(off.tick(0)));
            assert!(!a.flags.has(Flags::WHEEL_SLIP), "v_ref {v_ref}, tick {k}");
            assert_eq!((a.t_psi_dnm, a.u_a_cv), (b.t_psi_dnm, b.u_a_cv), "tick {k}");
        }
        let s = status_on(&mut on, &driving(501, 5_000, v_ref)).1;
        assert_eq!((s.wsp_ticks, s.wsp_events), (0, 0), "v_ref {v_ref}");
    }
    let mut on = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    on.receive(&driving(1, 5_000, 1));
    assert!(
        act(on.tick(0)).flags.has(Flags::WHEEL_SLIP),
        "known, 1 mm/s"
    );
}

#[test]
fn a_boot_after_a_fault_drives_the_safe_outputs_until_clear_faults() {
    for cause in [reset_cause::FAULT, reset_cause::WATCHDOG] {
        let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
        r.set_boot(2, cause);
        // A device with its outputs disabled: zero torque, the back-EMF of the speed.
        let mut disabled = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
        disabled.receive(
            &encode_vec(&Message::Config(Config {
                mode: YawMode::Lead,
                traction: true,
                enable: false,
                hold_ticks: DEFAULT_HOLD_TICKS,
                wsp: true,
                monitor_safe: false,
                rates: None,
            }))
            .expect("fits"),
        );
        // A freshly powered device gets the full lead torque on the same frame.
        let mut fresh = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
        fresh.set_boot(1, reset_cause::POWER_ON);
        let f = driving(1, 5_000, 83_333);
        let (a, d, p) = {
            r.receive(&f);
            disabled.receive(&f);
            fresh.receive(&f);
            (act(r.tick(0)), act(disabled.tick(0)), act(fresh.tick(0)))
        };
        assert!(p.t_psi_dnm.abs() > 1_000, "the lead's first torque {p:?}");
        assert!(
            a.flags.has(Flags::SAFE) && a.flags.has(Flags::FAULT_LATCHED),
            "{a:?}"
        );
        assert_eq!((a.t_psi_dnm, a.u_a_cv), (0, d.u_a_cv), "cause {cause}");
        // The host's Config after the reset (new rates too) does not end it.
        let cfg = RuntimeConfig::default()
            .designed(2_500, 1)
            .expect("a design point");
        r.receive(
            &encode_vec(&Message::Config(Config {
                mode: YawMode::Lead,
                traction: true,
                enable: true,
                hold_ticks: DEFAULT_HOLD_TICKS,
                wsp: true,
                monitor_safe: false,
                rates: Some(rates_for::<Fx>(&cfg).expect("valid")),
            }))
            .expect("fits"),
        );
        assert_eq!(r.base_rate_hz(), 2_500, "the Config is applied");
        for k in 2..=200u16 {
            r.receive(&driving(k, 5_000, 83_333));
            let a = act(r.tick(0));
            assert!(a.flags.has(Flags::SAFE), "tick {k}");
            assert_eq!(a.t_psi_dnm, 0, "tick {k}");
        }
        // Acknowledged: the safe state ends, the torque limit ramps up from zero (at
        // the safe ramp's 2e5 N m/s: 80 N m per 400 us tick at 2.5 kHz), the latch clears.
        r.receive(&command(Command::ClearFaults));
        let mut last = 0;
        for k in 201..=260u16 {
            r.receive(&driving(k, 5_000, 83_333));
            let a = act(r.tick(0));
            assert!(!a.flags.has(Flags::SAFE) && !a.flags.has(Flags::FAULT_LATCHED));
            assert!((a.t_psi_dnm - last).abs() <= 800, "tick {k}: {a:?}");
            last = a.t_psi_dnm;
        }
        assert!(last.abs() > 1_000, "the torque came back: {last}");
        let s = status(&mut r, 261);
        assert_eq!((s.safe_entries, s.safe_exits), (1, 1));
    }
}

/// A Command frame whose variant index is the varint `index` (bytes as sent).
fn command_index(index: &[u8]) -> Vec<u8> {
    let mut raw = vec![VERSION, 3];
    raw.extend_from_slice(index);
    let mut out = vec![0u8; MAX_FRAME];
    let n = frame_raw(&raw, &mut out).expect("fits");
    out.truncate(n);
    out
}

#[test]
fn cmd_refused_marks_the_latest_config_or_command() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    let refused = config(YawMode::Lead, true, false, u16::MAX);
    let accepted = config(YawMode::Lead, true, false, DEFAULT_HOLD_TICKS);
    let mut seq = 0u16;
    let mut flag = |r: &mut Runtime<Fx>, frame: &[u8]| {
        r.receive(frame);
        seq += 1;
        r.receive(&sensor(seq, 0, 925_600, 0));
        act(r.tick(0)).flags.has(Flags::CMD_REFUSED)
    };
    assert!(flag(&mut r, &refused));
    // A Command taken clears it; the reason of the refusal stays in the Status.
    assert!(!flag(&mut r, &command(Command::ClearFaults)));
    assert_eq!(
        status(&mut r, 100).refuse_reason,
        RefuseReason::HoldTicks.code()
    );
    assert!(flag(&mut r, &refused));
    // RequestStatus, a read, leaves it: the Status shows the Config's verdict.
    assert!(flag(&mut r, &command(Command::RequestStatus)));
    let (a, s) = status_on(&mut r, &sensor(101, 0, 925_600, 0));
    assert!(a.flags.has(Flags::CMD_REFUSED) && s.flags.has(Flags::CMD_REFUSED));
    // An unknown request (index 200, a two-byte varint) is refused, not a decoding
    // error; a Config taken clears the flag.
    assert!(!flag(&mut r, &command(Command::ResetCounters)));
    assert!(flag(&mut r, &command_index(&[0xC8, 0x01])));
    assert_eq!(r.refuse_reason(), RefuseReason::UnknownRequest);
    assert!(!flag(&mut r, &accepted));
    let s = status(&mut r, 102);
    assert_eq!(
        (s.cmd_refused, s.rx_postcard),
        (1, 0),
        "one refusal since the reset"
    );
}

/// With `fault-inject` (the QEMU firmware's runtime): a HardFault is honoured on any
/// board, a stall only where a watchdog ends it (`Runtime::set_watchdog`); elsewhere it
/// is refused as Unsupported.
#[cfg(feature = "fault-inject")]
#[test]
fn a_stall_is_honoured_only_where_a_watchdog_ends_it() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    r.receive(&command(Command::InjectStall));
    let a = act(r.tick(0));
    assert!(a.flags.has(Flags::CMD_REFUSED));
    assert_eq!(r.refuse_reason(), RefuseReason::Unsupported);
    assert_eq!(r.take_injected(), None);
    r.receive(&command(Command::InjectHardFault));
    assert!(!act(r.tick(0)).flags.has(Flags::CMD_REFUSED));
    assert_eq!(r.take_injected(), Some(Command::InjectHardFault));
    r.set_watchdog(true);
    r.receive(&command(Command::InjectStall));
    assert!(!act(r.tick(0)).flags.has(Flags::CMD_REFUSED));
    assert_eq!(r.take_injected(), Some(Command::InjectStall));
}

/// A Sensor frame whose armature current swings by `amp_ma` at 0.186 of the rate around
/// its 115 A (a current-loop limit cycle near 930 Hz at 5 kHz), tick `k`.
fn limit_cycle(k: u32, amp_ma: f64) -> Vec<u8> {
    let i = 115_000.0 + amp_ma * (2.0 * std::f64::consts::PI * 0.186 * f64::from(k)).sin();
    sensor_frame(Sensor {
        i_a_ma: i as i32,
        ..sample(k as u16, Lateral::Velocity(0))
    })
}

/// Runs ticks `from..from + n` on [`limit_cycle`]; returns the first tick flagged
/// DRIVE_OSC and the last actuation.
fn oscillate(r: &mut Runtime<Fx>, from: u32, n: u32, amp_ma: f64) -> (Option<u32>, Actuation) {
    first_flagged(r, (from, n), Flags::DRIVE_OSC, |k| limit_cycle(k, amp_ma))
}

#[test]
fn a_current_limit_cycle_raises_the_drive_alarm_not_the_yaw_ones() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    // A ripple of 20 A (RMS 14 A, the healthy loop's order): nothing.
    let (first, last) = oscillate(&mut r, 1, 2_000, 20_000.0);
    assert!(first.is_none() && !last.flags.has(Flags::FAULT_LATCHED));
    // 1.5 kA: the drive alarm, latched; neither yaw alarm; reported only.
    let (first, last) = oscillate(&mut r, 2_001, 2_000, 1_500_000.0);
    let first = first.expect("a ripple RMS of 1.2 kA is above the 300 A threshold");
    // The mean square crosses within a few steps, then the persistence's 64 steps.
    assert!(
        (2_001 + 64..2_001 + 128).contains(&first),
        "first at {first}"
    );
    assert!(last.flags.has(Flags::FAULT_LATCHED) && !last.flags.has(Flags::SAFE));
    assert!(!last.flags.has(Flags::HUNTING) && !last.flags.has(Flags::ACTUATOR_FAULT));
    let s = status(&mut r, 4_001);
    assert_eq!(
        (s.drive_alarms, s.hunt_alarms, s.act_alarms),
        (1, 0, 0),
        "{s:?}"
    );
    // The runtime's tick count at the rising edge (tick k is the runtime's k-th).
    assert_eq!(s.first_drive_alarm_tick, first, "{s:?}");
    assert_eq!(s.first_alarm_tick, first, "{s:?}");
    // The oscillation gone, the alarm falls; the latch stays until ClearFaults.
    let (_, last) = oscillate(&mut r, 4_002, 2_000, 0.0);
    assert!(!last.flags.has(Flags::DRIVE_OSC) && last.flags.has(Flags::FAULT_LATCHED));
    r.receive(&command(Command::ClearFaults));
    let (_, last) = oscillate(&mut r, 6_002, 10, 0.0);
    assert!(!last.flags.has(Flags::FAULT_LATCHED));
}

#[test]
fn monitor_safe_takes_the_drive_alarm_to_the_safe_state() {
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("valid");
    r.receive(&config(YawMode::Lead, false, true, DEFAULT_HOLD_TICKS));
    let (first, _) = oscillate(&mut r, 1, 1_000, 1_500_000.0);
    let first = first.expect("drive alarm");
    // Safe from the tick after the alarm on, the oscillation going on or not.
    let (_, last) = oscillate(&mut r, 1_001, 2_000, 1_500_000.0);
    assert!(last.flags.has(Flags::SAFE) && last.flags.has(Flags::FAULT_LATCHED));
    let s = status(&mut r, 3_001);
    assert_eq!(s.safe_entries, 1, "{s:?}");
    assert_eq!(s.safe_ticks, 3_001 - first, "{s:?}");
    r.receive(&command(Command::ClearFaults));
    r.receive(&limit_cycle(3_002, 0.0));
    assert!(!act(r.tick(0)).flags.has(Flags::SAFE));
}
