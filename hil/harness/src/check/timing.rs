//! Timing checks from what the host saw of each exchange. With `T` the control period,
//! `t_k = k T` the sample instants and `d` the ticks of delay the host applies each
//! actuation with (1: lock-step; more: a pipelined link):
//!
//! - **execution time**: each Actuation frame's `exec` (the device's previous tick: host
//!   ns in process, instructions under QEMU, cycles on a board), in ns by the
//!   transport's factor; min/mean/p99/max and a histogram.
//! - **latency**: `arrival of the first actuation echoing sample k - t_k`, judged as a
//!   share of `d T` (under lock-step, where the host's frame is the device's clock,
//!   modelled: both frames' wire time at the link's baud + the reported execution time).
//! - **period jitter**: the device's output instants (arrival - wire time - latency)
//!   against `t_0 + j T` (`j` the device's tick counter, `t_0` the earliest phase seen, so
//!   the maximum lateness is the peak-to-peak jitter); not applicable under lock-step.
//! - **missed ticks**: periods without an actuation echoing their own sample by
//!   `t_k + d T` (tick-counter gaps counted apart); **overruns**: execution time > T.
//! - **link utilisation**: mean bytes per period (both ways) x 10 bits / baud / T;
//!   pipelined, the larger of each direction's share of `T` and both's share of `d T`.

use serde::Serialize;
use wheelset_loop::sim_link::wire_ns;

use crate::budget::{Limit, TimingBudgets};
use wheelset_loop::exchange::{Period, RxActuation};
use wheelset_loop::transport::Clock;
use wheelset_report::{Stats, Verdict};

/// A histogram: `counts[i]` samples in `[edges[i], edges[i+1])` (the last bin closed).
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct Histogram {
    /// Bin edges, ns (`counts.len() + 1` of them).
    pub edges_ns: Vec<f64>,
    /// Counts per bin.
    pub counts: Vec<u64>,
}

impl Histogram {
    /// `bins` equal bins over `[min, max]` of `v`.
    #[must_use]
    pub fn of(v: &[f64], bins: usize) -> Self {
        let s = Stats::of(v);
        if v.is_empty() || bins == 0 {
            return Self::default();
        }
        let (lo, mut hi) = (s.min, s.max);
        if hi <= lo {
            hi = lo + 1.0;
        }
        let w = (hi - lo) / bins as f64;
        let edges_ns = (0..=bins).map(|i| lo + w * i as f64).collect();
        let mut counts = vec![0u64; bins];
        for &x in v {
            let i = (((x - lo) / w) as usize).min(bins - 1);
            counts[i] += 1;
        }
        Self { edges_ns, counts }
    }
}

/// One budgeted timing figure and its verdict.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Check {
    /// Budget name (`timing.<name>` in the budget file).
    pub name: String,
    /// The measured value (fraction of T unless `unit` says otherwise).
    pub value: f64,
    /// The limits.
    pub limit: Limit,
    /// Pass, warn or fail; `pass` with `applicable = false` when it cannot be measured on
    /// this target.
    pub verdict: Verdict,
    /// Whether the figure is measured on this target.
    pub applicable: bool,
}

/// The timing section of a run's report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct TimingReport {
    /// Worst verdict of the checks.
    pub verdict: Verdict,
    /// The time base.
    pub clock: Clock,
    /// Control period, ns.
    pub period_ns: u64,
    /// Periods run.
    pub periods: u64,
    /// The device's execution-time unit and its ns per unit.
    pub exec_unit: String,
    /// ns per exec unit.
    pub exec_ns_per_unit: f64,
    /// Whether the device measured its execution time (`false` in process: the figures
    /// below are zeros, not a measurement; `exec_note` says where real ones come from).
    pub exec_measured: bool,
    /// What the execution-time figures are, or where to get them when not measured.
    pub exec_note: String,
    /// Execution time per tick, in the device's unit.
    pub exec_units: Stats,
    /// Execution time per tick, ns.
    pub exec_ns: Stats,
    /// Histogram of the execution time, ns.
    pub exec_histogram: Histogram,
    /// Input-to-output latency, ns.
    pub latency_ns: Stats,
    /// Whether the latency is modelled (lock-step) rather than measured.
    pub latency_modelled: bool,
    /// Largest lateness of an output instant behind the ideal schedule (peak-to-peak
    /// jitter), ns (None: not applicable).
    pub jitter_max_ns: Option<f64>,
    /// RMS of the same, ns.
    pub jitter_rms_ns: Option<f64>,
    /// Periods without an actuation echoing their own sample by the deadline.
    pub missed_ticks: u64,
    /// Gaps in the device's tick counter (ticks whose frames never arrived valid).
    pub tick_gaps: u64,
    /// Ticks whose execution time exceeded the period.
    pub overruns: u64,
    /// Mean execution time / T.
    pub cpu_mean: f64,
    /// Max execution time / T.
    pub cpu_max: f64,
    /// Mean bytes per period, host -> device.
    pub bytes_up_per_period: f64,
    /// Mean bytes per period, device -> host.
    pub bytes_down_per_period: f64,
    /// Wire time of those bytes / T.
    pub link_utilisation: f64,
    /// Line rate, baud.
    pub baud: u32,
    /// Every budgeted figure.
    pub checks: Vec<Check>,
}

/// What the timing analysis needs to know about the transport.
#[derive(Debug, Clone, Copy)]
pub struct TimingContext {
    /// Time base.
    pub clock: Clock,
    /// Control period, ns.
    pub period_ns: u64,
    /// Ticks of delay the host applies each actuation with (at least 1).
    pub delay_ticks: u32,
    /// Line rate.
    pub baud: u32,
    /// One-way link latency, ns (0 if unknown).
    pub latency_ns: u64,
    /// Exec unit name.
    pub exec_unit: &'static str,
    /// ns per exec unit.
    pub exec_ns_per_unit: f64,
    /// Whether the device measures its execution time (not the in-process one).
    pub exec_measured: bool,
}

/// Where real execution-time figures come from, for a device that measures none (the
/// in-process one).
pub const EXEC_NOT_MEASURED: &str = "not measured: the in-process device runs on the host \
     and reports no execution time (0 in every Actuation frame); real figures: \
     --target qemu (instructions of the Cortex-M4/M3 firmware, deterministic; per \
     function: cargo xtask fw-bench) or a board (--target serial:PATH, DWT cycles at \
     --cpu-hz)";

/// Analyses one run.
#[must_use]
pub fn analyse(
    ctx: &TimingContext,
    periods: &[Period],
    acts: &[RxActuation],
    bytes: (u64, u64),
    b: &TimingBudgets,
) -> TimingReport {
    let t = ctx.period_ns as f64;
    // The first frame reports the tick before it, which did not exist: skip it.
    let exec_u: Vec<f64> = acts
        .iter()
        .skip(1)
        .map(|a| f64::from(a.frame.exec))
        .collect();
    let exec_n: Vec<f64> = exec_u.iter().map(|e| e * ctx.exec_ns_per_unit).collect();
    let exec_ns = Stats::of(&exec_n);
    let overruns = exec_n.iter().filter(|&&e| e > t).count() as u64;

    let lockstep = ctx.clock == Clock::LockStep;
    let mut latency = Vec::new();
    let mut seen = vec![false; periods.len()];
    for (i, a) in acts.iter().enumerate() {
        let Some(k) = a.echo else { continue };
        let Some(p) = periods.get(k as usize) else {
            continue;
        };
        if std::mem::replace(&mut seen[k as usize], true) {
            continue;
        }
        if lockstep {
            // Sensor frame on the wire + this tick's execution (reported by the next frame,
            // else this one's previous) + the actuation frame on the wire.
            let exec = acts.get(i + 1).unwrap_or(a).frame.exec;
            latency.push(
                (wire_ns(p.sensor_bytes, ctx.baud) + wire_ns(a.wire_bytes, ctx.baud)) as f64
                    + 2.0 * ctx.latency_ns as f64
                    + f64::from(exec) * ctx.exec_ns_per_unit,
            );
        } else {
            latency.push(a.at_ns.saturating_sub(p.t_ns) as f64);
        }
    }
    let latency_ns = Stats::of(&latency);
    let missed = periods.iter().filter(|p| p.echo_at_ns.is_none()).count() as u64;

    let steps: Vec<u16> = std::iter::once(0)
        .chain(
            acts.windows(2)
                .map(|w| w[1].frame.tick.wrapping_sub(w[0].frame.tick)),
        )
        .collect();
    let tick_gaps = steps
        .iter()
        .skip(1)
        .map(|&s| u64::from(s.saturating_sub(1)))
        .sum();
    let (jitter_max_ns, jitter_rms_ns) = if lockstep || acts.is_empty() {
        (None, None)
    } else {
        let ticks: Vec<(f64, f64)> = acts
            .iter()
            .zip(&steps)
            .scan(0i64, |j, (a, &step)| {
                *j += i64::from(step);
                let wire = wire_ns(a.wire_bytes, ctx.baud) as f64;
                Some((*j as f64, a.at_ns as f64 - wire - ctx.latency_ns as f64))
            })
            .collect();
        let t0 = ticks
            .iter()
            .map(|&(j, o)| o - j * t)
            .fold(f64::INFINITY, f64::min);
        let dev: Vec<f64> = ticks.iter().map(|&(j, o)| o - (t0 + j * t)).collect();
        let max = dev.iter().fold(0.0f64, |m, d| m.max(d.abs()));
        let rms = (dev.iter().map(|d| d * d).sum::<f64>() / dev.len() as f64).sqrt();
        (Some(max), Some(rms))
    };

    let n = periods.len().max(1) as f64;
    let (up, down) = (bytes.0 as f64 / n, bytes.1 as f64 / n);
    let bits = wheelset_proto::link::BITS_PER_BYTE as f64;
    let d = f64::from(ctx.delay_ticks.max(1));
    let line = |bytes: f64| bytes * bits / f64::from(ctx.baud.max(1)) * 1e9;
    let link = (line(up + down) / (d * t)).max(line(up.max(down)) / t);
    let cpu_mean = exec_ns.mean / t;
    let cpu_max = exec_ns.max / t;
    let measured = !exec_n.is_empty();
    let overrun_frac = overruns as f64 / exec_n.len().max(1) as f64;
    let (lat, jit) = (latency_ns.max / (d * t), jitter_max_ns.unwrap_or(0.0) / t);
    let checks: Vec<Check> = [
        ("latency_max", lat, b.latency_max, !latency.is_empty()),
        ("jitter_max", jit, b.jitter_max, jitter_max_ns.is_some()),
        ("missed_frac", missed as f64 / n, b.missed_frac, true),
        ("overrun_frac", overrun_frac, b.overrun_frac, measured),
        ("cpu_max", cpu_max, b.cpu_max, measured),
        ("cpu_mean", cpu_mean, b.cpu_mean, measured),
        ("link", link, b.link, true),
    ]
    .into_iter()
    .map(|(name, value, limit, applicable)| Check {
        name: name.into(),
        value,
        limit,
        verdict: if applicable {
            limit.judge(value)
        } else {
            Verdict::Pass
        },
        applicable,
    })
    .collect();
    let verdict = checks
        .iter()
        .map(|c| c.verdict)
        .max()
        .unwrap_or(Verdict::Pass);
    TimingReport {
        verdict,
        clock: ctx.clock,
        period_ns: ctx.period_ns,
        periods: periods.len() as u64,
        exec_unit: ctx.exec_unit.into(),
        exec_ns_per_unit: ctx.exec_ns_per_unit,
        exec_measured: ctx.exec_measured,
        exec_note: if ctx.exec_measured {
            format!(
                "measured by the device: {} per tick, {} ns each",
                ctx.exec_unit, ctx.exec_ns_per_unit
            )
        } else if exec_u.iter().any(|&e| e > 0.0) {
            format!(
                "simulated, not measured: the in-process device's fault model sets it; {}",
                EXEC_NOT_MEASURED.trim_start_matches("not measured: ")
            )
        } else {
            EXEC_NOT_MEASURED.to_string()
        },
        exec_units: Stats::of(&exec_u),
        exec_ns,
        exec_histogram: Histogram::of(&exec_n, 20),
        latency_ns,
        latency_modelled: lockstep,
        jitter_max_ns,
        jitter_rms_ns,
        missed_ticks: missed,
        tick_gaps,
        overruns,
        cpu_mean,
        cpu_max,
        bytes_up_per_period: up,
        bytes_down_per_period: down,
        link_utilisation: link,
        baud: ctx.baud,
        checks,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stats_and_histogram() {
        let v: Vec<f64> = (1..=100).map(f64::from).collect();
        let s = Stats::of(&v);
        assert_eq!((s.min, s.max, s.p99, s.mean), (1.0, 100.0, 99.0, 50.5));
        let h = Histogram::of(&v, 4);
        assert_eq!(h.counts.iter().sum::<u64>(), 100);
        assert_eq!(h.edges_ns.len(), 5);
        assert_eq!(h.counts, vec![25, 25, 25, 25]);
        assert_eq!(Stats::of(&[]).n, 0);
    }
}
