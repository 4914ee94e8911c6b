//! The serial-port transport closes the loop over a pseudo-terminal pair, with the
//! firmware's runtime answering on the other end (frame-clocked, lock-step).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use hil::budget::Verdict;
use hil::run::{run, RunOptions, Target};
use hil::serial::{serve_lockstep, Pace};
use serialport::{SerialPort, TTYPort};
use wheelset_control::Fx;
use wheelset_runtime::{Runtime, RuntimeConfig};

#[test]
fn the_serial_transport_closes_the_loop_over_a_pty() {
    // `pair` neither sets TIOCEXCL nor flocks the slave: the harness can open it by its
    // path. Ours stays open so the master never sees the slave side closed.
    let (mut master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
    let path = slave.name().expect("the slave has a path");
    master
        .set_timeout(std::time::Duration::from_millis(5))
        .unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let stop2 = Arc::clone(&stop);
    let device = std::thread::spawn(move || {
        let mut rt = Runtime::<Fx>::try_new(RuntimeConfig::default()).unwrap();
        let ticks = serve_lockstep(&mut master, &mut rt, &stop2);
        (ticks.map_err(|e| e.to_string()), *rt.counters())
    });
    let opts = RunOptions {
        target: Target::Serial(path.clone()),
        scenario: concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short.toml").into(),
        pace: Pace::LockStep,
        ..RunOptions::default()
    };
    let out = run(&opts);
    stop.store(true, Ordering::Relaxed);
    let (ticks, counters) = device.join().unwrap();
    let out = out.expect("the run is made");
    drop(slave);
    let r = &out.report;
    assert_eq!(r.target, format!("serial:{path}"));
    // Every frame accounted for from the device's own counters, nothing lost.
    assert_eq!(r.frames.source, "device-status");
    assert!(r.frames.adds_up, "{:?}", r.frames);
    assert_eq!(r.frames.up.sent, 15_001);
    assert_eq!(r.frames.up.received, 15_001);
    assert_eq!(r.frames.down.received, r.frames.down.sent);
    assert_eq!(ticks.unwrap(), 15_001);
    assert_eq!(u64::from(counters.rx_ok), 15_001);
    // Lock-step: every sample answered in its own period; latency modelled from the baud.
    assert_eq!(r.timing.missed_ticks, 0);
    assert!(r.timing.latency_modelled);
    assert_eq!(r.timing.jitter_max_ns, None);
    // The same device as in process: the same numerics verdict and trajectory.
    assert_eq!(r.numerics.verdict, Verdict::Pass, "{:?}", r.numerics);
    assert_eq!(r.verdict, Verdict::Pass);
    let inproc = run(&RunOptions {
        scenario: opts.scenario.clone(),
        ..RunOptions::default()
    })
    .unwrap();
    let ys = |t: &sim_host::sim::Trajectory| t.records.iter().map(|r| r.y_m).collect::<Vec<_>>();
    assert_eq!(ys(&out.trajectory), ys(&inproc.trajectory));
}
