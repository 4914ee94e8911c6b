//! The QEMU firmware's two channels against each other: UART0 over TCP (the faithful
//! path, byte by byte through the emulated UART) and the semihosting bulk channel (one
//! trap per frame, firmware/app/src/board/qemu/bulk.rs). The same closed loop through
//! each gives the same Actuation frames (`exec` included) and the same plant trajectory,
//! record for record. Skips when QEMU or the ELF is missing, unless `REQUIRE_QEMU=1`.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use common::{qemu_curve, start_or_skip};
use wheelset_plant::sim::Trajectory;
use wheelset_proto::Actuation;
use wheelset_targets::qemu::Channel;

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

/// Adhesion-limited traction under QEMU: `hil run --target qemu --qemu-link bulk --scenario low-adhesion`,
/// the firmware's wheel-slip protection in the loop for the 20 s (100 000 exchanges over
/// the bulk channel, about 8 s of wall time in release), passes its numerics against the
/// f64 core with protection, and its closed loop is the in-process one record for record.
#[test]
fn low_adhesion_under_qemu_passes_its_numerics_and_is_the_in_process_loop() {
    use hil::run::{run, RunOptions, Target};
    use wheelset_report::Verdict;
    let cfg = wheelset_targets::qemu::QemuConfig {
        channel: Channel::Bulk,
        ..wheelset_targets::qemu::QemuConfig::new()
    };
    if !common::can_run("low-adhesion over the bulk channel", &cfg) {
        return;
    }
    let opts = RunOptions {
        target: Target::Qemu,
        qemu_link: Channel::Bulk,
        scenario: "low-adhesion".into(),
        ..RunOptions::default()
    };
    let qemu = run(&opts).expect("the QEMU run is made");
    let n = &qemu.report.numerics;
    assert_eq!(n.verdict, Verdict::Pass, "{n:?}");
    assert!(n.reference.contains("wsp on") && n.reference.contains("tube at 0.2 ms"));
    let st = qemu.report.device_status.expect("status frame");
    assert!(st.wsp_events >= 2, "{st:?}");
    let inproc = run(&RunOptions {
        scenario: "low-adhesion".into(),
        ..RunOptions::default()
    })
    .unwrap();
    assert_eq!(qemu.trajectory.records, inproc.trajectory.records);
    assert_eq!(qemu.report.numerics, inproc.report.numerics);
}

/// The closed loop of the harness (`wheelset_loop::exchange::close_loop`) through the
/// QEMU target: over the bulk channel with two exchanges in flight (the next Sensor
/// frame goes out before the answer to the last one) and over the UART with one. Every
/// Actuation frame (`exec` included) with its arrival stamp, every period and link
/// record, the device's counters and the plant's trajectory are the same.
#[test]
fn two_exchanges_in_flight_over_the_bulk_channel_are_the_uart_s_loop() {
    use std::time::Duration;
    use wheelset_loop::exchange::{close_loop, ClosedLoop, LoopSetup};
    use wheelset_loop::transport::Transport;
    use wheelset_plant::params::Params;
    use wheelset_plant::scenario::Scenario;
    use wheelset_targets::qemu::{target::QemuTarget, Machine, QemuConfig};
    let cfg = QemuConfig::new();
    if !common::can_run("two exchanges in flight", &cfg) {
        return;
    }
    let mut sc = Scenario::load("curve", &Params::default()).unwrap();
    sc.duration_ns = 400_000_000;
    let period_ns = 1_000_000_000 / u64::from(wheelset_control::DEFAULT_BASE_RATE_HZ);
    let run = |channel| -> (ClosedLoop, bool) {
        let mut t = QemuTarget::start_with(
            Machine::default(),
            channel,
            1_000_000,
            168e6,
            Duration::from_secs(10),
        )
        .unwrap();
        let pipelined = t.pipelined();
        let cl = close_loop(
            &sc,
            &mut t,
            LoopSetup {
                period_ns,
                yaw_spring: false,
                label: "lead",
                ..LoopSetup::default()
            },
        )
        .unwrap();
        assert!(cl.rec.error.is_none(), "{:?}", cl.rec.error);
        (cl, pipelined)
    };
    let (bulk, pipelined) = run(Channel::Bulk);
    let (uart, one) = run(Channel::Uart);
    assert!(!one);
    if std::env::var("WHEELSET_QEMU_IN_FLIGHT").as_deref() != Ok("1") {
        assert!(pipelined, "the bulk channel keeps two exchanges in flight");
    }
    // 2 000 Sensor frames, then the tick of the status request.
    assert_eq!(bulk.rec.actuations.len(), 2_001);
    assert!(bulk.rec.actuations.iter().any(|a| a.frame.exec != 0));
    assert_eq!(bulk.rec.actuations, uart.rec.actuations);
    assert_eq!(bulk.rec.periods, uart.rec.periods);
    assert_eq!(bulk.rec.log, uart.rec.log);
    assert_eq!(bulk.rec.host, uart.rec.host);
    // The Status's counters; its stack mark is the channel's own (the bulk receiver's
    // buffer is on thread mode's stack, under the tick's interrupt frames).
    let counters = |s: Option<wheelset_proto::Status>| {
        s.map(|s| wheelset_proto::Status { stack_peak: 0, ..s })
    };
    assert_eq!(counters(bulk.rec.status), counters(uart.rec.status));
    assert_eq!(bulk.trajectory.records, uart.trajectory.records);
    assert_eq!(
        bulk.trajectory.info.controller_calls,
        uart.trajectory.info.controller_calls
    );
}

/// A firmware change that must not change a bit: the 20 s `curve` through this ELF and
/// through another build (`WHEELSET_QEMU_ELF_BEFORE`, e.g. `target/fw/wheelset-qemu.elf`
/// of an earlier commit) over the bulk channel, every Actuation frame (`exec` included)
/// and trajectory record compared. `WHEELSET_QEMU_ELF_BEFORE=OLD.elf cargo test --release
/// -p hil --test qemu_bulk -- --ignored --nocapture same_frames`
#[test]
#[ignore = "needs WHEELSET_QEMU_ELF_BEFORE; 20 s scenario twice: run by hand"]
fn same_frames_as_another_build() {
    let Some(before) = std::env::var_os("WHEELSET_QEMU_ELF_BEFORE") else {
        panic!("set WHEELSET_QEMU_ELF_BEFORE to the other build's ELF");
    };
    let cfg = |elf| wheelset_targets::qemu::QemuConfig {
        channel: Channel::Bulk,
        elf,
        ..wheelset_targets::qemu::QemuConfig::new()
    };
    let this = cfg(wheelset_targets::qemu::QemuConfig::default_elf());
    let (Some(a), Some(b)) = (
        common::start_cfg_or_skip("this build", &this),
        common::start_cfg_or_skip("the other build", &cfg(before.into())),
    ) else {
        return;
    };
    let a = qemu_curve(a, 20.0);
    let b = qemu_curve(b, 20.0);
    assert_eq!(a.1.len(), 100_000);
    assert_same(&a, &b);
}
