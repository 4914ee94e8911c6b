//! Closed-loop numerics: the trajectory through the device against the f64
//! continuous-time reference (`sim_host::sim::run_continuous`, same scenario, same law).
//!
//! For each signal `x` with reference `r`, both sampled at the scenario's output
//! interval, the error at `t` is the distance from `x(t)` to the tube the reference spans
//! within the time tolerance `tau`:
//! `e(t) = max(0, x(t) - max_{|s| <= tau} r(t + s), min_{|s| <= tau} r(t + s) - x(t))`
//! (so a step the device follows a little later, or ramps through, is not an error while
//! it stays inside the reference's range over `t +- tau`). The signal passes if
//! `max_t e(t) <= abs + rel * max_t |r(t)|`, warns up to `warn_factor` times that, and
//! fails beyond (or if the run produced a non-finite value). A run or a reference that
//! diverged (and was stopped by `sim_host::sim`) fails the numerics outright.

use std::collections::BTreeMap;

use serde::Serialize;
use sim_host::sim::{Record, Trajectory};

use crate::budget::{Tolerance, Verdict};

/// One signal's comparison.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct SignalCheck {
    /// CSV column name.
    pub name: String,
    /// Largest error (after the time tolerance), signal unit.
    pub max_err: f64,
    /// When it occurred, s.
    pub max_err_t_s: f64,
    /// RMS error (after the time tolerance).
    pub rms_err: f64,
    /// The reference's peak |value|.
    pub ref_peak: f64,
    /// `abs + rel * ref_peak`.
    pub allowed: f64,
    /// `max_err / allowed`.
    pub ratio: f64,
    /// The tolerance applied.
    pub tolerance: Tolerance,
    /// Verdict.
    pub verdict: Verdict,
}

/// The numerics section of a run's report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct NumericsReport {
    /// Worst verdict.
    pub verdict: Verdict,
    /// What the run was compared with.
    pub reference: String,
    /// When the closed-loop run diverged and stopped (|y| > 5 cm or not finite), s: a
    /// failure whatever the signals' errors up to then.
    pub run_diverged_at_s: Option<f64>,
    /// When the reference diverged and stopped, s (it is then no yardstick: failure).
    pub reference_diverged_at_s: Option<f64>,
    /// Per signal.
    pub signals: Vec<SignalCheck>,
}

/// The value of column `name` of a record (None: unknown column).
#[must_use]
pub fn column(r: &Record, name: &str) -> Option<f64> {
    Record::COLUMNS
        .iter()
        .position(|c| *c == name)
        .map(|i| r.values()[i])
}

/// Compares `run` with `reference` for every signal in `tolerances`.
#[must_use]
pub fn compare(
    run: &Trajectory,
    reference: &Trajectory,
    tolerances: &BTreeMap<String, Tolerance>,
) -> NumericsReport {
    let dt = match (run.records.first(), run.records.get(1)) {
        (Some(a), Some(b)) => (b.t_s - a.t_s).max(1e-12),
        _ => 1.0,
    };
    let n = run.records.len().min(reference.records.len());
    let mut signals = Vec::new();
    for (name, tol) in tolerances {
        let x: Vec<f64> = run.records[..n]
            .iter()
            .map(|r| column(r, name).unwrap_or(f64::NAN))
            .collect();
        let r: Vec<f64> = reference.records[..n]
            .iter()
            .map(|r| column(r, name).unwrap_or(f64::NAN))
            .collect();
        let w = (tol.time_s / dt).round() as usize;
        let mut max_err = 0.0f64;
        let mut max_t = 0.0;
        let mut sq = 0.0;
        let mut finite = true;
        for (i, &xi) in x.iter().enumerate() {
            let lo = i.saturating_sub(w);
            let hi = (i + w).min(n.saturating_sub(1));
            let (rmin, rmax) = r[lo..=hi]
                .iter()
                .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                    (a.min(v), b.max(v))
                });
            // A non-finite value on either side (a diverged run or reference) is an
            // infinite error, never hidden by the NaN-ignoring min/max.
            let e = if xi.is_finite() && rmin.is_finite() && rmax.is_finite() {
                (xi - rmax).max(rmin - xi).max(0.0)
            } else {
                f64::INFINITY
            };
            if !e.is_finite() {
                finite = false;
            }
            if e > max_err || !e.is_finite() {
                max_err = e;
                max_t = run.records[i].t_s;
            }
            sq += e * e;
        }
        let ref_peak = r.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let allowed = tol.abs + tol.rel * ref_peak;
        let ratio = if allowed > 0.0 {
            max_err / allowed
        } else if max_err == 0.0 {
            0.0
        } else {
            f64::INFINITY
        };
        let verdict = if !finite || n == 0 || ratio.is_nan() || ratio > tol.warn_factor {
            Verdict::Fail
        } else if ratio > 1.0 {
            Verdict::Warn
        } else {
            Verdict::Pass
        };
        signals.push(SignalCheck {
            name: name.clone(),
            max_err,
            max_err_t_s: max_t,
            rms_err: (sq / n.max(1) as f64).sqrt(),
            ref_peak,
            allowed,
            ratio,
            tolerance: *tol,
            verdict,
        });
    }
    let (run_div, ref_div) = (run.info.diverged_at_s, reference.info.diverged_at_s);
    let stopped_short = run.records.len() != reference.records.len();
    let verdict = if run_div.is_some() || ref_div.is_some() || stopped_short {
        Verdict::Fail
    } else {
        signals
            .iter()
            .map(|s| s.verdict)
            .max()
            .unwrap_or(Verdict::Pass)
    };
    NumericsReport {
        verdict,
        run_diverged_at_s: run_div,
        reference_diverged_at_s: ref_div,
        reference: format!(
            "f64 continuous-time reference, control {}",
            reference.info.control
        ),
        signals,
    }
}
