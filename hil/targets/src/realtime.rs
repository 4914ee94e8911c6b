//! Real-time pacing against a free-running device on a serial port (a board on its own
//! ticker, `hil serve --pty`, the firmware under QEMU on its own timer): the
//! [`RealTime`] transport.
//!
//! **Deadline-driven.** Every wait is against a deadline on the host's monotonic clock:
//! the port is polled for input with a bounded wait (at most a quarter period, never a
//! blocking read past the deadline) until `spin` before the deadline, then with
//! non-blocking reads until it. Each chunk is stamped at its read; bytes stamped after a
//! period's deadline belong to the next period. Where permitted the loop runs with
//! `SCHED_FIFO`, locked memory and a pinned core ([`crate::realtime::os`]); what was obtained
//! is reported.
//!
//! **Host deadlines apart from the device's answers.** A Sensor frame written more than
//! a quarter period after its instant `t_k`, or a receive deadline overshot by as much,
//! is a *host* miss (`host.missed_deadlines`); the device's late or missing answers are
//! the timing checks' `missed_ticks` as on every target.
//!
//! **Start-up.** A free-running device talks before the run (a powered board sends an
//! Actuation every tick). [`RealTime::prepare`]:
//! 1. listens for a few periods (a silent device is refused: frame-clocked devices take
//!    `--pace lockstep`);
//! 2. sends the run's Config (yaw law, hold ticks, the rates computed by
//!    `wheelset_runtime::rates_for`) with a status request, and checks that the device
//!    applied it;
//! 3. on a serial port, probes the link's round trip ([`ROUND_TRIP_PROBES`] status
//!    requests spread over the device's period) and refuses a run whose delay
//!    (`--delay-ticks`) it does not fit, naming the delay that would (a board behind a
//!    USB bridge: 1-2 ms of round trip; the probe's arithmetic in `prepare.rs`);
//! 4. asks for a second Status: its counters are the *baseline* the end-of-run counters
//!    are taken relative to ([`RunStart`]);
//! 5. measures the device's tick phase from the arrival of its frames (the earliest
//!    output instant `o_j - j T` over 32 ticks, `j` from the frames' tick counter) and
//!    its period, and refuses a device that does not tick at the configured rate.
//!
//! The plant's clock then starts so that each Sensor frame is written a *lead* before the
//! device's tick (`lead_ns`, [`RealTimeOptions::lead_num`] eighths of the period: half
//! by default): the Actuation echoing sample `k` arrives about `lead + exec + wire` after
//! `t_k`, and a host up to `T - lead` late, or a frame up to `lead` on its way, is still
//! in time. Every
//! frame that arrives before the device first answers one of the run's Sensor frames
//! (by echoing its `seq`: the first one, or a later one if the first was superseded
//! within one device tick, [`echoes_this_run`]) is discarded and counted (`pre_run`),
//! never passed on. During the
//! run the phase is re-measured every 256 device frames and the schedule follows a
//! drifting device clock (a board's crystal against the host's).
//!
//! Files: the start-up in `realtime/prepare.rs`, the send queue in `realtime/queue.rs`,
//! the tests in `realtime/tests.rs`; what stays here (~600 lines) is the one deadline loop
//! of [`RealTime`] (`send`, `recv`) with the phase and envelope estimates it needs on
//! every period, kept together because each step of the loop reads them.

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
    /// Frames the device sent after the baseline Status and before the run's first
    /// echo (ticks that belong to no period of the run).
    pub ticks_before_run: u64,
    /// Every frame discarded before the run (before and after the baseline).
    pub pre_run: u64,
}

impl RunStart {
    /// The end-of-run counters `end` relative to the start of the run: the fields the
    /// frame accounting reads (ticks, received and rejected frames) less the baseline,
    /// the ticks before the run's first echo taken off.
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
    /// Periods in which the host wrote its Sensor frame, or ended its receive, more
    /// than a quarter period late.
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
    /// The least round trip of [`ROUND_TRIP_PROBES`] status requests before the run
    /// (request written to its Status read), ns; 0 where not probed (a TCP device).
    pub round_trip_ns: f64,
    /// What of it a Sensor frame needs before the device's tick, as the host sees that
    /// tick: both ways' latency and the Sensor frame's wire time, ns (the round trip
    /// less the device's execution, the answer's frames' and the request's wire time,
    /// plus the Sensor frame's; [`RealTime::prepare`] refuses a run this does not fit).
    pub before_tick_ns: f64,
}

/// Status requests whose least round trip [`RealTime::prepare`] takes, each a
/// `1/ROUND_TRIP_PROBES` period later in the device's tick than the one before.
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
    /// The lead of each Sensor frame before the device's tick, in eighths of the period
    /// (4: half a period; the module docs). A link whose frames take longer than half a
    /// period to cross (QEMU's UART, `--target qemu-free`) needs more.
    pub lead_num: u64,
}

/// The byte stream to a free-running device: a serial port, or the TCP chardev of
/// QEMU's UART0 (the free-running firmware, `--target qemu-free`; the QEMU it belongs
/// to is held here, so it is killed when the transport is dropped).
pub enum Port {
    /// A serial port (a board, `hil serve --pty`).
    Tty(TTYPort),
    /// A TCP stream, and what must live as long as it.
    Tcp(TcpStream, Option<crate::qemu::Qemu>),
}

impl Port {
    /// Bounds the next read to `wait` (zero: non-blocking) and writes to a period.
    ///
    /// A TCP stream waits in `ppoll` (nanosecond timeout) and then reads without
    /// blocking: a socket's `SO_RCVTIMEO` is rounded *up to whole jiffies* by Linux
    /// (`sock_set_timeout`), so a 250 us bounded read blocked for a whole jiffy and the
    /// host missed most deadlines of a 1 kHz `qemu-free` run (measured with `SO_RCVTIMEO`:
    /// 2 994 of 3 000, send lateness p99 4.8 ms; with `ppoll`: 0 to 10 of 3 000, p99
    /// 12-19 us; README "QEMU free-running").
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
                // A non-blocking socket left from the last read: block for the write
                // (bounded by a write timeout; a few jiffies more do not matter there).
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
    /// Chunks read and not yet delivered: (arrival ns after `origin`, bytes).
    pending: VecDeque<(u64, Vec<u8>)>,
    /// The frame being assembled from the device's bytes, with its decoder.
    decoder: Decoder,
    frame: Vec<u8>,
    /// The seq of the run's first Sensor frame, once sent.
    first_seq: Option<u16>,
    /// The seq of the latest Sensor frame sent.
    last_seq: u16,
    synced: bool,
    sync: SyncReport,
    baseline: Option<Status>,
    /// The last Status seen during start-up.
    last_status: Option<Status>,
    /// Its arrival (ns after `origin`) and its bytes on the wire.
    last_status_at: Option<(u64, usize)>,
    /// Actuation frames seen during start-up: (arrival ns, wire bytes, tick, exec).
    seen: Vec<(u64, usize, u16, u32)>,
    /// Phase tracking during the run: the device's output phase on the run's clock,
    /// and the window of residuals.
    phase_ref_ns: f64,
    window: Vec<f64>,
    send_late: Vec<f64>,
    recv_over: Vec<f64>,
    late_sends: u64,
    late_receives: u64,
    missed: u64,
    period_missed: bool,
    status_owed: bool,
    obtained: Obtained,
}

fn io_err(path: &str, e: &io::Error) -> TransportError {
    TransportError::Io(format!("{path}: {e}"))
}

impl RealTime {
    /// Opens `path` at `o.baud` (8N1) and asks the operating system for `o.want` on the
    /// calling thread (the harness's loop).
    pub fn open(path: &str, o: RealTimeOptions) -> Result<Self, TransportError> {
        let port = serialport::new(path, o.baud)
            .timeout(Duration::ZERO)
            .open_native()
            .map_err(|e| {
                TransportError::Unavailable(format!(
                    "serial:{path}: cannot open at {} baud: {e} (is the board connected, \
                     and is the path right?)",
                    o.baud
                ))
            })?;
        let _ = port.clear(serialport::ClearBuffer::All);
        Ok(Self::on(&format!("serial:{path}"), Port::Tty(port), o))
    }

    /// Real-time pacing over `port` (named `name` in messages and the report); asks the
    /// operating system for `o.want` on the calling thread.
    #[must_use]
    pub fn on(name: &str, port: Port, o: RealTimeOptions) -> Self {
        let obtained = rt_os::obtain(o.want);
        Self {
            path: name.to_string(),
            port,
            o,
            origin: Instant::now(),
            pending: VecDeque::new(),
            decoder: Decoder::new(),
            frame: Vec::new(),
            first_seq: None,
            last_seq: 0,
            synced: false,
            sync: SyncReport::default(),
            baseline: None,
            last_status: None,
            last_status_at: None,
            seen: Vec::new(),
            phase_ref_ns: 0.0,
            window: Vec::with_capacity(TRACK_FRAMES),
            send_late: Vec::new(),
            recv_over: Vec::new(),
            late_sends: 0,
            late_receives: 0,
            missed: 0,
            period_missed: false,
            status_owed: false,
            obtained,
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

    /// One read of what is there, waiting at most `wait` for it; the chunk is stamped
    /// and filtered.
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
            Err(e)
                if matches!(
                    e.kind(),
                    io::ErrorKind::TimedOut
                        | io::ErrorKind::WouldBlock
                        | io::ErrorKind::Interrupted
                ) =>
            {
                Ok(())
            }
            Err(e) => Err(io_err(&self.path, &e)),
        }
    }

    /// Reads until `deadline`: bounded waits for input up to `spin` before it, then
    /// non-blocking reads.
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

    /// Splits the device's bytes into frames; before the run's first echo every frame is
    /// examined and discarded (counted), from it on every byte is passed on.
    fn ingest(&mut self, at: u64, bytes: &[u8]) {
        let mut rest = bytes;
        while !rest.is_empty() {
            let (r, more) = self.decoder.next_message(rest);
            self.frame
                .extend_from_slice(rest.get(..rest.len() - more.len()).unwrap_or(&[]));
            rest = more;
            let Some(r) = r else {
                continue;
            };
            let frame = std::mem::take(&mut self.frame);
            let n = frame.len();
            match r {
                Ok(Message::Actuation(a)) => {
                    if !self.synced
                        && self
                            .first_seq
                            .is_some_and(|s| echoes_this_run(a.seq_echo, s, self.last_seq))
                    {
                        self.synced = true;
                    }
                    if self.synced {
                        self.track(at, n);
                    } else {
                        self.seen.push((at, n, a.tick, a.exec));
                    }
                }
                Ok(Message::Status(s)) if !self.synced => {
                    self.last_status = Some(s);
                    self.last_status_at = Some((at, n));
                }
                _ => {}
            }
            if self.synced {
                // Stamped with the arrival of the frame's last byte, as received.
                match self.pending.back_mut() {
                    Some((t, v)) if *t == at => v.extend_from_slice(&frame),
                    _ => self.pending.push_back((at, frame)),
                }
            } else {
                self.sync.pre_run += 1;
                if self.baseline.is_some() {
                    self.sync.ticks_before_run += 1;
                }
            }
        }
        // A partial frame is passed on whole when its delimiter arrives.
    }

    /// Phase tracking during the run (see the module docs): the device's output
    /// instants modulo the period against the reference phase; every
    /// [`TRACK_FRAMES`] frames the schedule follows the window's lower decile (robust to
    /// frames delayed on the way and to ticks the device skipped).
    fn track(&mut self, at: u64, wire_bytes: usize) {
        let t = self.o.period_ns as f64;
        let o = at as f64 - wire_ns(wire_bytes, self.o.baud) as f64;
        self.window.push(wrap(o - self.phase_ref_ns, t));
        if self.window.len() >= TRACK_FRAMES {
            let drift = lower_decile(&mut self.window);
            self.window.clear();
            if drift.abs() > t / 50.0 {
                // Follow at most an eighth of a period per window.
                let step = drift.clamp(-t / 8.0, t / 8.0) as i64;
                if step > 0 {
                    self.origin += Duration::from_nanos(step as u64);
                } else {
                    self.origin -= Duration::from_nanos(step.unsigned_abs());
                }
                // The reference is on the run's clock, which moved with the origin.
                self.sync.phase_corrections += 1;
                self.sync.phase_correction_ns += step;
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
        let periods = self.send_late.len() as u64;
        HostDeadlines {
            periods,
            missed_deadlines: self.missed,
            missed_frac: self.missed as f64 / periods.max(1) as f64,
            late_sends: self.late_sends,
            late_receives: self.late_receives,
            send_lateness_ns: Stats::of(&self.send_late),
            recv_overshoot_ns: Stats::of(&self.recv_over),
        }
    }

    /// The host's deadlines so far.
    #[must_use]
    pub fn host_deadlines(&self) -> HostDeadlines {
        self.host_report()
    }

    /// The start-up synchronisation so far.
    #[must_use]
    pub fn sync_report(&self) -> &SyncReport {
        &self.sync
    }
}

impl RealTime {
    /// The run's start for the frame accounting, once the baseline was taken.
    #[must_use]
    pub fn run_start(&self) -> Option<RunStart> {
        self.baseline.map(|baseline| RunStart {
            baseline,
            ticks_before_run: self.sync.ticks_before_run,
            pre_run: self.sync.pre_run,
        })
    }
}

/// Whether an Actuation echoing `echo` answers a Sensor frame this run sent: seqs
/// `first..=last` (16-bit, wrapping; 0 is the echo of no sample). The run starts at the
/// first such answer, not only at the echo of `first`: a device that received the first
/// two Sensor frames within one of its ticks (a host late by a period) echoes only the
/// second, and waiting for the first would discard the whole run.
#[must_use]
pub fn echoes_this_run(echo: u16, first: u16, last: u16) -> bool {
    echo != 0 && echo.wrapping_sub(first) <= last.wrapping_sub(first)
}

/// Waits until `s` is readable (or hung up) for at most `wait`, with `ppoll`'s
/// nanosecond timeout (not `SO_RCVTIMEO`'s whole jiffies); a signal ends the wait early.
#[allow(unsafe_code)]
fn poll_readable(s: &TcpStream, wait: Duration) -> io::Result<()> {
    use std::os::fd::AsRawFd;
    let mut p = libc::pollfd {
        fd: s.as_raw_fd(),
        events: libc::POLLIN,
        revents: 0,
    };
    let ts = libc::timespec {
        tv_sec: libc::time_t::try_from(wait.as_secs()).unwrap_or(libc::time_t::MAX),
        tv_nsec: libc::c_long::from(wait.subsec_nanos()),
    };
    // SAFETY: one valid `pollfd` and one valid `timespec` for the call, no signal mask
    // (null), an fd owned by `s` and open throughout.
    let r = unsafe { libc::ppoll(&mut p, 1, &ts, std::ptr::null()) };
    if r < 0 {
        let e = io::Error::last_os_error();
        if e.kind() != io::ErrorKind::Interrupted {
            return Err(e);
        }
    }
    Ok(())
}

/// Whether the frames in `bytes` hold a Status frame.
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

/// The lower decile of `v` (reorders it; 0 when empty).
fn lower_decile(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    v.get(v.len() / 10).copied().unwrap_or(0.0)
}
