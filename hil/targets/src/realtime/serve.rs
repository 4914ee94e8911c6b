//! `hil serve --pty`: a free-running stand-in for a board, the firmware's runtime ticking
//! behind a pseudo-terminal with the board's tick policy (`firmware/app/src/tick.rs`),
//! optionally behind a modelled USB bridge. See docs/board-in-loop.md.

use std::collections::VecDeque;
use std::io::{self, Read};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use serde::Serialize;
use serialport::{SerialPort, TTYPort};
use wheelset_control::Fx;
use wheelset_runtime::{Runtime, RuntimeConfig};

use crate::realtime::bridge::{BridgeModel, DelayLine, LineReport};
use crate::realtime::os::{self as rt_os, Obtained, Want};
use crate::realtime::{flush_queue, queue_frame};
use crate::serial::nothing_yet;

/// Bytes the stand-in queues for transmission (the firmware's TX pipe).
pub const TX_QUEUE: usize = 256;

/// Options of the stand-in.
#[derive(Debug, Clone, Copy)]
pub struct ServeOptions {
    /// Base rate at start, Hz (a host Config frame may change it).
    pub rate_hz: u32,
    /// Stop after this long (None: until stopped).
    pub duration: Option<Duration>,
    /// Core clock the `exec` field is expressed in, Hz.
    pub cpu_hz: f64,
    /// What to ask of the operating system.
    pub want: Want,
    /// The USB bridge between the stand-in and the host ([`BridgeModel::is_none`]: none).
    pub bridge: BridgeModel,
}

/// What the modelled bridge did (`hil serve --json`, `bridge`).
#[derive(Debug, Clone, Copy, Serialize, Default)]
pub struct BridgeReport {
    /// The model as applied.
    pub model: BridgeModel,
    /// Host to stand-in.
    pub up: LineReport,
    /// Stand-in to host.
    pub down: LineReport,
}

/// What the stand-in did.
#[derive(Debug, Clone, Serialize, Default)]
pub struct ServeReport {
    /// Ticks run.
    pub ticks: u64,
    /// Wake-ups more than a quarter period late (and less than one period).
    pub late: u64,
    /// Ticks skipped after a wake-up a period or more late.
    pub skipped: u64,
    /// Largest lateness of a wake-up, ns.
    pub max_lateness_ns: u64,
    /// Bytes received.
    pub rx_bytes: u64,
    /// Bytes sent.
    pub tx_bytes: u64,
    /// Frames not queued (the TX queue full: nobody reading).
    pub tx_dropped: u64,
    /// Base rate at the end, Hz.
    pub rate_hz: u32,
    /// Ticks of delay the gains in force at the end are designed for.
    pub delay_ticks: u8,
    /// The modelled USB bridge, if any.
    pub bridge: Option<BridgeReport>,
    /// What the operating system granted.
    pub realtime: Obtained,
}

fn period_ns(rate_hz: u32) -> Option<u64> {
    (rate_hz > 0 && 1_000_000_000 % u64::from(rate_hz) == 0)
        .then(|| 1_000_000_000 / u64::from(rate_hz))
}

/// The runtime for `rate_hz`, or why not.
pub fn runtime_at(rate_hz: u32) -> Result<Runtime<Fx>, String> {
    if period_ns(rate_hz).is_none() {
        return Err(format!(
            "--rate-hz {rate_hz}: the period must be a whole number of nanoseconds"
        ));
    }
    let cfg = RuntimeConfig::default()
        .designed(rate_hz, 1)
        .map_err(|e| format!("--rate-hz {rate_hz}: {e}"))?;
    Runtime::try_new(cfg).map_err(|e| format!("--rate-hz {rate_hz}: {e}"))
}

/// Runs `rt` free-running on `port` (the pty's master) until `stop`, the end or a failure.
pub fn serve(
    port: &mut TTYPort,
    mut rt: Runtime<Fx>,
    o: &ServeOptions,
    stop: &AtomicBool,
) -> io::Result<ServeReport> {
    let mut rep = ServeReport {
        realtime: rt_os::obtain(o.want),
        ..ServeReport::default()
    };
    let mut bridge =
        (!o.bridge.is_none()).then(|| (DelayLine::new(o.bridge, 0), DelayLine::new(o.bridge, 1)));
    let mut rate = rt.base_rate_hz();
    let mut period = period_ns(rate).unwrap_or(1_000_000);
    let start = Instant::now();
    let end = o.duration.map(|d| start + d);
    let mut next = start + Duration::from_nanos(period);
    let mut queue = VecDeque::with_capacity(TX_QUEUE);
    let mut buf = [0u8; 512];
    let mut last_exec = 0u32;
    let ns_to_cycles = o.cpu_hz / 1e9;
    while !stop.load(Ordering::Relaxed) && end.is_none_or(|e| Instant::now() < e) {
        // Sleep to shortly before the deadline, then spin (moving the bridge's runs).
        let spin = Duration::from_nanos((period / 5).min(80_000));
        loop {
            let now = Instant::now();
            if let Some((_, down)) = bridge.as_mut() {
                release(port, down, &mut queue, now, &mut rep)?;
            }
            if now >= next {
                break;
            }
            let left = next - now;
            if left > spin {
                let wait = (left - spin).min(Duration::from_millis(5));
                match bridge.as_mut() {
                    None => std::thread::sleep(wait),
                    Some((up, down)) => {
                        let wait = down
                            .next_release()
                            .map_or(wait, |r| wait.min(r.saturating_duration_since(now)));
                        read_into(port, wait, &mut buf, &mut rep, |b| {
                            up.push(Instant::now(), b);
                        })?;
                    }
                }
            } else {
                std::hint::spin_loop();
            }
        }
        let woke = Instant::now();
        let lateness = u64::try_from(woke.duration_since(next).as_nanos()).unwrap_or(u64::MAX);
        rep.max_lateness_ns = rep.max_lateness_ns.max(lateness);
        if lateness >= period {
            let missed = lateness / period;
            rep.skipped += missed;
            next += Duration::from_nanos(missed * period);
        } else if lateness > period / 4 {
            rep.late += 1;
        }
        let mut take = |b: &[u8]| match bridge.as_mut() {
            None => rt.receive(b),
            Some((up, _)) => {
                up.push(Instant::now(), b);
            }
        };
        while read_into(port, Duration::ZERO, &mut buf, &mut rep, &mut take)? == buf.len() {}
        if let Some((up, _)) = bridge.as_mut() {
            while let Some(run) = up.pop_due(woke) {
                rt.receive(&run);
            }
        }
        let out = rt.tick(last_exec);
        match bridge.as_mut() {
            None => enqueue(&mut queue, out, &mut rep),
            Some((_, down)) => {
                if !down.push(Instant::now(), out) {
                    rep.tx_dropped += 1;
                }
            }
        }
        let exec_ns = woke.elapsed().as_nanos() as f64;
        last_exec = (exec_ns * ns_to_cycles).min(f64::from(u32::MAX)) as u32;
        flush_queue(port, &mut queue)?;
        rep.ticks += 1;
        next += Duration::from_nanos(period);
        // A Config frame may have changed the base rate: re-arm from now.
        let now_rate = rt.base_rate_hz();
        if now_rate != rate {
            if let Some(p) = period_ns(now_rate) {
                rate = now_rate;
                period = p;
                next = Instant::now() + Duration::from_nanos(period);
            }
        }
    }
    rep.rate_hz = rate;
    rep.delay_ticks = rt.core().compiled().schedule().delay_ticks;
    rep.bridge = bridge.map(|(up, down)| BridgeReport {
        model: o.bridge,
        up: up.report(),
        down: down.report(),
    });
    Ok(rep)
}

/// One read of the pty (waiting at most `wait`), its bytes to `sink`; how many.
fn read_into(
    port: &mut TTYPort,
    wait: Duration,
    buf: &mut [u8],
    rep: &mut ServeReport,
    mut sink: impl FnMut(&[u8]),
) -> io::Result<usize> {
    let _ = port.set_timeout(wait);
    match port.read(buf) {
        Ok(n) => {
            rep.rx_bytes += n as u64;
            sink(buf.get(..n).unwrap_or(&[]));
            Ok(n)
        }
        Err(e) if nothing_yet(&e) => Ok(0),
        Err(e) => Err(e),
    }
}

/// The bridge's `down` runs due by `now` into the TX queue, and the queue to the pty.
fn release(
    port: &mut TTYPort,
    down: &mut DelayLine,
    queue: &mut VecDeque<u8>,
    now: Instant,
    rep: &mut ServeReport,
) -> io::Result<()> {
    let mut any = false;
    while let Some(run) = down.pop_due(now) {
        any = true;
        enqueue(queue, &run, rep);
    }
    if any {
        flush_queue(port, queue)?;
    }
    Ok(())
}

/// Queues `frame` for the pty, counted as sent, or as dropped when the queue is full.
fn enqueue(queue: &mut VecDeque<u8>, frame: &[u8], rep: &mut ServeReport) {
    if queue_frame(queue, TX_QUEUE, frame) {
        rep.tx_bytes += frame.len() as u64;
    } else {
        rep.tx_dropped += 1;
    }
}

/// Creates a pty pair: (master, slave, slave path). Keep the slave open, or the master
/// sees the other side closed while no host is connected.
pub fn open_pty() -> io::Result<(TTYPort, TTYPort, String)> {
    let (master, slave) = TTYPort::pair().map_err(io::Error::other)?;
    let path = slave
        .name()
        .ok_or_else(|| io::Error::other("the pseudo-terminal has no path"))?;
    Ok((master, slave, path))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rates_whose_period_is_not_whole_nanoseconds_are_refused() {
        assert!(runtime_at(0).is_err());
        assert!(runtime_at(3_000)
            .err()
            .unwrap_or_default()
            .contains("--rate-hz 3000"));
        assert!(runtime_at(5_000).is_ok());
    }
}
