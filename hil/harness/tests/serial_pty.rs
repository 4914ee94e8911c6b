//! The serial-port transport closes the loop over a pseudo-terminal pair, with the
//! firmware's runtime answering on the other end (frame-clocked, lock-step).

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;

use std::io::{Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use hil::run::{run, RunOptions, Target};
use serialport::{SerialPort, TTYPort};
use wheelset_control::Fx;
use wheelset_report::Verdict;
use wheelset_runtime::{Runtime, RuntimeConfig};
use wheelset_targets::serial::Pace;

/// A pseudo-terminal pair with a device thread on its master side, running `serve` with a
/// default runtime until [`PtyDevice::finish`].
struct PtyDevice<T> {
    path: String,
    slave: TTYPort,
    stop: Arc<AtomicBool>,
    thread: std::thread::JoinHandle<T>,
}

impl<T: Send + 'static> PtyDevice<T> {
    fn spawn(
        serve: impl FnOnce(&mut TTYPort, &mut Runtime<Fx>, &AtomicBool) -> T + Send + 'static,
    ) -> Self {
        // `pair` neither sets TIOCEXCL nor flocks the slave: the harness can open it by
        // its path. Ours stays open so the master never sees the slave side closed.
        let (mut master, slave) = TTYPort::pair().expect("a pseudo-terminal pair");
        let path = slave.name().expect("the slave has a path");
        master
            .set_timeout(std::time::Duration::from_millis(5))
            .unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let stop2 = Arc::clone(&stop);
        let thread = std::thread::spawn(move || {
            let mut rt = Runtime::<Fx>::try_new(RuntimeConfig::default()).unwrap();
            serve(&mut master, &mut rt, &stop2)
        });
        Self {
            path,
            slave,
            stop,
            thread,
        }
    }

    /// Stops the device and returns what it served.
    fn finish(self) -> T {
        self.stop.store(true, Ordering::Relaxed);
        let out = self.thread.join().unwrap();
        drop(self.slave);
        out
    }
}

/// A frame-clocked device on a port: each 0x00 delimiter received is one tick of `rt`,
/// whose output is written back at once (exec 0). Runs until `stop` is set or the port
/// fails; returns the ticks run.
fn serve_lockstep<P: Read + Write + ?Sized>(
    port: &mut P,
    rt: &mut Runtime<Fx>,
    stop: &AtomicBool,
) -> std::io::Result<u64> {
    let mut buf = [0u8; 256];
    let mut ticks = 0;
    while !stop.load(Ordering::Relaxed) {
        let n = match port.read(&mut buf) {
            Ok(n) => n,
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut
                        | std::io::ErrorKind::WouldBlock
                        | std::io::ErrorKind::Interrupted
                ) =>
            {
                continue
            }
            Err(e) => return Err(e),
        };
        for chunk in buf[..n].split_inclusive(|&b| b == 0) {
            rt.receive(chunk);
            if chunk.last() == Some(&0) {
                let out = rt.tick(0).to_vec();
                port.write_all(&out)?;
                ticks += 1;
            }
        }
    }
    Ok(ticks)
}

#[test]
fn the_serial_transport_closes_the_loop_over_a_pty() {
    let device = PtyDevice::spawn(|port, rt, stop| {
        let ticks = serve_lockstep(port, rt, stop);
        (ticks.map_err(|e| e.to_string()), *rt.counters())
    });
    let path = device.path.clone();
    let opts = RunOptions {
        target: Target::Serial(path.clone()),
        scenario: concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short.toml").into(),
        pace: Pace::LockStep,
        ..RunOptions::default()
    };
    let out = run(&opts);
    let (ticks, counters) = device.finish();
    let out = out.expect("the run is made");
    let r = &out.report;
    assert_eq!(r.target, format!("serial:{path}"));
    // Every frame accounted for from the device's own counters, nothing lost.
    assert_eq!(r.frames.source, "device-status");
    assert!(r.frames.adds_up, "{:?}", r.frames);
    // Up: the run's Config (wsp, monitor_safe), 15 000 Sensor frames, the Status request.
    assert_eq!(r.frames.up.sent, 15_002);
    assert_eq!(r.frames.up.received, 15_002);
    assert_eq!(r.frames.down.received, r.frames.down.sent);
    assert_eq!(ticks.unwrap(), 15_002);
    assert_eq!(u64::from(counters.rx_ok), 15_002);
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
    let ys =
        |t: &wheelset_plant::sim::Trajectory| t.records.iter().map(|r| r.y_m).collect::<Vec<_>>();
    assert_eq!(ys(&out.trajectory), ys(&inproc.trajectory));
}

/// A frame-clocked device as the firmware's receiver is: slow to get round to its input
/// (2 ms here), it takes every byte that arrived meanwhile in one burst and ticks once per
/// burst, however many delimiters it held (the tick monitor's skip policy). Returns the
/// ticks run and the largest number of delimiters one burst held.
fn serve_in_bursts(port: &mut TTYPort, rt: &mut Runtime<Fx>, stop: &AtomicBool) -> (u64, usize) {
    let (mut ticks, mut most) = (0, 0);
    let mut buf = [0u8; 1024];
    while !stop.load(Ordering::Relaxed) {
        let Ok(n) = port.read(&mut buf) else { continue };
        if n == 0 {
            continue;
        }
        let mut burst = buf[..n].to_vec();
        std::thread::sleep(std::time::Duration::from_millis(2));
        port.set_timeout(std::time::Duration::from_millis(0))
            .unwrap();
        while let Ok(n @ 1..) = port.read(&mut buf) {
            burst.extend_from_slice(&buf[..n]);
        }
        port.set_timeout(std::time::Duration::from_millis(5))
            .unwrap();
        let edges = burst.iter().filter(|&&b| b == 0).count();
        most = most.max(edges);
        rt.receive(&burst);
        if edges > 0 {
            let out = rt.tick(0).to_vec();
            port.write_all(&out).unwrap();
            ticks += 1;
        }
    }
    (ticks, most)
}

#[test]
fn a_lock_step_transport_keeps_one_frame_in_flight() {
    // The run's Config goes out just before its first Sensor frame: sent back to back,
    // they would reach this device as one burst, one tick, and the host would wait for
    // the second answer until its timeout.
    let device = PtyDevice::spawn(serve_in_bursts);
    let path = device.path.clone();
    let out = run(&RunOptions {
        target: Target::Serial(path.clone()),
        scenario: concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/tiny.toml").into(),
        pace: Pace::LockStep,
        ..RunOptions::default()
    });
    let (ticks, most) = device.finish();
    let out = out.expect("the run is made: every frame answered");
    // One tick per frame: the Config, 1 000 Sensor frames, the Status request.
    assert_eq!(most, 1, "a burst held {most} frames");
    assert_eq!(ticks, 1_002);
    assert_eq!(out.report.timing.missed_ticks, 0);
    assert_eq!(out.report.verdict, Verdict::Pass, "{:?}", out.report);
}

/// Two frames in one write (here two Sensor frames; a fault that turns a byte of one frame
/// into 0x00 makes the same two delimiters) reach a device that ticks once per burst as
/// two bursts: the transport sends a write's frames one at a time
/// (`wheelset_targets::lockstep::frames`), so both are answered and nothing is left owed.
#[test]
fn two_frames_in_one_write_are_two_ticks_and_two_answers() {
    use common::sensor;
    use wheelset_loop::transport::Transport;
    use wheelset_proto::{Decoder, Message};
    let device = PtyDevice::spawn(serve_in_bursts);
    let mut port = wheelset_targets::serial::Serial::open(
        &device.path,
        921_600,
        hil::run::DEFAULT_CPU_HZ,
        std::time::Duration::from_secs(2),
    )
    .unwrap();
    let mut write = sensor(1);
    write.extend_from_slice(&sensor(2));
    port.send(0, &write).expect("sent");
    let mut got = Vec::new();
    port.recv(1, &mut |_, b| got.extend_from_slice(b))
        .expect("both answers arrive (a lost one is a timeout error)");
    let (ticks, most) = device.finish();
    let mut dec: Decoder = Decoder::new();
    let echoes: Vec<u16> = dec
        .messages(&got)
        .filter_map(|m| match m {
            Ok(Message::Actuation(a)) => Some(a.seq_echo),
            _ => None,
        })
        .collect();
    assert_eq!(most, 1, "a burst held {most} frames");
    assert_eq!(ticks, 2);
    assert_eq!(echoes, vec![1, 2]);
}
