//! One transport for every target: bytes out, bytes in with a deadline ([`Transport`]), in
//! integer ns on its [`Clock`] (lock-step `recv` stamps with the deadline).

use std::fmt;

use wheelset_proto::{Decoder, FrameError, Message};

/// Per decoded piece of [`Transport::recv_frames`]: arrival ns, bytes, closed frame's result.
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
    /// The target cannot be started or opened; the message says how to get it.
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
    /// The device's `exec` unit and its ns per unit (`("cycles", 1e9 / f_cpu)` on a board).
    fn exec_unit(&self) -> (&'static str, f64);
    /// Hands `bytes` (whole frames, delimiters included) to the link at `t_ns`.
    fn send(&mut self, t_ns: u64, bytes: &[u8]) -> Result<(), TransportError>;
    /// Passes every chunk arrived by `deadline_ns` to `sink(arrival_ns, bytes)`, in order.
    fn recv(
        &mut self,
        deadline_ns: u64,
        sink: &mut dyn FnMut(u64, &[u8]),
    ) -> Result<(), TransportError>;
    /// [`Self::recv`] decoded with `dec`: each piece to `sink(arrival_ns, bytes, frame)`.
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
    /// Whether a lock-step transport keeps two exchanges in flight (default `false`).
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
