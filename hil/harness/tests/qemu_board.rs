//! The board's own counters and boot record under QEMU (issues 14 and 20): the
//! `wheelset-qemu` firmware reports its late and skipped ticks, the bytes its receive
//! path lost and the frames its transmit path dropped, and its boot record (boot 1,
//! power-on, no latched fault after a fresh start) in the Status; a HardFault resets
//! it (lock-step build) and the new boot drives the safe outputs until `ClearFaults`; a
//! stalled control task trips the CMSDK watchdog, which resets it (the free-running
//! build `wheelset-qemu-free.elf`, where alone the watchdog runs:
//! `firmware/app/src/board/qemu/wdog.rs`), and the lock-step build, with no watchdog,
//! refuses the stall. Skips when QEMU or the ELF is missing, unless `REQUIRE_QEMU=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::{exchange, sensor, status};
use wheelset_proto::{
    encode_vec, reset_cause, Actuation, Command, Decoder, Flags, Message, Status,
};
use wheelset_targets::qemu::{Qemu, QemuConfig};

/// The firmware's RX pipe between the UART interrupt and the control task, bytes
/// (`firmware/app/src/settings.rs`, `RX_PIPE`).
const RX_PIPE: usize = 256;

#[test]
fn the_qemu_board_reports_its_counters_and_boot_record() {
    let Some(mut q) = common::start_cfg_or_skip("board counters", &QemuConfig::new()) else {
        return;
    };
    for k in 1..=5 {
        exchange(&mut q, &sensor(k), 1);
    }
    let s = status(&mut q);
    // A fresh QEMU process: the first boot since "power-on", nothing latched; lock-step
    // ticks are never late, and nothing was lost yet.
    assert_eq!((s.boot_count, s.reset_cause), (1, reset_cause::POWER_ON));
    assert!(!s.flags.has(Flags::FAULT_LATCHED), "{:?}", s.flags);
    assert_eq!((s.ticks_late, s.ticks_missed), (0, 0));
    assert_eq!((s.rx_overrun, s.tx_dropped), (0, 0));

    // A burst longer than the RX pipe before one delimiter: the interrupt handler
    // stores RX_PIPE bytes (the control task drains the pipe only at the tick the
    // delimiter clocks) and loses the rest, the delimiter included.
    let burst = 600usize;
    let mut bytes = vec![0x55u8; burst];
    bytes.push(0);
    exchange(&mut q, &bytes, 1);
    // The lost delimiter leaves the decoder inside the garbage: the next frame resyncs
    // it (its Actuation still comes, one per tick), the one after is received whole.
    exchange(&mut q, &sensor(6), 1);
    let m = exchange(&mut q, &sensor(7), 1);
    let Some(Message::Actuation(a)) = m.first() else {
        panic!("{m:?}")
    };
    assert_eq!(a.seq_echo, 7);
    let s = status(&mut q);
    assert_eq!(s.rx_overrun as usize, burst + 1 - RX_PIPE);
    assert_eq!((s.ticks_late, s.ticks_missed, s.tx_dropped), (0, 0, 0));
    assert_eq!(s.boot_count, 1);
}

fn command(c: Command) -> Vec<u8> {
    encode_vec(&Message::Command(c)).unwrap().to_vec()
}

/// Injects `fault`, expects the safe frame from the handler, waits for the reset and
/// returns the first Status of the new boot and the first Actuation after it.
fn fault_and_rejoin(q: &mut Qemu, fault: Command) -> (Actuation, Status) {
    for k in 1..=5 {
        exchange(q, &sensor(k), 1);
    }
    // The tick that takes the command queues its Actuation, then stalls (or faults);
    // that Actuation may or may not leave before the handler's safe frame, which comes
    // last, after a lone delimiter (an empty frame: it ends a frame the handler cut off
    // half sent, so that the safe frame arrives whole).
    q.send(&command(fault)).unwrap();
    let mut before_safe = Vec::new();
    let safe = loop {
        let mut f = q.recv_frame().unwrap();
        let empty = f.is_empty();
        f.push(0);
        let mut dec: Decoder = Decoder::new();
        match dec.next_message(&f).0.and_then(Result::ok) {
            Some(Message::Actuation(a)) if a.flags.has(Flags::SAFE) => break a,
            _ => before_safe.push(empty),
        }
        assert!(before_safe.len() <= 3, "no safe frame: {before_safe:?}");
    };
    assert_eq!(
        before_safe.last(),
        Some(&true),
        "the safe frame follows a lone delimiter: {before_safe:?}"
    );
    assert!(safe.flags.has(Flags::SAFE) && !safe.flags.has(Flags::ENABLED));
    assert_eq!((safe.t_psi_dnm, safe.u_a_cv, safe.tick), (0, 0, 0));
    // The reset follows within milliseconds of wall time; let the new boot come up.
    std::thread::sleep(std::time::Duration::from_millis(500));
    let m = exchange(q, &sensor(100), 1);
    let Some(Message::Actuation(first)) = m.first() else {
        panic!("{m:?}")
    };
    (*first, status(q))
}

/// The next frame from a free-running device (it sends one Actuation per tick of its
/// own, whether or not a frame came): its message, or `None` for a frame that does not
/// decode. The one such frame a stall may cause: the Actuation the TX task had on the
/// wire when the control task (at a higher priority) stalled, cut off by the NMI's safe
/// frame, which follows it on the wire.
fn next_message(q: &mut Qemu) -> Option<Message> {
    let mut f = q.recv_frame().unwrap();
    f.push(0);
    let mut dec: Decoder = Decoder::new();
    dec.next_message(&f).0.and_then(Result::ok)
}

/// Sends `bytes`, then reads up to `within` frames for the first message that `want`
/// accepts, sending a Sensor frame (`keep_alive`) after every 10 frames it reads: a
/// host that goes quiet trips the watchdog too (its feed rule needs the receive path),
/// and bytes sent while the board reboots are lost. At most one frame on the way may
/// fail to decode. `None` if none came.
fn try_await<T>(
    q: &mut Qemu,
    bytes: &[u8],
    keep_alive: u16,
    within: usize,
    mut want: impl FnMut(&Message) -> Option<T>,
) -> Option<T> {
    q.send(bytes).unwrap();
    let mut seen = Vec::new();
    let mut bad = 0;
    for k in 1..=within {
        if k % 10 == 0 {
            q.send(&sensor(keep_alive)).unwrap();
        }
        let Some(m) = next_message(q) else {
            bad += 1;
            assert!(bad <= 1, "{bad} frames that do not decode");
            continue;
        };
        if let Some(t) = want(&m) {
            return Some(t);
        }
        seen.push(m);
    }
    eprintln!(
        "no such message within {within} frames; the last: {:?}",
        seen.get(seen.len().saturating_sub(3)..)
    );
    None
}

/// [`try_await`] that must succeed.
fn await_message<T>(
    q: &mut Qemu,
    bytes: &[u8],
    keep_alive: u16,
    within: usize,
    want: impl FnMut(&Message) -> Option<T>,
) -> T {
    try_await(q, bytes, keep_alive, within, want).expect("the awaited message")
}

/// The device's Status; the request goes again after every 200 frames without it (the
/// free-running device drops frames its TX queue has no room for, `tx_dropped`, at
/// one Actuation per tick over this link).
fn free_status(q: &mut Qemu, keep_alive: u16) -> Status {
    (0..10)
        .find_map(|_| {
            try_await(
                q,
                &command(Command::RequestStatus),
                keep_alive,
                200,
                |m| match m {
                    Message::Status(s) => Some(*s),
                    _ => None,
                },
            )
        })
        .expect("a Status within 10 requests")
}

/// Runs the loop for 20 frames (the next Sensor when the device has echoed the one
/// before), injects a stall and waits for the watchdog: the NMI's safe frame, then the
/// new boot's Actuations. Returns the last tick before the stall, the first Actuation of
/// the new boot that echoes a Sensor, and its Status.
fn stall_and_rejoin(q: &mut Qemu, seq0: u16) -> (u16, Actuation, Status) {
    let mut last_tick = 0;
    for seq in seq0..seq0 + 20 {
        last_tick = await_message(q, &sensor(seq), seq, 2_000, |m| match m {
            Message::Actuation(a) if a.seq_echo == seq => Some(a.tick),
            _ => None,
        });
    }
    // The tick that takes the command stalls (nothing comes for the 2 s timeout); the
    // watchdog's NMI sends the safe frame, the reset follows 20 ms later. No keep-alive
    // frames now: they would reach the stalled board's receive path, which still runs.
    // A stalled board sends nothing: frames that still come more than 1 s after the
    // command say it was not taken (bytes can be lost on this link), and it goes again.
    // (Not sooner: bytes sent while the NMI holds the board wait in QEMU's chardev and
    // reach the next boot, which would stall too.)
    let stall = command(Command::InjectStall);
    q.send(&stall).unwrap();
    let mut sent = std::time::Instant::now();
    let safe = (0..10_000)
        .find_map(|_| match next_message(q) {
            Some(Message::Actuation(a)) if a.flags.has(Flags::SAFE) && a.tick == 0 => Some(a),
            _ => {
                if sent.elapsed() > std::time::Duration::from_secs(1) {
                    q.send(&stall).unwrap();
                    sent = std::time::Instant::now();
                }
                None
            }
        })
        .expect("the safe frame of the watchdog's NMI");
    assert!(!safe.flags.has(Flags::ENABLED), "{safe:?}");
    assert_eq!((safe.t_psi_dnm, safe.u_a_cv), (0, 0));
    // The new boot ticks on its own: its counter restarts (the host notices the reset by
    // that) and it reports the latched fault.
    let seq = seq0 + 100;
    let first = await_message(q, &sensor(seq), seq, 2_000, |m| match m {
        Message::Actuation(a) if a.seq_echo == seq => Some(*a),
        _ => None,
    });
    (last_tick, first, free_status(q, seq))
}

#[test]
fn a_stalled_control_task_trips_the_watchdog_and_the_board_rejoins() {
    let Some(mut q) = common::start_cfg_or_skip("watchdog reset", &QemuConfig::free_running())
    else {
        return;
    };
    let s = free_status(&mut q, 0);
    assert_eq!((s.boot_count, s.reset_cause), (1, reset_cause::POWER_ON));
    let (last, first, s) = stall_and_rejoin(&mut q, 1);
    // A new boot: its tick counter restarted below the one before the stall, the record
    // counts the second boot, the cause is the watchdog, and the fault is latched.
    assert!(first.tick < last, "tick {} after {last}", first.tick);
    assert!(first.flags.has(Flags::FAULT_LATCHED), "{:?}", first.flags);
    assert_eq!((s.boot_count, s.reset_cause), (2, reset_cause::WATCHDOG));
    assert!(s.flags.has(Flags::FAULT_LATCHED));
    // ClearFaults clears the latch; the loop goes on (the new boot's watchdog is fed).
    let a = await_message(
        &mut q,
        &command(Command::ClearFaults),
        200,
        2_000,
        |m| match m {
            Message::Actuation(a) if !a.flags.has(Flags::FAULT_LATCHED) => Some(*a),
            _ => None,
        },
    );
    assert!(a.tick > first.tick, "{a:?}");
    // Fed since: no reset in between, the latch stays clear.
    let s = free_status(&mut q, 200);
    assert_eq!(s.boot_count, 2);
    assert!(!s.flags.has(Flags::FAULT_LATCHED));
    // A second stall: boot 3.
    let (_, _, s) = stall_and_rejoin(&mut q, 300);
    assert_eq!((s.boot_count, s.reset_cause), (3, reset_cause::WATCHDOG));
}

#[test]
fn a_hardfault_drives_the_safe_outputs_and_resets() {
    let Some(mut q) = common::start_cfg_or_skip("hardfault reset", &QemuConfig::new()) else {
        return;
    };
    let (first, s) = fault_and_rejoin(&mut q, Command::InjectHardFault);
    assert_eq!(first.tick, 1, "{first:?}");
    assert_eq!((s.boot_count, s.reset_cause), (2, reset_cause::FAULT));
    assert!(s.flags.has(Flags::FAULT_LATCHED));
}

/// A Sensor frame of a driven wheelset: `y'` 1 mm/s, the motor at 925.6 rad/s, a
/// demand of 5 000 N m, the vehicle at 83.3 m/s.
fn driving(seq: u16) -> Vec<u8> {
    encode_vec(&Message::Sensor(wheelset_proto::Sensor {
        seq,
        t_us: seq.wrapping_mul(200),
        lateral: wheelset_proto::Lateral::Velocity(1_000),
        i_a_ma: 0,
        omega_m_mrad_s: 925_600,
        demand_nm: 5_000,
        v_ref_mm_s: 83_304,
    }))
    .unwrap()
    .to_vec()
}

/// The Actuation of one lock-step exchange.
fn actuation(q: &mut Qemu, bytes: &[u8]) -> Actuation {
    match exchange(q, bytes, 1).first() {
        Some(Message::Actuation(a)) => *a,
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_device_that_has_just_crashed_drives_the_safe_outputs_until_clear_faults() {
    let Some(mut q) = common::start_cfg_or_skip("safe after a fault", &QemuConfig::new()) else {
        return;
    };
    // Before the fault the same frame gets the lead's torque.
    let live = actuation(&mut q, &driving(1));
    assert!(live.t_psi_dnm.abs() > 1_000, "{live:?}");
    let (first, s) = fault_and_rejoin(&mut q, Command::InjectHardFault);
    assert_eq!((s.boot_count, s.reset_cause), (2, reset_cause::FAULT));
    // The new boot: the safe state from its first tick, zero torque, zero current (the
    // back-EMF K_m omega = 3 961.57 V of the received speed), the fault latched.
    assert!(first.flags.has(Flags::SAFE) && first.flags.has(Flags::FAULT_LATCHED));
    assert_eq!(first.t_psi_dnm, 0, "{first:?}");
    assert!((first.u_a_cv - 396_157).abs() <= 1, "{first:?}");
    // The host's Config (new rates too, as `hil run` sends after a reset) does not end it.
    let a = actuation(&mut q, &common::config_at(5_000));
    assert!(!a.flags.has(Flags::CMD_REFUSED), "{a:?}");
    for k in 101..=300u16 {
        let a = actuation(&mut q, &driving(k));
        assert!(a.flags.has(Flags::SAFE), "tick {k}: {a:?}");
        assert_eq!(a.t_psi_dnm, 0, "tick {k}: {a:?}");
        assert!((a.u_a_cv - 396_157).abs() <= 1, "tick {k}: {a:?}");
    }
    // Acknowledged: the latch and the safe state end; the torque limit ramps up from
    // zero at the safe ramp's 40 N m per tick, to the lead's torque.
    let a = actuation(
        &mut q,
        &encode_vec(&Message::Command(Command::ClearFaults)).unwrap(),
    );
    let mut last = a.t_psi_dnm;
    assert!(last.abs() <= 400, "{a:?}");
    for k in 301..=400u16 {
        let a = actuation(&mut q, &driving(k));
        assert!(!a.flags.has(Flags::SAFE) && !a.flags.has(Flags::FAULT_LATCHED));
        assert!((a.t_psi_dnm - last).abs() <= 400, "tick {k}: {a:?}");
        last = a.t_psi_dnm;
    }
    assert!(last.abs() > 1_000, "the torque is back: {last}");
    let s = status(&mut q);
    assert_eq!((s.safe_entries, s.safe_exits), (1, 1));
}

#[test]
fn the_lock_step_build_refuses_a_stall_it_could_not_end() {
    let Some(mut q) = common::start_cfg_or_skip("stall refused", &QemuConfig::new()) else {
        return;
    };
    for k in 1..=5 {
        exchange(&mut q, &sensor(k), 1);
    }
    // No watchdog in this build: InjectStall is refused, and the device goes on.
    let a = actuation(&mut q, &command(Command::InjectStall));
    assert!(a.flags.has(Flags::CMD_REFUSED), "{a:?}");
    let a = actuation(&mut q, &sensor(6));
    assert_eq!(a.seq_echo, 6);
    let s = status(&mut q);
    assert_eq!(
        s.refuse_reason,
        wheelset_proto::RefuseReason::Unsupported.code()
    );
    assert_eq!((s.cmd_refused, s.boot_count), (1, 1));
}
