//! `hil sweep`: the closed loop of `hil run` at every point of a parameter grid, on all
//! cores, and the merge of shards (`docs/campaigns.md`).
//!
//! The grid is the Cartesian product of the `--param` axes, the last varying fastest
//! (point `i`'s axis indices are `i` in the mixed radix of the axis lengths). An axis
//! `KEY=FROM..TO:N` has the values `v_j = FROM + (TO - FROM) j / (N - 1)`, `j = 0..N-1`
//! (`N = 1` needs `FROM = TO`), `KEY=VALUE` one value; `KEY` is a parameter key (SI);
//! `f11` sets `f22` too unless `f22` is an axis of its own. A point's parameters are the
//! base with the point's values on top, then the scenario's `[params]`; a scenario that
//! would override a swept key is refused. Every point runs the same fault seed, so the
//! records depend on the grid and the seed only, not on threads, shards or machines.
//!
//! `--shard I/N` runs part of the grid ([`shard`]); [`merge`] joins the shards' documents
//! ([`atomic`], with the campaign's [`Identity`], no timing) into the single run's, byte for byte.

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc;

use serde::{Deserialize, Serialize};
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;

use crate::run::{run, RunError, RunOptions, RunReport};
use wheelset_report::Verdict;

pub mod atomic;
pub mod document;
mod grid;
mod identity;
mod merge;
pub mod shard;
pub mod throughput;
pub use grid::*;
pub use identity::*;
pub use merge::merge;
pub use shard::{resolve, Shard, ShardSpec};

/// What fixes a campaign's result: the first part of its document, equal in every shard.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Header {
    /// `--scenario` as given.
    pub scenario: String,
    /// The yaw law.
    pub control: crate::run::Law,
    /// The target.
    pub target: String,
    /// The link faults applied (canonical spec; empty: none).
    pub faults: String,
    /// The seed of the link's faults, the same at every point.
    pub seed: u64,
    /// `--params FILE` as given (None: the paper's parameters; its content is
    /// `identity.params_sha256`).
    pub params_file: Option<String>,
    /// `--budget FILE` as given (its content is `identity.budget_sha256`).
    pub budget_file: Option<String>,
    /// `--set` overrides as given.
    pub sets: Vec<String>,
    /// The axes, in grid order (the last varies fastest).
    pub axes: Vec<Axis>,
    /// Keys set with another axis: `f22` follows `f11` unless it is an axis.
    pub follows: Vec<(String, String)>,
    /// Grid points in all.
    pub points: usize,
    /// The build and the input files by content.
    pub identity: Identity,
}

/// One failing (or warning) check of a point.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Failing {
    /// The check: `timing.NAME`, `numerics.SIGNAL`, `numerics.diverged`, `frames`,
    /// `monitor`.
    pub check: String,
    /// Warn or fail.
    pub verdict: Verdict,
    /// Why, with the figures.
    pub reason: String,
}

/// One grid point's result.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Record {
    /// Index in the grid.
    pub index: usize,
    /// The point's parameters: the axis keys, then their followers (a JSON object, in order).
    pub params: indexmap::IndexMap<String, f64>,
    /// The run's verdict (worst of timing, numerics, frames, monitor).
    pub verdict: Verdict,
    /// Peak `|y|` of the closed loop through the device, m.
    pub peak_abs_y_m: f64,
    /// Time the closed loop diverged and was stopped, s.
    pub diverged_at_s: Option<f64>,
    /// The checks that did not pass, with their reasons.
    pub failing: Vec<Failing>,
}

/// Verdict counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Summary {
    /// Points that passed.
    pub pass: usize,
    /// Points that warned.
    pub warn: usize,
    /// Points that failed.
    pub fail: usize,
}

impl Summary {
    /// The counts of `records`.
    #[must_use]
    pub fn of(records: &[Record]) -> Self {
        let mut s = Summary::default();
        for r in records {
            match r.verdict {
                Verdict::Pass => s.pass += 1,
                Verdict::Warn => s.warn += 1,
                Verdict::Fail => s.fail += 1,
            }
        }
        s
    }
}

/// The document of `hil sweep --json` (and of `hil sweep merge`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SweepDoc {
    /// What fixes the result.
    pub sweep: Header,
    /// The shard this document holds (absent: every point).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shard: Option<Shard>,
    /// Verdict counts over `records`.
    pub summary: Summary,
    /// One record per point run, in index order.
    pub records: Vec<Record>,
}

/// A campaign's definition.
#[derive(Debug, Clone)]
pub struct Campaign {
    /// What each point's run shares; its `params` are the base.
    pub base: RunOptions,
    /// The header written into the document (the caller fills the file names).
    pub header: Header,
}

/// The parameters of one point: `base` with the point's values on top, validated. The
/// error names the flag and the point.
pub fn point_params(base: &Params, point: &[(String, f64)]) -> Result<Params, String> {
    let mut t = toml::Table::new();
    for (k, v) in point {
        t.insert(k.clone(), toml::Value::Float(*v));
    }
    base.with_overrides(&t, "--param").map_err(|e| {
        let at: Vec<String> = point.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        format!("--param: at {}: {e}", at.join(", "))
    })
}

/// Checks every point before any runs: its parameters are plausible, and the scenario's
/// `[params]` do not override a swept key. Returns each point's parameters.
pub fn prepare(c: &Campaign) -> Result<Vec<(Point, Params)>, String> {
    let pts = points(&c.header.axes, &c.header.follows);
    let mut out = Vec::with_capacity(pts.len());
    for p in pts {
        let params = point_params(&c.base.params, &p)?;
        let sc = Scenario::load(&c.base.scenario, &params).map_err(|e| e.to_string())?;
        let applied = sc.params.entries();
        for (k, v) in &p {
            if let Some(&(_, a)) = applied.iter().find(|(key, _)| key == k) {
                if a != *v {
                    return Err(format!(
                        "--param {k}: scenario {} sets {k} = {a} in its [params], which applies \
                         on top of the sweep's {v}; sweep a copy of the scenario without that key",
                        sc.source
                    ));
                }
            }
        }
        out.push((p, params));
    }
    Ok(out)
}

/// The checks of `r` that did not pass, with their reasons.
#[must_use]
pub fn failing(r: &RunReport) -> Vec<Failing> {
    let mut out = Vec::new();
    let mut add = |check: String, verdict, reason| {
        out.push(Failing {
            check,
            verdict,
            reason,
        });
    };
    for c in r
        .timing
        .checks
        .iter()
        .filter(|c| c.verdict != Verdict::Pass)
    {
        let (v, l) = (c.verdict, c.limit);
        let why = format!(
            "{:.4} above the {v} limit {} (warn {}, fail {})",
            c.value,
            l.crossed(v),
            l.warn,
            l.fail
        );
        add(format!("timing.{}", c.name), v, why);
    }
    let n = &r.numerics;
    let diverged = n.verdict.max(Verdict::Warn);
    if let Some(t) = n.run_diverged_at_s {
        let why = format!("the closed loop diverged at {t:.3} s (run stopped)");
        add("numerics.diverged".into(), diverged, why);
    }
    if let Some(t) = n.reference_diverged_at_s {
        let why = format!("the f64 reference ({}) diverged at {t:.3} s", n.reference);
        add("numerics.reference_diverged".into(), diverged, why);
    }
    for s in n.signals.iter().filter(|s| s.verdict != Verdict::Pass) {
        let why = format!(
            "max error {:.3e} at {:.3} s against {} (allowed {:.3e})",
            s.max_err, s.max_err_t_s, n.reference, s.allowed
        );
        add(format!("numerics.{}", s.name), s.verdict, why);
    }
    if r.frames_verdict != Verdict::Pass {
        let f = &r.frames;
        let adds_up = if f.adds_up { "" } else { " does not add up" };
        add(
            "frames".into(),
            r.frames_verdict,
            format!("{}{adds_up}", f.total),
        );
    }
    if r.monitor.verdict != Verdict::Pass {
        add(
            "monitor".into(),
            r.monitor.verdict,
            r.monitor.reason.clone(),
        );
    }
    out
}

fn run_point(
    c: &Campaign,
    index: usize,
    point: &[(String, f64)],
    params: &Params,
) -> Result<Record, RunError> {
    let out = run(&RunOptions {
        params: params.clone(),
        progress: false,
        ..c.base.clone()
    })?;
    let peak = out
        .trajectory
        .records
        .iter()
        .map(|r| r.y_m.abs())
        .fold(0.0, f64::max);
    Ok(Record {
        index,
        params: point.iter().cloned().collect(),
        verdict: out.report.verdict,
        peak_abs_y_m: peak,
        diverged_at_s: out.trajectory.info.diverged_at_s,
        failing: failing(&out.report),
    })
}

/// Runs the points of `shard` (every point without one) on `jobs` threads, calling
/// `progress(done, total)` after each point; the records in index order, whatever the
/// threads' order; and the campaign's cost ([`throughput::Throughput`], not in the document).
pub fn run_campaign(
    c: &Campaign,
    shard: Option<Shard>,
    jobs: usize,
    progress: &mut dyn FnMut(usize, usize),
) -> Result<(SweepDoc, throughput::Throughput), RunError> {
    let wall = std::time::Instant::now();
    let main_cpu = throughput::thread_cpu();
    // Each point's QEMU is a child, waited for when its point ends.
    let children_cpu = throughput::children_cpu();
    let all = prepare(c).map_err(RunError::Input)?;
    let mine: Vec<(usize, &(Point, Params))> = all
        .iter()
        .enumerate()
        .filter(|(i, _)| shard.is_none_or(|s| s.holds(*i)))
        .collect();
    let total = mine.len();
    let next = AtomicUsize::new(0);
    let stop = AtomicBool::new(false);
    let (tx, rx) = mpsc::channel::<Result<Record, RunError>>();
    let mut records = Vec::with_capacity(total);
    let mut first_err = None;
    // The CPU time of the worker threads (None: one could not read its own).
    let workers_cpu = std::thread::scope(|s| {
        let workers: Vec<_> = (0..jobs.clamp(1, total.max(1)))
            .map(|_| {
                let tx = tx.clone();
                let (next, stop, mine) = (&next, &stop, &mine);
                s.spawn(move || {
                    while !stop.load(Ordering::Relaxed) {
                        let Some((i, (p, params))) = mine.get(next.fetch_add(1, Ordering::Relaxed))
                        else {
                            break;
                        };
                        if tx.send(run_point(c, *i, p, params)).is_err() {
                            break;
                        }
                    }
                    throughput::thread_cpu()
                })
            })
            .collect();
        drop(tx);
        for r in rx {
            match r {
                Ok(rec) => {
                    records.push(rec);
                    progress(records.len(), total);
                }
                Err(e) => {
                    stop.store(true, Ordering::Relaxed);
                    first_err.get_or_insert(e);
                }
            }
        }
        workers
            .into_iter()
            .map(|w| w.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .sum::<Option<std::time::Duration>>()
    });
    if let Some(e) = first_err {
        return Err(e);
    }
    records.sort_by_key(|r| r.index);
    let main = main_cpu
        .zip(throughput::thread_cpu())
        .map(|(a, b)| b.saturating_sub(a));
    let children = children_cpu
        .zip(throughput::children_cpu())
        .map(|(a, b)| b.saturating_sub(a));
    let cost = throughput::Throughput {
        points: records.len(),
        cpu: main
            .zip(children)
            .zip(workers_cpu)
            .map(|((m, c), w)| m + c + w),
        wall: wall.elapsed(),
    };
    let doc = SweepDoc {
        sweep: c.header.clone(),
        shard: shard.filter(|s| s.count > 1),
        summary: Summary::of(&records),
        records,
    };
    Ok((doc, cost))
}
