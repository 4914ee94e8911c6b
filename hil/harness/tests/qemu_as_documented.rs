//! What the wire crate's and the runtime's docs say, on the `wheelset-qemu` firmware
//! (lock-step, its UART), each next to the host runtime fed the same frames (one tick
//! per frame on both): the boot default (the wheel-slip protection and the stability
//! monitor on before any Config), `v_ref_mm_s = 0` as an unknown reference (the
//! protection idle), `CMD_REFUSED` marking the latest Config or Command, an undefined
//! Command index in a two-byte varint refused as an unknown request, and the `y''`-only
//! estimate floored to whole um/s. Skips when QEMU or the ELF is missing, unless
//! `REQUIRE_QEMU=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use wheelset_control::Fx;
use wheelset_proto::{
    encode_vec, frame_raw, Actuation, Command, Config, Decoder, Flags, Lateral, Message,
    RefuseReason, Sensor, Status, YawMode, MAX_FRAME, VERSION,
};
use wheelset_runtime::{Runtime, RuntimeConfig, DEFAULT_HOLD_TICKS};
use wheelset_targets::qemu::{Qemu, QemuConfig};

/// The emulated device and a host runtime at the firmware's default configuration.
struct Pair {
    q: Qemu,
    dec: Decoder,
    host: Runtime<Fx>,
}

impl Pair {
    fn start(test: &str) -> Option<Self> {
        let q = common::start_cfg_or_skip(test, &QemuConfig::new())?;
        Some(Self {
            q,
            dec: Decoder::new(),
            host: Runtime::try_new(RuntimeConfig::default()).unwrap(),
        })
    }

    /// One frame to the device and `host_frame` to the host runtime, one tick each:
    /// their Actuations.
    fn step_with(&mut self, frame: &[u8], host_frame: &[u8]) -> (Actuation, Actuation) {
        let d = common::tick(&mut self.q, &mut self.dec, frame);
        self.host.receive(host_frame);
        (d, self.host_tick())
    }

    /// The host runtime's tick: its Actuation.
    fn host_tick(&mut self) -> Actuation {
        let mut dec: Decoder = Decoder::new();
        let first = dec.messages(self.host.tick(0)).find_map(|r| match r {
            Ok(Message::Actuation(a)) => Some(a),
            _ => None,
        });
        first.expect("the host's Actuation")
    }

    /// The same frame to both.
    fn step(&mut self, frame: &[u8]) -> (Actuation, Actuation) {
        self.step_with(frame, frame)
    }

    /// The device's Status (the request goes to the host too, so both tick on it).
    fn status(&mut self) -> Status {
        let s = common::status(&mut self.q);
        self.host.receive(&command(Command::RequestStatus));
        self.host_tick();
        s
    }
}

/// The same outputs and flags (the execution time aside).
fn same(d: &Actuation, h: &Actuation, what: &str) {
    assert_eq!(
        (d.flags, d.t_psi_dnm, d.u_a_cv),
        (h.flags, h.t_psi_dnm, h.u_a_cv),
        "{what}: device {d:?}, host {h:?}"
    );
}

/// A Sensor frame: `y'` 1 mm/s, the motor at 925.6 rad/s (83.3 m/s at the rim), a
/// demand of 5 000 N m, the reference speed `v_ref_mm_s`.
fn driving(seq: u16, v_ref_mm_s: i32) -> Vec<u8> {
    frame(Sensor {
        seq,
        t_us: seq.wrapping_mul(200),
        lateral: Lateral::Velocity(1_000),
        i_a_ma: 0,
        omega_m_mrad_s: 925_600,
        demand_nm: 5_000,
        v_ref_mm_s,
    })
}

fn frame(s: Sensor) -> Vec<u8> {
    encode_vec(&Message::Sensor(s)).unwrap().to_vec()
}

fn config(wsp: bool, hold_ticks: u16) -> Vec<u8> {
    encode_vec(&Message::Config(Config {
        mode: YawMode::Lead,
        traction: true,
        enable: true,
        hold_ticks,
        wsp,
        monitor_safe: false,
        rates: None,
    }))
    .unwrap()
    .to_vec()
}

fn command(c: Command) -> Vec<u8> {
    encode_vec(&Message::Command(c)).unwrap().to_vec()
}

#[test]
fn an_unknown_reference_speed_leaves_the_protection_idle_on_the_device() {
    let Some(mut p) = Pair::start("v_ref 0") else {
        return;
    };
    // The protection on (the device, by Config) against off (the host): at v_ref 0 the
    // outputs are the unprotected ones, no WHEEL_SLIP on any tick; at 83 333 mm/s
    // likewise (the wheel rolls).
    let (d, _) = p.step_with(
        &config(true, DEFAULT_HOLD_TICKS),
        &config(false, DEFAULT_HOLD_TICKS),
    );
    assert!(!d.flags.has(Flags::CMD_REFUSED));
    for (k, v_ref) in (1..=200u16).map(|k| (k, if k <= 100 { 0 } else { 83_333 })) {
        let (d, h) = p.step(&driving(k, v_ref));
        assert!(!d.flags.has(Flags::WHEEL_SLIP), "tick {k}, v_ref {v_ref}");
        same(&d, &h, &format!("tick {k}, v_ref {v_ref}"));
    }
    let s = p.status();
    assert_eq!((s.wsp_ticks, s.wsp_events), (0, 0));
    // Known, 1 mm/s (a vehicle known to stand): the same wheel slips, the device cuts.
    let (d, h) = p.step(&driving(201, 1));
    assert!(d.flags.has(Flags::WHEEL_SLIP), "{d:?}");
    assert!(!h.flags.has(Flags::WHEEL_SLIP), "the host has it off");
}

#[test]
fn the_device_boots_with_the_protection_and_the_monitor_on() {
    let Some(mut p) = Pair::start("boot default") else {
        return;
    };
    // No Config: an 8 Hz y' of 0.1 m/s (RMS 71 mm/s, above the monitor's 30 mm/s) at a
    // known reference speed, tick for tick as the host runtime's default.
    let mut hunting = None;
    for k in 1..=6_000u16 {
        let y = 100_000.0 * (2.0 * std::f64::consts::PI * 8.0 * f64::from(k) / 5_000.0).sin();
        let (d, h) = p.step(&frame(Sensor {
            seq: k,
            t_us: k.wrapping_mul(200),
            lateral: Lateral::Velocity(y as i32),
            i_a_ma: 0,
            omega_m_mrad_s: 925_600,
            demand_nm: 0,
            v_ref_mm_s: 83_304,
        }));
        same(&d, &h, &format!("tick {k}"));
        if d.flags.has(Flags::HUNTING) && hunting.is_none() {
            hunting = Some(k);
        }
    }
    let k = hunting.expect("the monitor raised the hunting alarm");
    eprintln!("boot default: HUNTING from tick {k}");
    let s = p.status();
    assert!(
        s.hunt_alarms >= 1 && s.flags.has(Flags::FAULT_LATCHED),
        "{s:?}"
    );
    // Reported, not acted on (monitor_safe off at boot): the outputs stay live.
    assert!(!s.flags.has(Flags::SAFE));
    // The protection, on at boot: the wheel at 83.3 m/s against a vehicle at 70 m/s.
    let (d, h) = p.step(&driving(6_001, 70_000));
    assert!(d.flags.has(Flags::WHEEL_SLIP), "{d:?}");
    same(&d, &h, "the slip");
    assert_eq!(p.status().wsp_events, 1);
}

/// A Command frame whose variant index is the varint `index` (bytes as sent).
fn command_index(index: &[u8]) -> Vec<u8> {
    let mut raw = vec![VERSION, 3];
    raw.extend_from_slice(index);
    let mut out = vec![0u8; MAX_FRAME];
    let n = frame_raw(&raw, &mut out).unwrap();
    out.truncate(n);
    out
}

#[test]
fn cmd_refused_marks_the_latest_config_or_command_on_the_device() {
    let Some(mut p) = Pair::start("CMD_REFUSED") else {
        return;
    };
    let refused = config(true, u16::MAX);
    let flagged = |p: &mut Pair, f: &[u8]| {
        let (d, h) = p.step(f);
        same(&d, &h, &format!("{f:x?}"));
        d.flags.has(Flags::CMD_REFUSED)
    };
    assert!(!flagged(&mut p, &driving(1, 83_333)));
    assert!(flagged(&mut p, &refused));
    assert!(
        flagged(&mut p, &driving(2, 83_333)),
        "a Sensor frame is no request"
    );
    // An accepted Command clears it; the reason stays in the Status.
    assert!(!flagged(&mut p, &command(Command::ClearFaults)));
    let s = p.status();
    assert_eq!(s.refuse_reason, RefuseReason::HoldTicks.code());
    assert!(!s.flags.has(Flags::CMD_REFUSED));
    // RequestStatus, a read, leaves it: the Status that answers shows the refusal.
    assert!(flagged(&mut p, &refused));
    let s = p.status();
    assert!(s.flags.has(Flags::CMD_REFUSED), "{:?}", s.flags);
    // Index 200 (two varint bytes): an unknown request, refused, not a decoding error.
    assert!(!flagged(&mut p, &command(Command::ResetCounters)));
    assert!(flagged(&mut p, &command_index(&[0xC8, 0x01])));
    let s = p.status();
    assert_eq!(s.refuse_reason, RefuseReason::UnknownRequest.code());
    assert_eq!((s.cmd_refused, s.rx_postcard), (1, 0));
    // An accepted Config clears it.
    assert!(!flagged(&mut p, &config(true, DEFAULT_HOLD_TICKS)));
}

#[test]
fn the_integrated_velocity_reaches_the_lead_floored_to_whole_um_s_on_the_device() {
    let Some(mut p) = Pair::start("y'' floor") else {
        return;
    };
    let sensor = |seq: u16, lateral| {
        frame(Sensor {
            seq,
            t_us: seq.wrapping_mul(200),
            lateral,
            i_a_ma: 0,
            omega_m_mrad_s: 925_600,
            demand_nm: 0,
            v_ref_mm_s: 0,
        })
    };
    for k in 1..=10u16 {
        let (d, h) = p.step(&sensor(k, Lateral::Velocity(0)));
        same(&d, &h, "seed");
    }
    // `y''` = -1 code (-0.1 mm/s^2) on the device, `y'` = -1 um/s on the host: the
    // integrated -0.02 um/s per tick is floored to -1 um/s from the first tick, so the
    // yaw torque is the same (a rounding would give 0 um/s for 25 ticks, a truncation
    // for 50, and another torque).
    let mut moved = false;
    for k in 11..=40u16 {
        let (d, h) = p.step_with(
            &sensor(k, Lateral::Acceleration(-1)),
            &sensor(k, Lateral::Velocity(-1)),
        );
        assert_eq!(d.t_psi_dnm, h.t_psi_dnm, "tick {k}: {d:?} {h:?}");
        moved |= d.t_psi_dnm != 0;
    }
    assert!(moved, "one um/s moves the lead's torque");
}
