//! Frame accounting: every frame sent in either direction is received (decoded valid),
//! rejected (part of a frame the receiver's decoder refused: CRC, COBS, length ...),
//! dropped (never reached the decoder), or still in flight at the end:
//! `sent = received + rejected + dropped + in_flight`, per direction and in total.
//!
//! Two sources:
//! - `link`: the simulated link attributes every frame exactly (`wheelset_loop::sim_link`);
//! - `device-status`: the device's own counters (its Status frame, requested at the end)
//!   for host -> device, the host's decoder for device -> host; `dropped` is what remains
//!   (`sent - received - rejected`), and a negative remainder is reported as not adding up.

use serde::Serialize;
use wheelset_proto::Status;

use wheelset_loop::exchange::HostCounts;
use wheelset_loop::transport::LinkAccounting;

/// One direction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Default)]
pub struct Direction {
    /// Frames sent.
    pub sent: u64,
    /// Frames received valid.
    pub received: u64,
    /// Frames rejected by the receiver.
    pub rejected: u64,
    /// Frames dropped on the way.
    pub dropped: u64,
    /// Frames still in flight at the end.
    pub in_flight: u64,
}

impl Direction {
    /// `sent == received + rejected + dropped + in_flight`.
    #[must_use]
    pub fn adds_up(&self) -> bool {
        self.sent == self.received + self.rejected + self.dropped + self.in_flight
    }

    /// `[sent, received, rejected, dropped, in_flight]`.
    #[must_use]
    pub fn counts(&self) -> [u64; 5] {
        [
            self.sent,
            self.received,
            self.rejected,
            self.dropped,
            self.in_flight,
        ]
    }
}

/// `sent S = received R + rejected J + dropped D + in flight F`.
impl std::fmt::Display for Direction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [s, r, j, d, i] = self.counts();
        write!(
            f,
            "sent {s} = received {r} + rejected {j} + dropped {d} + in flight {i}"
        )
    }
}

/// The `frames` section of a run's report: totals of both directions, and each.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct FramesReport {
    /// Both directions together (`sent`, `received`, ... at the top of the section).
    #[serde(flatten)]
    pub total: Direction,
    /// Whether every direction adds up.
    pub adds_up: bool,
    /// Where the numbers come from: `link` or `device-status`.
    pub source: String,
    /// Host -> device.
    pub up: Direction,
    /// Device -> host.
    pub down: Direction,
    /// Frames from a free-running device discarded before the run's first answer
    /// (`wheelset_targets::realtime`): never applied, not part of the sums above.
    pub pre_run: u64,
}

impl FramesReport {
    fn new(up: Direction, down: Direction, source: &str) -> Self {
        Self {
            total: Direction {
                sent: up.sent + down.sent,
                received: up.received + down.received,
                rejected: up.rejected + down.rejected,
                dropped: up.dropped + down.dropped,
                in_flight: up.in_flight + down.in_flight,
            },
            adds_up: up.adds_up() && down.adds_up(),
            source: source.into(),
            up,
            down,
            pre_run: 0,
        }
    }

    /// From the simulated link's exact accounting.
    #[must_use]
    pub fn from_link(l: &LinkAccounting) -> Self {
        let d = |a: &wheelset_loop::sim_link::Accounting| Direction {
            sent: a.sent,
            received: a.received,
            rejected: a.rejected,
            dropped: a.dropped,
            in_flight: a.in_flight,
        };
        Self::new(d(&l.up), d(&l.down), "link")
    }

    /// From the device's Status (None: it never arrived, so nothing can be said about the
    /// up direction: reported as not adding up) and the host's counts.
    #[must_use]
    pub fn from_status(status: Option<&Status>, host: &HostCounts) -> Self {
        let Some(s) = status else {
            let up = Direction {
                sent: host.sent,
                ..Direction::default()
            };
            let mut f = Self::new(up, Direction::default(), "device-status (lost)");
            f.adds_up = false;
            return f;
        };
        let rejected = wheelset_loop::inproc::rx_counts(s)[1..6]
            .iter()
            .map(|&n| u64::from(n))
            .sum();
        let received = u64::from(s.rx_ok);
        let up = Direction {
            sent: host.sent,
            received,
            rejected,
            dropped: host.sent.saturating_sub(received + rejected),
            in_flight: 0,
        };
        // The device sent one Actuation per tick, and the Status after the last one.
        let sent = u64::from(s.ticks) + 1;
        let down = Direction {
            sent,
            received: host.received,
            rejected: host.rejected,
            dropped: sent.saturating_sub(host.received + host.rejected),
            in_flight: 0,
        };
        Self::new(up, down, "device-status")
    }
}

/// The frames verdict: fail if the accounting does not add up, else the worst of the
/// rejected and dropped fractions against their budgets.
#[must_use]
pub fn judge(f: &FramesReport, b: &crate::budget::FrameBudgets) -> wheelset_report::Verdict {
    use wheelset_report::Verdict;
    if !f.adds_up {
        return Verdict::Fail;
    }
    let t = &f.total;
    let n = t.sent.max(1) as f64;
    b.rejected_frac
        .judge(t.rejected as f64 / n)
        .max(b.dropped_frac.judge(t.dropped as f64 / n))
}
