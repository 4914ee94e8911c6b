//! The rate bug under QEMU (issue 14): the `wheelset-qemu` firmware refuses a Config
//! whose base period is not a whole number of microseconds (3 kHz: 333.3 us), flags it
//! (`CMD_REFUSED`), counts it (Status `cmd_refused`) and keeps ticking at its 5 kHz;
//! a plausible 4 kHz Config is then accepted. Skips when QEMU or the ELF is missing,
//! unless `REQUIRE_QEMU=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use hil::qemu::{Qemu, QemuConfig};
use wheelset_proto::{
    encode_vec, Actuation, Command, Config, Decoder, Flags, Lateral, Message, Sensor, YawMode,
};
use wheelset_runtime::{rates_for, RuntimeConfig, DEFAULT_HOLD_TICKS};

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

/// Sends one frame (its delimiter clocks one device tick) and returns every message the
/// device sent for that tick (the Actuation, and a Status if one was requested).
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

fn actuation(m: &[Message]) -> Actuation {
    match m.first() {
        Some(Message::Actuation(a)) => *a,
        other => panic!("expected an actuation frame, got {other:?}"),
    }
}

fn config_at(hz: u32) -> Vec<u8> {
    let mut rt = RuntimeConfig::default();
    rt.control.base_rate_hz = hz;
    let rates = rates_for::<wheelset_control::Fx>(&rt).expect("the host computes them");
    encode_vec(&Message::Config(Config {
        mode: YawMode::Lead,
        traction: true,
        enable: true,
        hold_ticks: DEFAULT_HOLD_TICKS,
        rates: Some(rates),
        monitor_safe: false,
        wsp: false,
    }))
    .unwrap()
    .to_vec()
}

#[test]
fn the_qemu_firmware_refuses_a_period_it_cannot_honour() {
    let Some(mut q) = start_or_skip("3 kHz refused") else {
        return;
    };
    for k in 1..=5 {
        let a = actuation(&exchange(&mut q, &sensor(k), 1));
        assert!(!a.flags.has(Flags::CMD_REFUSED));
    }
    // 3 kHz: refused; the device keeps its 5 kHz core.
    let a = actuation(&exchange(&mut q, &config_at(3_000), 1));
    assert!(
        a.flags.has(Flags::CMD_REFUSED),
        "3 kHz accepted: {:?}",
        a.flags
    );
    let a = actuation(&exchange(&mut q, &sensor(6), 1));
    assert!(a.flags.has(Flags::CMD_REFUSED) && a.flags.has(Flags::ENABLED));
    assert_eq!(a.seq_echo, 6);
    let st = exchange(
        &mut q,
        &encode_vec(&Message::Command(Command::RequestStatus)).unwrap(),
        2,
    );
    let Some(Message::Status(s)) = st.get(1) else {
        panic!("{st:?}")
    };
    assert_eq!(s.cmd_refused, 1);
    assert_eq!(s.rx_postcard + s.rx_crc + s.rx_length, 0);
    // A rate the ticker can honour is taken (4 kHz = 250 us): the flag clears.
    let a = actuation(&exchange(&mut q, &config_at(4_000), 1));
    assert!(
        !a.flags.has(Flags::CMD_REFUSED),
        "4 kHz refused: {:?}",
        a.flags
    );
}
