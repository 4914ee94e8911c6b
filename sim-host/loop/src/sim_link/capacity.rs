//! The link budget: the link's configuration ([`LinkConfig`]: baud, latency, faults) and
//! whether one exchange per period fits the line ([`check_budget`]).

use std::fmt;

use super::{Faults, BITS_PER_BYTE, NS_PER_S};

/// Timing and faults of a link.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkConfig {
    /// Baud rate (bits per second, 10 bits per byte).
    pub baud: u32,
    /// One-way latency added to every byte, ns.
    pub latency_ns: u64,
    /// Fault injection.
    pub faults: Faults,
    /// RNG seed (each direction derives its own stream).
    pub seed: u64,
}

/// Default baud: 5 Mbaud, just below the Nucleo build's highest (5.25 Mbaud); it carries
/// the 5 kHz worst-case round trip within [`check_budget`]'s share, 4 Mbaud does not.
pub const DEFAULT_BAUD: u32 = 5_000_000;
/// Default one-way latency: 2 us (UART FIFO + DMA hand-off).
pub const DEFAULT_LATENCY_NS: u64 = 2_000;
/// Share of the period the round trip may use; the rest is margin for execution and jitter.
pub const BUDGET_SHARE: f64 = wheelset_proto::link::LINK_SHARE_MAX_PERMILLE as f64 / 1000.0;

impl Default for LinkConfig {
    fn default() -> Self {
        Self {
            baud: DEFAULT_BAUD,
            latency_ns: DEFAULT_LATENCY_NS,
            faults: Faults::none(),
            seed: 1,
        }
    }
}

/// A link that cannot carry the configured exchange.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkBudgetError {
    /// Bytes per period, host -> device.
    pub up_bytes: usize,
    /// Bytes per period, device -> host.
    pub down_bytes: usize,
    /// Baud.
    pub baud: u32,
    /// Latency, ns.
    pub latency_ns: u64,
    /// Period, ns.
    pub period_ns: u64,
    /// Round-trip time needed, ns.
    pub needed_ns: u64,
    /// Time allowed, ns (`BUDGET_SHARE` of the period, or of the delay for the round trip).
    pub allowed_ns: u64,
    /// Ticks of delay the exchange is pipelined over (1: lock-step).
    pub delay_ticks: u32,
}

impl fmt::Display for LinkBudgetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let rate = NS_PER_S as f64 / self.period_ns as f64;
        if self.delay_ticks > 1 {
            let larger = self.up_bytes.max(self.down_bytes);
            return write!(
                f,
                "link budget exceeded: pipelined over {} ticks at {:.0} Hz, each direction's \
                 frame ({larger} bytes at most) must take at most {:.0} % of the {:.1} us period \
                 ({:.1} us on the line at {} baud) and the round trip at most {:.0} % of the \
                 delay ({:.1} us of {:.1} us allowed, {} ns latency each way); raise the baud, \
                 lower the latency, lengthen the delay or lower the rate",
                self.delay_ticks,
                rate,
                BUDGET_SHARE * 100.0,
                self.period_ns as f64 / 1e3,
                wire_ns(larger, self.baud) as f64 / 1e3,
                self.baud,
                BUDGET_SHARE * 100.0,
                self.needed_ns as f64 / 1e3,
                self.allowed_ns as f64 / 1e3,
                self.latency_ns,
            );
        }
        write!(
            f,
            "link budget exceeded: ({} + {}) bytes x {} bits / {} baud + 2 x {} ns latency = {:.1} us \
             per {:.0} Hz period, but only {:.0} % of the {:.1} us period = {:.1} us is allowed; \
             raise the baud to at least {:.0}, lower the rate or pipeline the exchange over \
             more ticks of delay",
            self.up_bytes,
            self.down_bytes,
            BITS_PER_BYTE,
            self.baud,
            self.latency_ns,
            self.needed_ns as f64 / 1e3,
            rate,
            BUDGET_SHARE * 100.0,
            self.period_ns as f64 / 1e3,
            self.allowed_ns as f64 / 1e3,
            wheelset_proto::link::min_baud(
                u32::try_from(NS_PER_S / self.period_ns.max(1)).unwrap_or(u32::MAX),
                u32::try_from(self.up_bytes).unwrap_or(u32::MAX),
                u32::try_from(self.down_bytes).unwrap_or(u32::MAX),
                self.latency_ns,
                wheelset_proto::link::LINK_SHARE_MAX_PERMILLE,
            )
            .map_or(f64::INFINITY, f64::from),
        )
    }
}

impl std::error::Error for LinkBudgetError {}

impl LinkBudgetError {
    /// The highest rate at which this link carries the same exchange, Hz (0: none), from
    /// the same budget ([`wheelset_proto::link::max_rate_hz`]).
    #[must_use]
    pub fn max_rate_hz(&self) -> u32 {
        wheelset_proto::link::max_rate_hz(
            self.baud,
            u32::try_from(self.up_bytes).unwrap_or(u32::MAX),
            u32::try_from(self.down_bytes).unwrap_or(u32::MAX),
            self.latency_ns,
            wheelset_proto::link::LINK_SHARE_MAX_PERMILLE,
        )
    }
}

/// Time on the line for `n` bytes at `baud`, ns (rounded up; [`wheelset_proto::link::wire_ns`]).
#[must_use]
pub fn wire_ns(n: usize, baud: u32) -> u64 {
    wheelset_proto::link::wire_ns(n as u64, baud)
}

/// The link budget with `delay_ticks` ticks of delay ([`wheelset_proto::link::link_fits_delayed`]):
/// `(up + down) bytes x 10 / baud + 2 latency <= BUDGET_SHARE x delay_ticks x period`, each
/// frame within `BUDGET_SHARE` of a period. The round-trip time, or an error naming the numbers.
pub fn check_budget(
    up_bytes: usize,
    down_bytes: usize,
    baud: u32,
    latency_ns: u64,
    period_ns: u64,
    delay_ticks: u32,
) -> Result<u64, LinkBudgetError> {
    use wheelset_proto::link::{link_fits_delayed, LinkError, LINK_SHARE_MAX_PERMILLE};
    let rate_hz = u32::try_from(NS_PER_S / period_ns.max(1)).unwrap_or(u32::MAX);
    let (up, down) = (
        u32::try_from(up_bytes).unwrap_or(u32::MAX),
        u32::try_from(down_bytes).unwrap_or(u32::MAX),
    );
    let d = delay_ticks.max(1);
    link_fits_delayed(
        rate_hz,
        baud,
        up,
        down,
        latency_ns,
        LINK_SHARE_MAX_PERMILLE,
        d,
    )
    .map_err(|e| {
        let (needed_ns, allowed_ns) = match e {
            LinkError::TooSlow {
                needed_ns,
                allowed_ns,
            } => (needed_ns, allowed_ns),
            _ => (u64::MAX, 0),
        };
        LinkBudgetError {
            up_bytes,
            down_bytes,
            baud,
            latency_ns,
            period_ns,
            needed_ns,
            allowed_ns,
            delay_ticks: d,
        }
    })
}
