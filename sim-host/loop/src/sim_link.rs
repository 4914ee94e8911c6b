//! The simulated serial link: two byte streams (host -> device "up", device -> host
//! "down"), each a UART timed by its baud rate (10 bits per byte: start, 8 data, stop)
//! plus a fixed latency, in integer-nanosecond simulated time, with seeded fault
//! injection. Deterministic for a seed.
//!
//! Byte `k` (from 0) of a frame handed to [`Channel::send`] at `t` leaves the line at
//! `start + ceil((k+1) * 10 * 1e9 / baud)` ns, `start = max(t, line free)`, and reaches the
//! receiver `latency` ns later.
//!
//! Faults ([`Faults`], parsed from `--faults SPEC`), applied per direction in this order:
//! whole-frame drop, outage (bytes on the wire during an outage are lost), byte drop,
//! bit errors (each data bit flips with probability `ber`, drawn by geometric skips),
//! bursts (a Poisson process of `rate` bursts per second, each XOR-ing `len` consecutive
//! bytes with random non-zero values).
//!
//! Frame accounting ([`RxPort`], [`Accounting`]): every byte carries the id of the frame it
//! belongs to, and the receiving port attributes each sent frame to exactly one fate:
//! received (decoded valid), rejected (part of a frame the decoder rejected: CRC, COBS,
//! length ...), dropped by the link (none of its bytes reached the decoder), or in flight
//! at the end of the run.

/// Bits on the line per byte (8N1).
pub const BITS_PER_BYTE: u64 = wheelset_proto::link::BITS_PER_BYTE;
/// Nanoseconds per second.
pub const NS_PER_S: u64 = 1_000_000_000;

mod accounting;
mod capacity;
mod channel;
mod line_faults;

pub use accounting::{Accounting, RxPort};
pub use capacity::{
    check_budget, wire_ns, LinkBudgetError, LinkConfig, BUDGET_SHARE, DEFAULT_BAUD,
    DEFAULT_LATENCY_NS,
};
pub use channel::{Channel, ChannelCounters, FrameId, Link};
pub use line_faults::{
    Burst, FaultDir, FaultSpecError, Faults, Outage, MAX_BURST_RATE_HZ, MAX_OUTAGE_S,
};
