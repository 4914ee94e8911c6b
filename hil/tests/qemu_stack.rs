//! The board's stack high-water mark under QEMU (issue 13): the `wheelset-qemu` firmware
//! paints its stack at the control task's start and reads the mark every
//! `SCAN_TICKS` ticks into `Status.stack_peak` (`firmware/app/src/stack.rs`). Skips
//! when QEMU or the ELF is missing, unless `REQUIRE_QEMU=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use hil::qemu::{Qemu, QemuConfig};
use wheelset_proto::{encode_vec, Command, Decoder, Lateral, Message, Sensor, Status};

/// `firmware/app/src/stack.rs`: the mark is read every this many ticks.
const SCAN_TICKS: u16 = 1024;
/// `firmware/app/src/stack.rs`: bytes painted below the stack pointer.
const WINDOW: u32 = 16 * 1024;

fn start_or_skip(test: &str) -> Option<Qemu> {
    let cfg = QemuConfig::new();
    if let Err(e) = cfg.check() {
        if std::env::var("REQUIRE_QEMU").as_deref() == Ok("1") {
            panic!("{test}: REQUIRE_QEMU=1 but the emulated device cannot run: {e}");
        }
        eprintln!("{test}: SKIPPED: {e}");
        return None;
    }
    Some(Qemu::start(&cfg).unwrap_or_else(|e| panic!("{test}: {e}")))
}

fn sensor(seq: u16) -> Vec<u8> {
    encode_vec(&Message::Sensor(Sensor {
        seq,
        t_us: seq.wrapping_mul(200),
        lateral: Lateral::Velocity(1_000),
        i_a_ma: 0,
        omega_m_mrad_s: 925_600,
        demand_nm: 0,
        v_ref_mm_s: 0,
    }))
    .unwrap()
    .to_vec()
}

/// Sends bytes ending in one delimiter (one device tick) and returns the `frames`
/// messages the device sent for it.
fn exchange(q: &mut Qemu, bytes: &[u8], frames: usize) -> Vec<Message> {
    q.send(bytes).unwrap();
    let mut dec: Decoder = Decoder::new();
    let mut out = Vec::new();
    for _ in 0..frames {
        let mut f = q.recv_frame().unwrap();
        f.push(0);
        dec.feed(&f, |r| out.push(r.expect("a valid frame from the device")));
    }
    out
}

fn status(q: &mut Qemu) -> Status {
    let m = exchange(
        q,
        &encode_vec(&Message::Command(Command::RequestStatus)).unwrap(),
        2,
    );
    match m.get(1) {
        Some(Message::Status(s)) => *s,
        other => panic!("expected a Status, got {other:?}"),
    }
}

#[test]
fn the_qemu_board_reports_its_stack_high_water_mark() {
    let Some(mut q) = start_or_skip("stack peak") else {
        return;
    };
    for k in 1..=5 {
        exchange(&mut q, &sensor(k), 1);
    }
    // Before the first scan the Status has no mark yet.
    assert_eq!(status(&mut q).stack_peak, 0);
    for k in 7..SCAN_TICKS + 16 {
        exchange(&mut q, &sensor(k), 1);
    }
    let peak = status(&mut q).stack_peak;
    // Measured (the ticks ran on the painted stack) and inside the painted window (a
    // mark at the window's size would mean the stack went deeper than the paint).
    assert!(peak > 0, "stack peak {peak} B");
    assert!(
        peak < WINDOW,
        "stack peak {peak} B: the stack reached the window's bottom"
    );
    eprintln!("stack peak after {} ticks: {peak} B", SCAN_TICKS + 16);
}
