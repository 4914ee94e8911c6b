//! What a traction engineer reads from an adhesion run: the creep characteristic of a
//! rail condition, the per-section adhesion summary of a run and the runaway verdict:
//! slip above [`RUNAWAY_SLIP_MPS`] for [`RUNAWAY_HOLD_S`] without a break (3 m/s is past
//! the adhesion peak of every condition, 0.2-1.5 m/s). Definitions: `docs/adhesion.md`.

use crate::adhesion::{Condition, Polach};
use crate::params::Params;
use crate::scenario::Scenario;
use crate::sim::{Record, Trajectory};
use serde::Serialize;

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
    /// Polach's parameters (flattened into the JSON).
    #[serde(flatten)]
    pub law: Polach,
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

/// The characteristic of `condition` at speed `v`, `points` creepages over 0..=0.2.
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
        law,
        creepage,
        force_over_q,
        mu_peak,
        creepage_peak: s_peak,
        slip_peak_mps: s_peak * v,
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

/// Whether the records show a runaway; `stopped` = the run was stopped as diverged,
/// so records ending above the threshold count.
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

/// The sections table of `sc` with (`on`) and without (`off`) the wheel-slip protection,
/// as Markdown (`sim-host run --loop core --sections-table`; `shown` is that command).
/// `None` without `[[adhesion]]` sections.
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
