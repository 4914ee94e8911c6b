//! Real-time pacing against a free-running device (a board, `hil serve --pty`, QEMU on
//! its own timer): the [`RealTime`] transport, one deadline loop on the host's monotonic
//! clock. [`RealTime::prepare`] syncs to the device's tick phase; each Sensor frame is
//! written a lead ([`RealTimeOptions::lead_num`]) before the tick, and the phase is
//! re-measured every [`TRACK_FRAMES`] frames. See docs/board-in-loop.md.

use std::collections::VecDeque;
use std::io::{self, Read, Write};
use std::net::TcpStream;
use std::time::{Duration, Instant};

use serde::Serialize;
use serialport::{SerialPort, TTYPort};
use wheelset_loop::sim_link::wire_ns;
use wheelset_proto::{Command, Decoder, Message, Status};

use crate::realtime::os::{self as rt_os, Obtained, Want};

mod as_transport;
pub mod bridge;
pub mod os;
mod prepare;
mod queue;
pub mod serve;
#[cfg(test)]
mod tests;

pub use prepare::envelope_period;
pub use queue::{flush_queue, queue_frame};
use wheelset_loop::transport::{Clock, Transport, TransportError};
use wheelset_report::Stats;

/// Device frames over which the tick phase is measured before the run.
pub const PHASE_FRAMES: usize = 32;
/// Device frames per phase re-measurement during the run.
pub const TRACK_FRAMES: usize = 256;

/// The run's start as the device's counters saw it (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RunStart {
    /// The device's counters just before the run.
    pub baseline: Status,
    /// Frames sent after the baseline Status and before the run's first echo.
    pub ticks_before_run: u64,
    /// Every frame discarded before the run (before and after the baseline).
    pub pre_run: u64,
}

impl RunStart {
    /// The end-of-run counters `end` less the baseline (and the ticks before the first echo).
    #[must_use]
    pub fn relative(&self, end: &Status) -> Status {
        let b = &self.baseline;
        let d = |e: u32, s: u32| e.wrapping_sub(s);
        let mut s = *end;
        s.ticks = d(end.ticks, b.ticks).wrapping_sub(self.ticks_before_run as u32);
        s.rx_ok = d(end.rx_ok, b.rx_ok);
        s.rx_crc = d(end.rx_crc, b.rx_crc);
        s.rx_cobs = d(end.rx_cobs, b.rx_cobs);
        s.rx_version = d(end.rx_version, b.rx_version);
        s.rx_length = d(end.rx_length, b.rx_length);
        s.rx_postcard = d(end.rx_postcard, b.rx_postcard);
        s
    }
}

/// The host's own deadlines (the `host` section of the transport JSON).
#[derive(Debug, Clone, Serialize)]
pub struct HostDeadlines {
    /// Periods run.
    pub periods: u64,
    /// Periods with a send or receive more than a quarter period late.
    pub missed_deadlines: u64,
    /// `missed_deadlines / periods`.
    pub missed_frac: f64,
    /// Sensor frames written more than a quarter period after `t_k`.
    pub late_sends: u64,
    /// Receive deadlines overshot by more than a quarter period.
    pub late_receives: u64,
    /// Lateness of the Sensor frame's write behind `t_k`, ns.
    pub send_lateness_ns: Stats,
    /// Overshoot of the receive deadline, ns.
    pub recv_overshoot_ns: Stats,
}

/// The start-up synchronisation (the `sync` section of the transport JSON).
#[derive(Debug, Clone, Serialize, Default)]
pub struct SyncReport {
    /// Frames discarded before the run (never applied to the plant).
    pub pre_run: u64,
    /// Of these, frames after the baseline Status.
    pub ticks_before_run: u64,
    /// The device's period measured from its frames before the run, ns.
    pub device_period_ns: f64,
    /// How far ahead of the device's tick each Sensor frame is written, ns.
    pub lead_ns: u64,
    /// Corrections of the schedule to the device's drifting phase during the run.
    pub phase_corrections: u64,
    /// Their sum, ns (positive: the device's clock runs slow against the host's).
    pub phase_correction_ns: i64,
    /// The least round trip of [`ROUND_TRIP_PROBES`] status requests, ns; 0 if not probed.
    pub round_trip_ns: f64,
    /// Time a Sensor frame needs before the device's tick (latency both ways plus its
    /// wire time), ns; [`RealTime::prepare`] refuses a run this does not fit.
    pub before_tick_ns: f64,
}

/// Status requests probed for the round trip, spread over the device's period.
pub const ROUND_TRIP_PROBES: u64 = 32;

/// Options of the real-time transport.
#[derive(Debug, Clone, Copy)]
pub struct RealTimeOptions {
    /// Control period, ns.
    pub period_ns: u64,
    /// Line rate (for the wire time of frames).
    pub baud: u32,
    /// Core clock of the device, Hz (its `exec` cycles).
    pub cpu_hz: f64,
    /// The longest the host waits for a start-up answer.
    pub timeout: Duration,
    /// What to ask of the operating system.
    pub want: Want,
    /// Lead of each Sensor frame before the device's tick, eighths of the period (4: half;
    /// a link slower than half a period, QEMU's UART, needs more).
    pub lead_num: u64,
}

/// The byte stream to a free-running device: a serial port, or QEMU's UART0 over TCP.
pub enum Port {
    /// A serial port (a board, `hil serve --pty`).
    Tty(TTYPort),
    /// A TCP stream, and what must live as long as it.
    Tcp(TcpStream, Option<crate::qemu::Qemu>),
}

impl Port {
    /// Bounds the next read to `wait` (zero: non-blocking). TCP waits in `ppoll`: Linux
    /// rounds `SO_RCVTIMEO` up to whole jiffies, which missed most 1 kHz deadlines.
    fn set_timeout(&mut self, wait: Duration) -> io::Result<()> {
        match self {
            Self::Tty(p) => p.set_timeout(wait).map_err(io::Error::other),
            Self::Tcp(s, _) => {
                s.set_nonblocking(true)?;
                if !wait.is_zero() {
                    poll_readable(s, wait)?;
                }
                Ok(())
            }
        }
    }

    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        match self {
            Self::Tty(p) => p.read(buf),
            Self::Tcp(s, _) => match s.read(buf) {
                Ok(0) => Err(io::Error::new(
                    io::ErrorKind::UnexpectedEof,
                    "the device closed the link",
                )),
                r => r,
            },
        }
    }

    fn write_all(&mut self, bytes: &[u8]) -> io::Result<()> {
        match self {
            Self::Tty(p) => p.write_all(bytes),
            Self::Tcp(s, _) => {
                // Non-blocking from the last read: block for the write, bounded.
                s.set_nonblocking(false)?;
                s.set_write_timeout(Some(Duration::from_millis(100)))?;
                s.write_all(bytes)
            }
        }
    }
}

/// A free-running device on a serial port, paced in real time (see the module docs).
pub struct RealTime {
    path: String,
    port: Port,
    o: RealTimeOptions,
    /// Plant time zero on the host's clock.
    origin: Instant,
    obtained: Obtained,
    run: RunState,
}

#[derive(Default)]
struct RunState {
    /// Chunks read and not yet delivered: (arrival ns after `origin`, bytes).
    pending: VecDeque<(u64, Vec<u8>)>,
    decoder: Decoder,
    frame: Vec<u8>,
    /// The seq of the run's first Sensor frame, once sent.
    first_seq: Option<u16>,
    last_seq: u16,
    synced: bool,
    sync: SyncReport,
    baseline: Option<Status>,
    last_status: Option<Status>,
    /// Its arrival (ns after `origin`) and its bytes on the wire.
    last_status_at: Option<(u64, usize)>,
    /// Actuation frames seen during start-up: (arrival ns, wire bytes, tick, exec).
    seen: Vec<(u64, usize, u16, u32)>,
    /// The device's output phase on the run's clock, and the window of residuals.
    phase_ref_ns: f64,
    window: Vec<f64>,
    send_late: Vec<f64>,
    recv_over: Vec<f64>,
    late_sends: u64,
    late_receives: u64,
    missed: u64,
    period_missed: bool,
    status_owed: bool,
}

fn io_err(path: &str, e: &io::Error) -> TransportError {
    TransportError::Io(format!("{path}: {e}"))
}

impl RealTime {
    /// Opens `path` at `o.baud` (8N1); asks the OS for `o.want` on the calling thread.
    pub fn open(path: &str, o: RealTimeOptions) -> Result<Self, TransportError> {
        let port = crate::serial::open_port(path, o.baud, Duration::ZERO)?;
        Ok(Self::on(&format!("serial:{path}"), Port::Tty(port), o))
    }

    /// Real-time pacing over `port` (named `name`); asks the OS for `o.want` on this thread.
    #[must_use]
    pub fn on(name: &str, port: Port, o: RealTimeOptions) -> Self {
        Self {
            path: name.to_string(),
            port,
            o,
            obtained: rt_os::obtain(o.want),
            origin: Instant::now(),
            // The residual window fills in the paced loop: no growth there.
            run: RunState {
                window: Vec::with_capacity(TRACK_FRAMES),
                ..RunState::default()
            },
        }
    }

    fn period(&self) -> Duration {
        Duration::from_nanos(self.o.period_ns)
    }

    /// Spin window before a deadline: a fifth of the period, at most 80 us.
    fn spin(&self) -> Duration {
        Duration::from_nanos((self.o.period_ns / 5).min(80_000))
    }

    fn at_ns(&self, t: Instant) -> u64 {
        u64::try_from(t.saturating_duration_since(self.origin).as_nanos()).unwrap_or(u64::MAX)
    }

    fn wall(&self, t_ns: u64) -> Instant {
        self.origin + Duration::from_nanos(t_ns)
    }

    /// One read, waiting at most `wait`; the chunk is stamped and filtered.
    fn read_once(&mut self, wait: Duration) -> Result<(), TransportError> {
        let mut buf = [0u8; 512];
        let _ = self.port.set_timeout(wait);
        match self.port.read(&mut buf) {
            Ok(0) => Ok(()),
            Ok(n) => {
                let at = self.at_ns(Instant::now());
                self.ingest(at, buf.get(..n).unwrap_or(&[]));
                Ok(())
            }
            Err(e) if crate::serial::nothing_yet(&e) => Ok(()),
            Err(e) => Err(io_err(&self.path, &e)),
        }
    }

    /// Reads period by period until `done` holds or the timeout runs out; whether it holds.
    fn wait_for(&mut self, done: impl Fn(&Self) -> bool) -> Result<bool, TransportError> {
        let give_up = Instant::now() + self.o.timeout;
        while !done(self) && Instant::now() < give_up {
            let d = Instant::now() + self.period();
            self.wait_until(d)?;
        }
        Ok(done(self))
    }

    /// Reads until `deadline`: bounded waits up to `spin` before it, then non-blocking.
    fn wait_until(&mut self, deadline: Instant) -> Result<(), TransportError> {
        let max_block = self.period() / 4;
        let spin = self.spin();
        loop {
            let now = Instant::now();
            if now >= deadline {
                return Ok(());
            }
            let left = deadline - now;
            let wait = if left > spin {
                (left - spin).min(max_block)
            } else {
                Duration::ZERO
            };
            self.read_once(wait)?;
        }
    }

    /// Frames out of `bytes`: discarded (counted) before the run's first echo, then passed on.
    fn ingest(&mut self, at: u64, bytes: &[u8]) {
        let mut rest = bytes;
        while !rest.is_empty() {
            let (r, more) = self.run.decoder.next_message(rest);
            self.run
                .frame
                .extend_from_slice(rest.get(..rest.len() - more.len()).unwrap_or(&[]));
            rest = more;
            let Some(r) = r else {
                continue;
            };
            let frame = std::mem::take(&mut self.run.frame);
            let n = frame.len();
            match r {
                Ok(Message::Actuation(a)) => {
                    if !self.run.synced
                        && self
                            .run
                            .first_seq
                            .is_some_and(|s| echoes_this_run(a.seq_echo, s, self.run.last_seq))
                    {
                        self.run.synced = true;
                    }
                    if self.run.synced {
                        self.track(at, n);
                    } else {
                        self.run.seen.push((at, n, a.tick, a.exec));
                    }
                }
                Ok(Message::Status(s)) if !self.run.synced => {
                    self.run.last_status = Some(s);
                    self.run.last_status_at = Some((at, n));
                }
                _ => {}
            }
            if self.run.synced {
                // Stamped with the arrival of the frame's last byte, as received.
                match self.run.pending.back_mut() {
                    Some((t, v)) if *t == at => v.extend_from_slice(&frame),
                    _ => self.run.pending.push_back((at, frame)),
                }
            } else {
                self.run.sync.pre_run += 1;
                if self.run.baseline.is_some() {
                    self.run.sync.ticks_before_run += 1;
                }
            }
        }
        // A partial frame is passed on whole when its delimiter arrives.
    }

    /// Phase tracking: every [`TRACK_FRAMES`] frames the schedule follows the window's
    /// lower decile (robust to frames delayed on the way and to skipped ticks).
    fn track(&mut self, at: u64, wire_bytes: usize) {
        let t = self.o.period_ns as f64;
        let o = at as f64 - wire_ns(wire_bytes, self.o.baud) as f64;
        self.run.window.push(wrap(o - self.run.phase_ref_ns, t));
        if self.run.window.len() >= TRACK_FRAMES {
            let drift = lower_decile(&mut self.run.window);
            self.run.window.clear();
            if drift.abs() > t / 50.0 {
                // Follow at most an eighth of a period per window.
                let step = drift.clamp(-t / 8.0, t / 8.0) as i64;
                if step > 0 {
                    self.origin += Duration::from_nanos(step as u64);
                } else {
                    self.origin -= Duration::from_nanos(step.unsigned_abs());
                }
                // The reference is on the run's clock, which moved with the origin.
                self.run.sync.phase_corrections += 1;
                self.run.sync.phase_correction_ns += step;
            }
        }
    }

    fn write(&mut self, bytes: &[u8]) -> Result<(), TransportError> {
        let period = self.period();
        if let Port::Tty(p) = &mut self.port {
            let _ = p.set_timeout(period);
        }
        self.port
            .write_all(bytes)
            .map_err(|e| io_err(&self.path, &e))
    }

    fn host_report(&self) -> HostDeadlines {
        let periods = self.run.send_late.len() as u64;
        HostDeadlines {
            periods,
            missed_deadlines: self.run.missed,
            missed_frac: self.run.missed as f64 / periods.max(1) as f64,
            late_sends: self.run.late_sends,
            late_receives: self.run.late_receives,
            send_lateness_ns: Stats::of(&self.run.send_late),
            recv_overshoot_ns: Stats::of(&self.run.recv_over),
        }
    }

    /// The run's start for the frame accounting, once the baseline was taken.
    #[must_use]
    pub fn run_start(&self) -> Option<RunStart> {
        self.run.baseline.map(|baseline| RunStart {
            baseline,
            ticks_before_run: self.run.sync.ticks_before_run,
            pre_run: self.run.sync.pre_run,
        })
    }
}

/// Whether `echo` answers a Sensor frame of this run, seqs `first..=last` (wrapping; 0
/// echoes nothing). Not only `first`: given two frames in one tick, a device echoes the second.
#[must_use]
pub fn echoes_this_run(echo: u16, first: u16, last: u16) -> bool {
    echo != 0 && echo.wrapping_sub(first) <= last.wrapping_sub(first)
}

/// Waits at most `wait` (ns resolution, `ppoll`) until `fd` is readable or hung up;
/// `false` on timeout (`true` when a signal interrupts the wait).
#[allow(unsafe_code)]
pub(crate) fn poll_readable(fd: &impl std::os::fd::AsRawFd, wait: Duration) -> io::Result<bool> {
    let mut p = libc::pollfd {
        fd: fd.as_raw_fd(),
        events: libc::POLLIN,
        revents: 0,
    };
    let ts = libc::timespec {
        tv_sec: libc::time_t::try_from(wait.as_secs()).unwrap_or(libc::time_t::MAX),
        tv_nsec: libc::c_long::from(wait.subsec_nanos()),
    };
    // SAFETY: one valid `pollfd` and `timespec` for the call, no signal mask, `fd` open throughout.
    let r = unsafe { libc::ppoll(&mut p, 1, &ts, std::ptr::null()) };
    if r < 0 {
        let e = io::Error::last_os_error();
        return if e.kind() == io::ErrorKind::Interrupted {
            Ok(true)
        } else {
            Err(e)
        };
    }
    Ok(r > 0)
}

fn is_status(bytes: &[u8]) -> bool {
    let mut d: Decoder = Decoder::new();
    let found = d
        .messages(bytes)
        .any(|r| matches!(r, Ok(Message::Status(_))));
    found
}

/// `x` wrapped into `[-t/2, t/2)`.
fn wrap(x: f64, t: f64) -> f64 {
    x - t * (x / t).round()
}

/// The median of the device's reported execution times `execs` (cycles at `cpu_hz`), ns.
fn median_exec_ns(execs: impl Iterator<Item = u32>, cpu_hz: f64) -> f64 {
    let mut v: Vec<f64> = execs.map(|e| f64::from(e) * 1e9 / cpu_hz).collect();
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 2).copied().unwrap_or(0.0)
}

/// The lower decile of `v` (reorders it; 0 when empty).
fn lower_decile(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 10).copied().unwrap_or(0.0)
}
