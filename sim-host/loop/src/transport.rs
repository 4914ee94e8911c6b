//! One transport for every target: bytes out, bytes in with a deadline; every closed loop
//! drives a device through [`Transport`] only ([`crate::exchange`]). Time is integer ns on
//! the transport's [`Clock`]:
//!
//! - [`Clock::Simulated`]: the in-process device ([`crate::inproc`]); `recv` delivers the
//!   bytes arrived by `deadline_ns`, stamped with their simulated arrival. Deterministic.
//! - [`Clock::LockStep`]: the host's frame is the device's clock (QEMU, a frame-clocked
//!   serial device); `recv` waits in wall time for the replies owed, stamped with the
//!   deadline (the harness models the wire time).
//! - [`Clock::RealTime`]: a board with its own timer; `send` waits for the wall clock to
//!   reach `t_ns`, `recv` stamps the wall time of arrival.

use std::fmt;

use wheelset_proto::{Decoder, FrameError, Message};

/// What [`Transport::recv_frames`] hands over for each piece it decoded: its arrival
/// (ns), the bytes it took, and the result of the frame it closed (None: none closed).
pub type FrameSink<'s> = dyn FnMut(u64, usize, Option<Result<Message, FrameError>>) + 's;

/// The time base a transport runs on (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Clock {
    /// Simulated integer-nanosecond time (in process).
    Simulated,
    /// The host's frame clocks the device (QEMU, a frame-clocked serial device).
    LockStep,
    /// Wall time against a free-running device (a board).
    RealTime,
}

impl std::fmt::Display for Clock {
    /// `simulated`, `lock-step` or `real-time`.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Clock::Simulated => "simulated",
            Clock::LockStep => "lock-step",
            Clock::RealTime => "real-time",
        })
    }
}

/// What a transport can fail with (all carry a human-readable reason).
#[derive(Debug)]
pub enum TransportError {
    /// The target cannot be started or opened (missing QEMU, missing ELF, no such port);
    /// the message says how to get it.
    Unavailable(String),
    /// An I/O error while the loop ran.
    Io(String),
    /// The device did not answer within the transport's timeout.
    Timeout(String),
}

impl fmt::Display for TransportError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Unavailable(m) => write!(f, "target unavailable: {m}"),
            Self::Io(m) => write!(f, "transport I/O error: {m}"),
            Self::Timeout(m) => write!(f, "timeout: {m}"),
        }
    }
}

impl std::error::Error for TransportError {}

/// Frame accounting of one direction as the link itself saw it (only the simulated link
/// knows this exactly; other transports derive it from the device's counters).
pub use crate::sim_link::Accounting;

/// Exact per-direction accounting a transport may provide at the end of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LinkAccounting {
    /// Host -> device.
    pub up: Accounting,
    /// Device -> host.
    pub down: Accounting,
}

/// Bytes out, bytes in with a deadline (see the module docs for the time semantics).
pub trait Transport {
    /// The target as named on the command line (`inproc`, `qemu`, `serial:PATH`).
    fn name(&self) -> String;
    /// The time base.
    fn clock(&self) -> Clock;
    /// The line rate in bits per second (10 bits per byte), for the link utilisation.
    fn baud(&self) -> u32;
    /// How the device's `exec` field converts to nanoseconds, and its unit's name
    /// (`("ns", 1.0)` in process, `("instructions", 2^shift)` under QEMU, `("cycles",
    /// 1e9 / f_cpu)` on a board).
    fn exec_unit(&self) -> (&'static str, f64);
    /// Hands `bytes` (whole frames, delimiters included) to the link at `t_ns`.
    fn send(&mut self, t_ns: u64, bytes: &[u8]) -> Result<(), TransportError>;
    /// Passes every chunk of bytes that arrived by `deadline_ns` to `sink(arrival_ns,
    /// bytes)`, in order.
    fn recv(
        &mut self,
        deadline_ns: u64,
        sink: &mut dyn FnMut(u64, &[u8]),
    ) -> Result<(), TransportError>;
    /// [`Self::recv`] decoded with the host's decoder `dec` (its state carried over):
    /// each piece ([`Decoder::pieces`]) goes to `sink(arrival_ns, bytes, frame)`, in
    /// order. The in-process link overrides it to attribute the decoder's own results.
    fn recv_frames(
        &mut self,
        deadline_ns: u64,
        dec: &mut Decoder,
        sink: &mut FrameSink<'_>,
    ) -> Result<(), TransportError> {
        self.recv(deadline_ns, &mut |at, run| {
            for (piece, r) in dec.pieces(run) {
                sink(at, piece.len(), r);
            }
        })
    }
    /// Whether a lock-step transport keeps two exchanges in flight: [`Self::recv`] waits
    /// only for the answers to the frames sent before its deadline, keeping later ones
    /// ([`crate::exchange`]). Default: `false`.
    fn pipelined(&self) -> bool {
        false
    }
    /// Exact link accounting after the run has drained, if the transport knows it.
    fn link_accounting(&self) -> Option<LinkAccounting> {
        None
    }
    /// Transport-specific figures for the report (informative, not judged).
    fn extra(&self) -> Option<serde_json::Value> {
        None
    }
}
