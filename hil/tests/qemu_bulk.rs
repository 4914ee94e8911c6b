//! The QEMU firmware's two channels against each other: UART0 over TCP (the faithful
//! path, byte by byte through the emulated UART) and the semihosting bulk channel (one
//! trap per frame, firmware/app/src/board/qemu/bulk.rs). The same closed loop through
//! each gives the same Actuation frames (`exec` included) and the same plant trajectory,
//! record for record. Skips when QEMU or the ELF is missing, unless `REQUIRE_QEMU=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use hil::qemu::{Channel, Qemu, QemuConfig};
use sim_host::control::{Actuation as PlantActuation, Measurements, SampledController, YawLaw};
use sim_host::params::Params;
use sim_host::scenario::Scenario;
use sim_host::sim::{run_sampled, ActuatorModel, SensorModel, Trajectory};
use wheelset_proto::units::{
    quantize, to_si, CURRENT_LSB_A, DEMAND_LSB_NM, LAT_VEL_LSB_M_PER_S, SPEED_LSB_RAD_PER_S,
    TORQUE_LSB_NM, VOLTAGE_LSB_V,
};
use wheelset_proto::{encode_vec, Actuation, Decoder, Lateral, Message, Sensor};

/// Starts the emulated device on `channel`, or `None` (skip) when it cannot run here and
/// the run does not require it.
fn start_or_skip(test: &str, channel: Channel) -> Option<Qemu> {
    let cfg = QemuConfig {
        channel,
        ..QemuConfig::new()
    };
    if let Err(e) = cfg.check() {
        if std::env::var("REQUIRE_QEMU").as_deref() == Ok("1") {
            panic!("{test}: REQUIRE_QEMU=1 but the emulated device cannot run: {e}");
        }
        eprintln!("{test}: SKIPPED: {e}");
        return None;
    }
    match Qemu::start(&cfg) {
        Ok(q) => Some(q),
        Err(e) => panic!("{test}: {e}"),
    }
}

/// The emulated device as the plant's sampled controller, one lock-step exchange per
/// control period.
struct QemuDevice {
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
        self.q
            .send(&encode_vec(&Message::Sensor(s)).unwrap())
            .unwrap();
        let mut frame = self.q.recv_frame().unwrap();
        frame.push(0);
        let mut out = None;
        self.dec.feed(&frame, |r| out = Some(r));
        let Some(Ok(Message::Actuation(a))) = out else {
            panic!("expected an actuation frame, got {out:?}");
        };
        self.actuations.push(a);
        PlantActuation {
            t_psi: to_si(a.t_psi_dnm, TORQUE_LSB_NM),
            u_a: to_si(a.u_a_cv, VOLTAGE_LSB_V),
        }
    }
}

/// `duration_s` of `curve` with the phase lead, the emulated device in the loop.
fn qemu_curve(q: Qemu, duration_s: f64) -> (Trajectory, Vec<Actuation>) {
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

/// Record for record, every field, exactly (`{:?}` of an `f64` is exact).
fn assert_same(a: &(Trajectory, Vec<Actuation>), b: &(Trajectory, Vec<Actuation>)) {
    assert_eq!(a.1.len(), b.1.len());
    for (k, (x, y)) in a.1.iter().zip(&b.1).enumerate() {
        assert_eq!(x, y, "actuation frame {k}");
    }
    assert_eq!(a.0.records.len(), b.0.records.len());
    for (k, (x, y)) in a.0.records.iter().zip(&b.0.records).enumerate() {
        assert_eq!(format!("{x:?}"), format!("{y:?}"), "trajectory record {k}");
    }
}

#[test]
fn the_bulk_channel_gives_the_uart_s_frames_and_trajectory_bit_for_bit() {
    let (Some(uart), Some(bulk)) = (
        start_or_skip("uart", Channel::Uart),
        start_or_skip("bulk", Channel::Bulk),
    ) else {
        return;
    };
    // 0.4 s = 2 000 ticks at 5 kHz: the first 0.4 s of `curve`, the loops starting
    // from rest (the frames change every tick).
    let t0 = std::time::Instant::now();
    let u = qemu_curve(uart, 0.4);
    let t_uart = t0.elapsed().as_secs_f64();
    let t0 = std::time::Instant::now();
    let b = qemu_curve(bulk, 0.4);
    let t_bulk = t0.elapsed().as_secs_f64();
    eprintln!("0.4 s of curve: UART {t_uart:.2} s wall, bulk {t_bulk:.2} s wall");
    assert_eq!(u.1.len(), 2_000);
    assert!(u.1.iter().any(|a| a.t_psi_dnm != 0) && u.1.iter().any(|a| a.exec != 0));
    assert_same(&u, &b);
}

/// The README's wall-time figure for the bulk channel: the 20 s `curve` run at the
/// default rate, lock-step, compared record for record with the UART run (which takes
/// about a minute more). `cargo test --release -p hil --test qemu_bulk -- --ignored
/// --nocapture`
#[test]
#[ignore = "20 s scenario twice (100 000 exchanges each): a measurement, run by hand"]
fn curve_20_s_over_the_bulk_channel() {
    let (Some(bulk), Some(uart)) = (
        start_or_skip("bulk", Channel::Bulk),
        start_or_skip("uart", Channel::Uart),
    ) else {
        return;
    };
    let t0 = std::time::Instant::now();
    let b = qemu_curve(bulk, 20.0);
    let wall = t0.elapsed().as_secs_f64();
    eprintln!(
        "20 s curve through QEMU over the bulk channel: {} exchanges in {wall:.1} s wall ({:.0} per s)",
        b.1.len(),
        b.1.len() as f64 / wall
    );
    assert_eq!(b.1.len(), 100_000);
    let t0 = std::time::Instant::now();
    let u = qemu_curve(uart, 20.0);
    eprintln!(
        "the same over the UART: {:.1} s wall",
        t0.elapsed().as_secs_f64()
    );
    assert_same(&u, &b);
}
