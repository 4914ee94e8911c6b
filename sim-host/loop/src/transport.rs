//! One transport for every target: bytes out, bytes in with a deadline.
//!
//! Every closed loop and every comparison with a device drives it through [`Transport`]
//! only (the closed-loop adapter [`crate::exchange`]): in process over the simulated link
//! ([`crate::inproc`]), or, in `hil`, the firmware under QEMU and a board on a serial
//! port. Time is integer
//! nanoseconds on the transport's [`Clock`]:
//!
//! - [`Clock::Simulated`]: the in-process device behind the simulated link. `send` at
//!   simulated `t_ns`, `recv` delivers every byte that has arrived by `deadline_ns`,
//!   stamped with its simulated arrival time. Deterministic.
//! - [`Clock::LockStep`]: the host's sensor frame is the device's clock (QEMU, or a
//!   frame-clocked device on a serial port). `recv` waits (in wall time, bounded by the
//!   transport's timeout) for the reply to the last frame sent (with two exchanges in
//!   flight, [`Transport::pipelined`]: to every frame sent before its deadline); the
//!   arrival stamp is the deadline, and the harness models the wire time at the link's
//!   baud.
//! - [`Clock::RealTime`]: a board with its own tick timer. `send` waits for the wall
//!   clock to reach `t_ns` after the run's start; `recv` returns what arrived by
//!   `deadline_ns`, stamped with the wall time of arrival.

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
    /// [`Self::recv`] decoded with the host's decoder `dec` (its state carried from call
    /// to call): every delivered chunk is taken up to each delimiter
    /// ([`Decoder::pieces`]) and each piece goes to `sink(arrival_ns, bytes, frame)`, in
    /// order. A transport that accounts for frames itself (the in-process
    /// link) overrides it to attribute the decoder's own results, with no second decoder
    /// over the same bytes.
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
    /// Whether a lock-step transport keeps two exchanges in flight: the next frame goes
    /// out before the device has answered the last one, and [`Self::recv`] waits only for
    /// the answers to the frames sent before its deadline (`t_sent < deadline_ns`),
    /// keeping later ones for a later call. The closed loop then sends sample `k + 1`
    /// before it takes the actuation of sample `k`, which the plant applies only from
    /// `t_k + T` ([`crate::exchange`]). Default: `false` (one exchange in flight).
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
