//! The simulated serial link: two byte streams (host -> device "up", device -> host
//! "down"), each a UART of 10 bits per byte plus a fixed latency, in integer-ns simulated
//! time, with seeded faults. Byte `k` (from 0) of a frame sent at `t` leaves the line at
//! `start + ceil((k+1) * 10 * 1e9 / baud)` ns, `start = max(t, line free)`, and arrives
//! `latency` ns later.
//!
//! Faults ([`Faults`], `--faults SPEC`), per direction in this order: whole-frame drop,
//! outage, byte drop, bit errors (probability `ber` per data bit, drawn by geometric
//! skips), bursts (Poisson, `rate` per second, each XOR-ing `len` bytes with random
//! non-zero values). Every byte carries its frame's id, and the receiving port
//! ([`RxPort`], [`Accounting`]) attributes each frame sent to one fate: received,
//! rejected, dropped or in flight.

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
