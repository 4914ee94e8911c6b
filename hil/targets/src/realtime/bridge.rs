//! A USB-serial bridge's latency, modelled in `hil serve`: each byte run is held, in FIFO
//! order, for `L + u` (`u` seeded uniform in `0 ..= J` ns) plus its wire time.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use serde::Serialize;

/// Bytes a bridge holds in each direction before it drops a run.
pub const BRIDGE_BYTES: usize = 4096;

/// The longest latency or jitter the model takes, us (1 s).
pub const MAX_US: f64 = 1e6;

/// A bridge's latency: a fixed one-way delay and a uniform jitter on top, seeded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize)]
pub struct BridgeModel {
    /// The fixed one-way delay, ns.
    pub latency_ns: u64,
    /// The jitter's range: each run's delay is `latency_ns + 0 ..= jitter_ns`.
    pub jitter_ns: u64,
    /// The generator's seed.
    pub seed: u64,
    /// The UART's line rate, baud (0: none, bytes take no wire time).
    pub baud: u32,
}

impl BridgeModel {
    /// Whether the model delays nothing (the default: bytes go through as written and read).
    #[must_use]
    pub fn is_none(&self) -> bool {
        self.latency_ns == 0 && self.jitter_ns == 0 && self.baud == 0
    }

    /// The same with the UART's line rate `baud` (0: none).
    #[must_use]
    pub fn with_baud(self, baud: u32) -> Self {
        Self { baud, ..self }
    }

    /// The wire time of `n` bytes, ns (0 without a line rate).
    #[must_use]
    pub fn wire_ns(&self, n: usize) -> u64 {
        if self.baud == 0 {
            0
        } else {
            (n as u64 * 10 * 1_000_000_000).div_ceil(u64::from(self.baud))
        }
    }

    /// The model from the command line's microseconds (each finite, in `[0, MAX_US]`).
    pub fn from_us(latency_us: f64, jitter_us: f64, seed: u64) -> Result<Self, String> {
        let ns = |flag: &str, us: f64| {
            if us.is_finite() && (0.0..=MAX_US).contains(&us) {
                Ok((us * 1e3).round() as u64)
            } else {
                Err(format!(
                    "{flag} {us}: must be a finite number of microseconds in [0, {MAX_US}] \
                     (the modelled USB bridge's one-way {})",
                    if flag == "--latency-us" {
                        "delay"
                    } else {
                        "jitter"
                    }
                ))
            }
        };
        Ok(Self {
            latency_ns: ns("--latency-us", latency_us)?,
            jitter_ns: ns("--jitter-us", jitter_us)?,
            seed,
            baud: 0,
        })
    }
}

/// What one direction of the bridge did (the `bridge` section of `hil serve --json`).
#[derive(Debug, Clone, Copy, Serialize, Default, PartialEq, Eq)]
pub struct LineReport {
    /// Byte runs delayed.
    pub runs: u64,
    /// Runs dropped (the bridge full).
    pub dropped: u64,
    /// The least and the largest delay drawn, ns.
    pub delay_min_ns: u64,
    /// See `delay_min_ns`.
    pub delay_max_ns: u64,
    /// The largest lateness of a release behind its due time, ns.
    pub release_late_max_ns: u64,
}

/// One direction of the bridge: byte runs held until their release, in order.
#[derive(Debug)]
pub struct DelayLine {
    model: BridgeModel,
    rng: SplitMix64,
    runs: VecDeque<(Instant, Vec<u8>)>,
    bytes: usize,
    last: Option<Instant>,
    report: LineReport,
}

impl DelayLine {
    /// A line of `model`; `stream` tells the directions' generators apart.
    #[must_use]
    pub fn new(model: BridgeModel, stream: u64) -> Self {
        Self {
            model,
            rng: SplitMix64(model.seed ^ stream.wrapping_mul(0xa076_1d64_78bd_642f)),
            runs: VecDeque::new(),
            bytes: 0,
            last: None,
            report: LineReport::default(),
        }
    }

    /// The next delay drawn, ns.
    pub fn draw_ns(&mut self) -> u64 {
        let j = self.model.jitter_ns;
        let u = if j == 0 {
            0
        } else {
            self.rng.next_u64() % (j + 1)
        };
        self.model.latency_ns + u
    }

    /// Holds `bytes`, arrived at `now`, for a drawn delay and their wire time, behind the
    /// run ahead; false (dropped) when full.
    pub fn push(&mut self, now: Instant, bytes: &[u8]) -> bool {
        if bytes.is_empty() {
            return true;
        }
        if self.bytes + bytes.len() > BRIDGE_BYTES {
            self.report.dropped += 1;
            return false;
        }
        let d = self.draw_ns();
        if self.report.runs == 0 {
            self.report.delay_min_ns = d;
        }
        self.report.runs += 1;
        self.report.delay_min_ns = self.report.delay_min_ns.min(d);
        self.report.delay_max_ns = self.report.delay_max_ns.max(d);
        let at = now + Duration::from_nanos(d);
        let at = self.last.map_or(at, |l| at.max(l))
            + Duration::from_nanos(self.model.wire_ns(bytes.len()));
        self.last = Some(at);
        self.bytes += bytes.len();
        self.runs.push_back((at, bytes.to_vec()));
        true
    }

    /// The run due by `now`, if any (the oldest first).
    pub fn pop_due(&mut self, now: Instant) -> Option<Vec<u8>> {
        let (at, _) = self.runs.front()?;
        if *at > now {
            return None;
        }
        let late = u64::try_from(now.duration_since(*at).as_nanos()).unwrap_or(u64::MAX);
        self.report.release_late_max_ns = self.report.release_late_max_ns.max(late);
        let (_, run) = self.runs.pop_front()?;
        self.bytes -= run.len();
        Some(run)
    }

    /// When the oldest run is due.
    #[must_use]
    pub fn next_release(&self) -> Option<Instant> {
        self.runs.front().map(|r| r.0)
    }

    /// What the line did.
    #[must_use]
    pub fn report(&self) -> LineReport {
        self.report
    }
}

/// SplitMix64: the same stream for the same seed on every platform.
#[derive(Debug, Clone)]
struct SplitMix64(u64);

impl SplitMix64 {
    fn next_u64(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn model(l: u64, j: u64, seed: u64) -> BridgeModel {
        BridgeModel {
            latency_ns: l,
            jitter_ns: j,
            seed,
            baud: 0,
        }
    }

    #[test]
    fn the_same_seed_draws_the_same_delays_within_the_model_s_range() {
        let draws = |seed, stream| {
            let mut l = DelayLine::new(model(900_000, 100_000, seed), stream);
            (0..1_000).map(|_| l.draw_ns()).collect::<Vec<_>>()
        };
        let a = draws(7, 0);
        assert_eq!(a, draws(7, 0));
        assert_ne!(a, draws(8, 0));
        // The two directions draw apart.
        assert_ne!(a, draws(7, 1));
        assert!(a.iter().all(|d| (900_000..=1_000_000).contains(d)), "{a:?}");
        // The range is covered, not one end of it.
        let (lo, hi) = (a.iter().min().copied(), a.iter().max().copied());
        assert!(lo < Some(910_000) && hi > Some(990_000), "{lo:?} {hi:?}");
        // Without jitter, the latency exactly.
        let mut l = DelayLine::new(model(1_000, 0, 3), 0);
        assert!((0..10).all(|_| l.draw_ns() == 1_000));
    }

    #[test]
    fn runs_are_released_in_order_after_their_delay() {
        let t0 = Instant::now();
        let mut l = DelayLine::new(model(1_000_000, 500_000, 1), 0);
        for i in 0..50u8 {
            assert!(l.push(t0 + Duration::from_micros(u64::from(i) * 10), &[i, 0]));
        }
        assert_eq!(l.pop_due(t0 + Duration::from_micros(999)), None);
        let mut out = Vec::new();
        let mut prev = t0;
        while let Some(at) = l.next_release() {
            assert!(at >= prev && at >= t0 + Duration::from_millis(1));
            assert!(at <= t0 + Duration::from_micros(490 + 1_500));
            prev = at;
            out.extend(l.pop_due(at).unwrap_or_default());
        }
        let want: Vec<u8> = (0..50u8).flat_map(|i| [i, 0]).collect();
        assert_eq!(out, want);
        let r = l.report();
        assert_eq!((r.runs, r.dropped, r.release_late_max_ns), (50, 0, 0));
        assert!(r.delay_min_ns >= 1_000_000 && r.delay_max_ns <= 1_500_000);
    }

    #[test]
    fn a_line_rate_adds_each_run_s_wire_time_after_the_one_ahead() {
        let t0 = Instant::now();
        // 1 Mbaud: 10 us a byte.
        let m = model(100_000, 0, 0).with_baud(1_000_000);
        assert!(!m.is_none() && !model(0, 0, 0).with_baud(9_600).is_none());
        assert_eq!(m.wire_ns(30), 300_000);
        let mut l = DelayLine::new(m, 0);
        assert!(l.push(t0, &[0; 30]));
        assert!(l.push(t0, &[1; 10]));
        let us = |a: Option<Instant>| a.map(|a| a.duration_since(t0).as_micros());
        // 100 us of latency, then 300 us on the wire; the second behind it.
        assert_eq!(us(l.next_release()), Some(400));
        l.pop_due(t0 + Duration::from_micros(400));
        assert_eq!(us(l.next_release()), Some(500));
    }

    #[test]
    fn a_full_bridge_drops_the_run_whole() {
        let t0 = Instant::now();
        let mut l = DelayLine::new(model(1_000, 0, 0), 0);
        assert!(l.push(t0, &[0; BRIDGE_BYTES - 10]));
        assert!(!l.push(t0, &[1; 11]));
        assert!(l.push(t0, &[2; 10]));
        assert_eq!(l.report().dropped, 1);
        let t1 = t0 + Duration::from_micros(1);
        assert_eq!(l.pop_due(t1).map(|r| r.len()), Some(BRIDGE_BYTES - 10));
        assert_eq!(l.pop_due(t1), Some(vec![2; 10]));
        assert_eq!(l.pop_due(t1), None);
    }

    #[test]
    fn bad_values_are_refused_with_the_flag_and_the_range() {
        assert_eq!(
            BridgeModel::from_us(0.0, 0.0, 0),
            Ok(BridgeModel::default())
        );
        assert_eq!(
            BridgeModel::from_us(1_000.0, 250.5, 9),
            Ok(model(1_000_000, 250_500, 9))
        );
        for (l, j, flag) in [
            (-1.0, 0.0, "--latency-us -1"),
            (f64::NAN, 0.0, "--latency-us NaN"),
            (f64::INFINITY, 0.0, "--latency-us inf"),
            (2e6, 0.0, "--latency-us 2000000"),
            (0.0, -5.0, "--jitter-us -5"),
            (0.0, f64::NAN, "--jitter-us NaN"),
        ] {
            let e = BridgeModel::from_us(l, j, 0).err().unwrap_or_default();
            assert!(e.starts_with(flag) && e.contains("[0, 1000000]"), "{e}");
        }
    }
}
