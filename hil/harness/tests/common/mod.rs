//! The QEMU tests' driver: whether the emulated device can run here ([`can_run`], every
//! `qemu_*` test), starting it or skipping (`qemu_smoke`, `qemu_bulk`), one lock-step tick, and the device as the plant's sampled controller over
//! a run of `curve`.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use wheelset_plant::control::{
    Actuation as PlantActuation, Measurements, SampledController, YawLaw,
};
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::{run_sampled, ActuatorModel, SensorModel, Trajectory};
use wheelset_proto::units::{
    quantize, to_si, CURRENT_LSB_A, DEMAND_LSB_NM, LAT_VEL_LSB_M_PER_S, SPEED_LSB_RAD_PER_S,
    TORQUE_LSB_NM, VOLTAGE_LSB_V,
};
use wheelset_proto::{encode_vec, Actuation, Command, Decoder, Lateral, Message, Sensor, Status};
use wheelset_targets::qemu::{Channel, Qemu, QemuConfig};

/// Whether QEMU and the firmware of `cfg` can run here: `false` (skip, said on stderr)
/// when they cannot and the run does not require them; a failure when `REQUIRE_QEMU=1`
/// (set by `cargo xtest` when QEMU is installed).
pub fn can_run(test: &str, cfg: &QemuConfig) -> bool {
    match cfg.check() {
        Ok(()) => true,
        Err(e) if std::env::var("REQUIRE_QEMU").as_deref() == Ok("1") => {
            panic!("{test}: REQUIRE_QEMU=1 but the emulated device cannot run: {e}")
        }
        Err(e) => {
            eprintln!("{test}: SKIPPED: {e}");
            false
        }
    }
}

/// Starts the emulated device of `cfg`, or `None` (skip, [`can_run`]).
pub fn start_cfg_or_skip(test: &str, cfg: &QemuConfig) -> Option<Qemu> {
    if !can_run(test, cfg) {
        return None;
    }
    Some(Qemu::start(cfg).unwrap_or_else(|e| panic!("{test}: {e}")))
}

/// Starts the emulated device on `channel`, or `None` (skip, [`can_run`]).
pub fn start_or_skip(test: &str, channel: Channel) -> Option<Qemu> {
    let cfg = QemuConfig {
        channel,
        ..QemuConfig::new()
    };
    start_cfg_or_skip(test, &cfg)
}

/// A Sensor frame `seq` of a wheelset at speed (motor 925.6 rad/s), no demand, 1 mm/s
/// lateral velocity: a still input for the board tests.
pub fn sensor(seq: u16) -> Vec<u8> {
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

/// Sends `bytes` and returns the next `frames` messages the device sends.
pub fn exchange(q: &mut Qemu, bytes: &[u8], frames: usize) -> Vec<Message> {
    q.send(bytes).unwrap();
    let mut dec: Decoder = Decoder::new();
    let mut out = Vec::new();
    for _ in 0..frames {
        let f = [q.recv_frame().unwrap(), vec![0]].concat();
        if let Some(r) = dec.next_message(&f).0 {
            out.push(r.expect("a valid frame from the device"));
        }
    }
    out
}

/// The device's Status (a `RequestStatus`: its tick's Actuation, then the Status).
pub fn status(q: &mut Qemu) -> Status {
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

/// One tick: sends `bytes` (a frame, or a bare delimiter for a tick without one) and
/// returns the device's actuation frame.
pub fn tick(q: &mut Qemu, dec: &mut Decoder, bytes: &[u8]) -> Actuation {
    q.send(bytes).unwrap();
    let mut frame = q.recv_frame().unwrap();
    frame.push(0);
    match dec.next_message(&frame).0 {
        Some(Ok(Message::Actuation(a))) => a,
        other => panic!("expected an actuation frame, got {other:?}"),
    }
}

/// The emulated device as the plant's sampled controller: one lock-step exchange per
/// control period (the Sensor frame is the device's clock).
pub struct QemuDevice {
    q: Qemu,
    dec: Decoder,
    seq: u16,
    period_ns: u64,
    actuations: Vec<Actuation>,
}

impl SampledController for QemuDevice {
    fn period_ns(&self) -> u64 {
        self.period_ns
    }

    fn step(&mut self, t_ns: u64, m: &Measurements) -> PlantActuation {
        self.seq = self.seq.wrapping_add(1);
        let s = Sensor {
            seq: self.seq,
            t_us: ((t_ns / 1_000) & 0xffff) as u16,
            lateral: Lateral::Velocity(quantize(m.yd_mps, LAT_VEL_LSB_M_PER_S).0),
            i_a_ma: quantize(m.i_a, CURRENT_LSB_A).0,
            omega_m_mrad_s: quantize(m.w_m, SPEED_LSB_RAD_PER_S).0,
            demand_nm: quantize(m.demand_nm, DEMAND_LSB_NM).0,
            v_ref_mm_s: 0,
        };
        let frame = encode_vec(&Message::Sensor(s)).unwrap();
        let a = tick(&mut self.q, &mut self.dec, &frame);
        self.actuations.push(a);
        PlantActuation {
            t_psi: to_si(a.t_psi_dnm, TORQUE_LSB_NM),
            u_a: to_si(a.u_a_cv, VOLTAGE_LSB_V),
        }
    }
}

/// Runs `duration_s` of the `curve` scenario with the phase lead, the emulated device in
/// the loop. Returns the trajectory and the device's actuation frames.
pub fn qemu_curve(q: Qemu, duration_s: f64) -> (Trajectory, Vec<Actuation>) {
    let mut sc = Scenario::load("curve", &Params::default()).unwrap();
    sc.duration_ns = (duration_s * 1e9) as u64;
    let period_ns = 1_000_000_000 / u64::from(wheelset_control::DEFAULT_BASE_RATE_HZ);
    let mut dev = QemuDevice {
        q,
        dec: Decoder::new(),
        seq: 0,
        period_ns,
        actuations: Vec::new(),
    };
    let mut actuator = ActuatorModel::ideal();
    actuator.delay_ns = period_ns;
    let traj = run_sampled(
        &sc,
        &mut dev,
        &mut SensorModel::ideal(),
        &mut actuator,
        YawLaw::Lead.has_spring(),
        "lead (QEMU device)",
    )
    .unwrap();
    (traj, dev.actuations)
}

/// A Config frame for the fixed-point core at base rate `hz` (lead law, traction on,
/// outputs enabled, the default hold), its rates as the host computes them.
pub fn config_at(hz: u32) -> Vec<u8> {
    // The design for the rate where there is one; else the paper's gains re-discretised
    // (what a device refuses).
    let rt = wheelset_runtime::RuntimeConfig::default();
    let rt = rt.designed(hz, 1).unwrap_or_else(|_| {
        let mut r = rt;
        r.control.base_rate_hz = hz;
        r
    });
    let rates =
        wheelset_runtime::rates_for::<wheelset_control::Fx>(&rt).expect("the host computes them");
    encode_vec(&Message::Config(wheelset_proto::Config {
        mode: wheelset_proto::YawMode::Lead,
        traction: true,
        enable: true,
        hold_ticks: wheelset_runtime::DEFAULT_HOLD_TICKS,
        rates: Some(rates),
        monitor_safe: false,
        wsp: false,
    }))
    .unwrap()
    .to_vec()
}

/// Whether this run judges timing bars (`JUDGE_TIMING=1`, by hand on a quiet machine).
/// The suite itself asserts what a run does, never how fast a shared machine did it: the
/// timing figures are printed always and asserted only on request.
pub fn judge_timing() -> bool {
    std::env::var("JUDGE_TIMING").is_ok_and(|v| v == "1")
}

/// `hil serve --pty` started as a powered board is, before the host: its pseudo-terminal
/// and its JSON report (`extra`: more `hil serve` options, such as a bridge model).
pub struct StandIn {
    child: std::process::Child,
    /// The pseudo-terminal it serves.
    pub path: String,
    report: std::path::PathBuf,
}

impl StandIn {
    /// Starts it at `rate_hz` for `duration_s`; `tag` names its report file.
    pub fn start(rate_hz: u32, duration_s: f64, tag: &str, extra: &[&str]) -> Self {
        use std::io::BufRead;
        let report =
            std::env::temp_dir().join(format!("hil-serve-{tag}-{}.json", std::process::id()));
        let mut child = std::process::Command::new(env!("CARGO_BIN_EXE_hil"))
            .args(["serve", "--pty", "--rate-hz", &rate_hz.to_string()])
            .args(["--duration-s", &duration_s.to_string()])
            .args(extra)
            .arg("--json")
            .arg(&report)
            .stdout(std::process::Stdio::piped())
            .stderr(std::process::Stdio::null())
            .spawn()
            .expect("hil serve starts");
        let mut line = String::new();
        std::io::BufReader::new(child.stdout.take().expect("stdout"))
            .read_line(&mut line)
            .expect("hil serve prints its pty");
        Self {
            child,
            path: line.trim().to_string(),
            report,
        }
    }

    /// Waits for its end (it must succeed) and returns its report.
    pub fn finish(mut self) -> serde_json::Value {
        let status = self.child.wait().expect("hil serve ends");
        assert!(status.success(), "hil serve: {status}");
        let text = std::fs::read_to_string(&self.report).expect("the stand-in's report");
        let _ = std::fs::remove_file(&self.report);
        serde_json::from_str(&text).expect("JSON")
    }
}
