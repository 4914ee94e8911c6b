//! What a traction engineer reads from an adhesion run: the creep characteristic of a
//! rail condition (`sim-host adhesion`), the per-section adhesion summary of a run
//! (`sim-host run --json`), the runaway verdict, and the traction figure.
//!
//! # Section summary
//! For each `[[adhesion]]` section `[t0, t1)` of the scenario, over the records in it:
//! `mu_peak` = mean of [`Record::mu_avail`] (the condition's peak at the speed of the
//! moment), `mu_used_mean` = mean of [`Record::mu_used`] (`(F_xR + F_xL)/(2Q)`),
//! `utilisation = mu_used_mean / mu_peak`, `slip_peak_mps` = largest `|slip_mps|`.
//! A section the records do not reach (a run stopped as diverged before it) has every
//! figure NaN (`null` in the JSON).
//!
//! # Runaway
//! A run **runs away** when the wheelset's slip velocity `|slip_mps|` stays above
//! [`RUNAWAY_SLIP_MPS`] = 3 m/s for [`RUNAWAY_HOLD_S`] = 1 s without a break (or until
//! the records end, when a run was stopped as diverged while above it). 3 m/s is past
//! the adhesion peak of every condition at every speed of the scenarios (the peaks lie
//! at 0.2-1.5 m/s of slip, `sim-host adhesion`), where the force falls as slip grows:
//! a wheel held there for a second by its motor torque is accelerating away, not
//! creeping.

use crate::adhesion::{Adhesion, Condition};
use crate::params::Params;
use crate::scenario::Scenario;
use crate::sim::{Record, Trajectory};
use crate::svg::{Figure, Plot, Series, Style, PALETTE};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Slip velocity above which a wheel counts as running away (with [`RUNAWAY_HOLD_S`]), m/s.
pub const RUNAWAY_SLIP_MPS: f64 = 3.0;
/// How long the slip must stay above [`RUNAWAY_SLIP_MPS`], s.
pub const RUNAWAY_HOLD_S: f64 = 1.0;

/// The creep characteristic `F/Q` against longitudinal creepage of one condition.
#[derive(Debug, Clone, Serialize)]
pub struct Characteristic {
    /// Rail condition.
    pub condition: Condition,
    /// Where its parameters come from.
    pub source: &'static str,
    /// Speed, m/s (the slip velocity is `creepage * v_mps`).
    pub v_mps: f64,
    /// Wheel load `Q`, N.
    pub q_n: f64,
    /// Longitudinal creep coefficient `f11`, N (the slope at zero creepage).
    pub f11_n: f64,
    /// Polach `mu0`.
    pub mu0: f64,
    /// Polach `A`.
    pub a: f64,
    /// Polach `B`, s/m.
    pub b: f64,
    /// Polach `kA`.
    pub ka: f64,
    /// Polach `kS`.
    pub ks: f64,
    /// Creepage of each point, 0..=0.2.
    pub creepage: Vec<f64>,
    /// `F/Q` at each point.
    pub force_over_q: Vec<f64>,
    /// Peak `F/Q` (adhesion available).
    pub mu_peak: f64,
    /// Creepage at the peak.
    pub creepage_peak: f64,
    /// Slip velocity at the peak, m/s.
    pub slip_peak_mps: f64,
}

/// The characteristic of `condition` at speed `v` with `p`'s `Q` and `f11`, `points`
/// evenly spaced creepages over 0..=0.2.
pub fn characteristic(condition: Condition, v: f64, p: &Params, points: usize) -> Characteristic {
    let law = condition.polach();
    let q = p.q();
    let n = points.max(2);
    let creepage: Vec<f64> = (0..n).map(|i| 0.2 * i as f64 / (n - 1) as f64).collect();
    let force_over_q = creepage
        .iter()
        .map(|&s| law.force_over_q(q, p.f11, s, v))
        .collect();
    let (s_peak, mu_peak) = law.peak(q, p.f11, v, 0.2);
    Characteristic {
        condition,
        source: condition.source(),
        v_mps: v,
        q_n: q,
        f11_n: p.f11,
        mu0: law.mu0,
        a: law.a,
        b: law.b,
        ka: law.ka,
        ks: law.ks,
        creepage,
        force_over_q,
        mu_peak,
        creepage_peak: s_peak,
        slip_peak_mps: s_peak * v,
    }
}

impl Characteristic {
    /// The SVG of the characteristic (and of the linear law for comparison).
    pub fn figure(&self) -> Figure {
        let pts: Vec<(f64, f64)> = self
            .creepage
            .iter()
            .zip(&self.force_over_q)
            .map(|(&s, &f)| (s, f))
            .collect();
        let lin: Vec<(f64, f64)> = self
            .creepage
            .iter()
            .map(|&s| (s, self.f11_n * s / self.q_n))
            .take_while(|&(_, f)| f <= 1.5 * self.mu_peak)
            .collect();
        let plot = Plot::new(&format!(
            "Polach creep characteristic, {} rail, v = {} m/s (peak {:.3} at creepage {:.4})",
            self.condition, self.v_mps, self.mu_peak, self.creepage_peak
        ))
        .x_label("longitudinal creepage (1)")
        .y_label("F / Q (1)")
        .series(Series::line(&format!("{}", self.condition), pts))
        .series(
            Series::line("linear law f11 s / Q", lin)
                .style(Style::Dashed)
                .color("#000"),
        )
        .hline(self.mu_peak);
        Figure::new(&format!("adhesion: {}", self.source)).panel(plot)
    }
}

/// One section of the summary.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct SectionSummary {
    /// Start, s.
    pub t0: f64,
    /// End, s.
    pub t1: f64,
    /// Rail condition.
    pub condition: Condition,
    /// Mean peak adhesion available over the section.
    pub mu_peak: f64,
    /// Mean adhesion used.
    pub mu_used_mean: f64,
    /// `mu_used_mean / mu_peak`.
    pub utilisation: f64,
    /// Largest `|slip_mps|` in the section, m/s.
    pub slip_peak_mps: f64,
}

/// The `adhesion` object of a run's summary JSON.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct AdhesionSummary {
    /// Per `[[adhesion]]` section, in order.
    pub sections: Vec<SectionSummary>,
    /// Whether a wheel ran away (module docs).
    pub runaway: bool,
    /// Largest `|slip_mps|` over the run, m/s.
    pub slip_peak_mps: f64,
}

/// Whether the records show a runaway (module docs); `stopped` = the run was stopped
/// as diverged, so records ending above the threshold count.
pub fn runaway(records: &[Record], stopped: bool) -> bool {
    let mut since: Option<f64> = None;
    for r in records {
        if r.slip_mps.abs() > RUNAWAY_SLIP_MPS {
            let t0 = *since.get_or_insert(r.t_s);
            if r.t_s - t0 >= RUNAWAY_HOLD_S {
                return true;
            }
        } else {
            since = None;
        }
    }
    since.is_some() && stopped
}

/// The adhesion summary of `tr`, a run of `sc` (`None` without `[[adhesion]]`).
pub fn summary(sc: &Scenario, tr: &Trajectory) -> Option<AdhesionSummary> {
    if sc.adhesion.is_empty() {
        return None;
    }
    let sections = sc
        .adhesion
        .iter()
        .map(|s| {
            let (t0, t1) = (s.t0_ns as f64 * 1e-9, s.t1_ns as f64 * 1e-9);
            let inside: Vec<&Record> = tr
                .records
                .iter()
                .filter(|r| r.t_s >= t0 && r.t_s < t1)
                .collect();
            // No records (the run stopped before the section): NaN, `null` in JSON.
            let n = if inside.is_empty() {
                f64::NAN
            } else {
                inside.len() as f64
            };
            let mu_peak = inside.iter().map(|r| r.mu_avail).sum::<f64>() / n;
            let mu_used_mean = inside.iter().map(|r| r.mu_used).sum::<f64>() / n;
            let slip_peak_mps = inside
                .iter()
                .map(|r| r.slip_mps.abs())
                .fold(f64::NAN, f64::max);
            SectionSummary {
                t0,
                t1,
                condition: s.condition,
                mu_peak,
                mu_used_mean,
                utilisation: mu_used_mean / mu_peak,
                slip_peak_mps,
            }
        })
        .collect();
    Some(AdhesionSummary {
        sections,
        runaway: runaway(&tr.records, tr.info.diverged_at_s.is_some()),
        slip_peak_mps: tr
            .records
            .iter()
            .fold(0.0f64, |a, r| a.max(r.slip_mps.abs())),
    })
}

/// The adhesion law of `condition` with `p`'s wheel load (a convenience for tools).
pub fn law(condition: Condition, p: &Params) -> Adhesion {
    Adhesion::new(condition, p.q())
}

/// One run of [`write_figure`].
#[derive(Debug, Clone, Copy)]
pub struct FigureRun<'a> {
    /// Legend label (e.g. `protection on`).
    pub label: &'a str,
    /// The run.
    pub tr: &'a Trajectory,
    /// The slip regulator's set point while the protection acted, `(t_s, m/s)`
    /// ([`crate::core_loop::CoreRun::set_point`]); empty for a run without protection.
    pub set_point: &'a [(f64, f64)],
}

/// The traction engineer's figure (`adhesion.svg` in `dir`): traction force delivered,
/// then the slip velocity of each run in its own panel and scale (a protected wheel's
/// tenths of m/s against its regulator's set point and the detection threshold
/// `slip_on_mps`; an unprotected one's runaway against the runaway threshold), then the
/// adhesion available and used. Each run keeps its colour across the panels.
pub fn write_figure(
    runs: &[FigureRun<'_>],
    slip_on_mps: f64,
    dir: &Path,
) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(dir)?;
    let colour = |k: usize| PALETTE[k % PALETTE.len()];
    // One time axis for every panel: a run stopped as diverged ends early.
    let end = runs
        .iter()
        .filter_map(|r| r.tr.records.last().map(|x| x.t_s))
        .fold(0.0f64, f64::max);
    let panel = |title: &str, y_label: &str| {
        let p = Plot::new(title).x_label("t (s)").y_label(y_label);
        if end > 0.0 {
            p.x_range(0.0, end)
        } else {
            p
        }
    };
    let mut force = panel("Traction force delivered F_xR + F_xL", "F (kN)");
    let mut mu = panel("Adhesion available (peak) and used", "F / Q (1)");
    let mut slips = Vec::new();
    for (k, run) in runs.iter().enumerate() {
        let pts = |f: &dyn Fn(&Record) -> f64| -> Vec<(f64, f64)> {
            run.tr.records.iter().map(|r| (r.t_s, f(r))).collect()
        };
        force = force.series(
            Series::line(run.label, pts(&|r| (r.fx_r_n + r.fx_l_n) * 1e-3)).color(colour(k)),
        );
        mu = mu.series(
            Series::line(&format!("used, {}", run.label), pts(&|r| r.mu_used)).color(colour(k)),
        );
        if k == 0 {
            mu = mu.series(
                Series::line("available", pts(&|r| r.mu_avail))
                    .style(Style::Dashed)
                    .color("#000"),
            );
        }
        let slip = panel(&format!("Slip velocity, {}", run.label), "slip (m/s)")
            .series(Series::line(run.label, pts(&|r| r.slip_mps)).color(colour(k)));
        slips.push(if run.set_point.is_empty() {
            slip.hmark(
                RUNAWAY_SLIP_MPS,
                &format!("runaway: above {RUNAWAY_SLIP_MPS} m/s for {RUNAWAY_HOLD_S} s"),
                "#D55E00",
            )
        } else {
            // The set point, broken where the protection did not act.
            let mut sp = Vec::with_capacity(run.set_point.len());
            let dt = run
                .set_point
                .windows(2)
                .map(|w| w[1].0 - w[0].0)
                .fold(f64::INFINITY, f64::min);
            for w in run.set_point.windows(2) {
                sp.push(w[0]);
                if w[1].0 - w[0].0 > 1.5 * dt {
                    sp.push((f64::NAN, f64::NAN));
                }
            }
            sp.extend(run.set_point.last());
            slip.series(
                Series::line("regulator's set point", sp)
                    .style(Style::Dashed)
                    .color("#000"),
            )
            .hmark(
                slip_on_mps,
                &format!("detection: slip above {slip_on_mps} m/s"),
                "#D55E00",
            )
        });
    }
    let path = dir.join("adhesion.svg");
    let mut fig = Figure::new("low adhesion: traction, slip, adhesion").panel(force);
    for p in slips {
        fig = fig.panel(p);
    }
    fig.panel(mu).save(&path)?;
    Ok(path)
}

/// The sections table of `sc` with (`on`) and without (`off`) the wheel-slip protection,
/// as Markdown (the README's generated comparison, `sim-host run --loop core
/// --sections-table`; `shown` is that command): per section its condition, the peak
/// adhesion available (of the protected run, which covers every section), and for each
/// run the mean adhesion used, the utilisation and the slip peak. A run stopped as
/// diverged shows where: a section it ended in is marked "to T s", one it never reached
/// "diverged at T s". `None` without `[[adhesion]]` sections.
pub fn sections_table(
    sc: &Scenario,
    on: &Trajectory,
    off: &Trajectory,
    shown: &str,
) -> Option<String> {
    use std::fmt::Write;
    let (a, b) = (summary(sc, on)?, summary(sc, off)?);
    let mut t = String::new();
    let _ = writeln!(
        t,
        "`{}`: the f64 control core on the plant, with and without the wheel-slip \
         protection (`{shown}`, generated):\n",
        sc.name
    );
    let _ = writeln!(
        t,
        "| section | condition | `mu_peak` | protection on: `mu_used_mean` | utilisation | \
         slip peak | protection off: `mu_used_mean` | utilisation | slip peak |"
    );
    let _ = writeln!(t, "|---|---|---|---|---|---|---|---|---|");
    let stopped = |tr: &Trajectory| tr.info.diverged_at_s;
    let cells = |s: &SectionSummary, tr: &Trajectory| match stopped(tr) {
        Some(d) if d <= s.t0 => format!("(diverged at {d:.1} s) | |"),
        stop => format!(
            "{:.3} | {:.2} | {:.3} m/s{}",
            s.mu_used_mean,
            s.utilisation,
            s.slip_peak_mps,
            match stop {
                Some(d) if d < s.t1 => format!(" (to {d:.1} s)"),
                _ => String::new(),
            }
        ),
    };
    for (x, y) in a.sections.iter().zip(&b.sections) {
        let _ = writeln!(
            t,
            "| {:.1}-{:.1} s | {} | {:.3} | {} | {} |",
            x.t0,
            x.t1,
            x.condition,
            x.mu_peak,
            cells(x, on),
            cells(y, off)
        );
    }
    let run = |s: &AdhesionSummary, tr: &Trajectory| {
        format!(
            "runaway {}, slip peak {:.3} m/s{}",
            s.runaway,
            s.slip_peak_mps,
            match stopped(tr) {
                Some(d) => format!(", the run diverged at {d:.3} s (|y| > 50 mm)"),
                None => String::new(),
            }
        )
    };
    let _ = writeln!(
        t,
        "\nProtection on: {}. Protection off: {}.",
        run(&a, on),
        run(&b, off)
    );
    Some(t)
}
