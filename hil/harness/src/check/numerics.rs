//! Closed-loop numerics: the trajectory through the device against the f64 reference
//! (`wheelset_plant::sim::run_continuous`, same scenario and law).
//!
//! For each signal `x` with reference `r`, the error at `t` is the distance from `x(t)` to
//! the tube the reference spans within the time tolerance `tau`:
//! `e(t) = max(0, x(t) - max_{|s| <= tau} r(t + s), min_{|s| <= tau} r(t + s) - x(t))`
//! (a step followed a little later is no error while it stays inside the reference's
//! range). The signal passes if `max_t e(t) <= abs + rel * max_t |r(t)|`, warns up to
//! `warn_factor` times that, and fails beyond, on a non-finite value, or when the run or
//! the reference diverged.
//!
//! [`compare_fine`]: where the reference can be recorded at the control period (the
//! control core, `wheelset_loop::core`, for runs with `[[adhesion]]`), the tube is taken
//! over those records (same `tau`, `abs`, `rel`; the peak from the output records). A
//! transient shorter than the output interval that the device makes a tick away from the
//! reference (a wheel-slip cut whose threshold crossing falls a tick apart on codes that
//! differ by an LSB) is then judged against the reference's own swing, not against
//! another phase of it; an amplitude error, a wrong sign or a shift beyond `tau` fails as
//! before.

use std::collections::BTreeMap;

use serde::Serialize;
use wheelset_plant::sim::{Record, Trajectory};

use crate::budget::{Limit, Tolerance};
use wheelset_report::Verdict;

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

/// The errors judged, per signal (CSV column): `(t_s, signed error)` outside the
/// reference's time tube.
pub type JudgedErrors = Vec<(String, Vec<(f64, f64)>)>;

/// The value of column `name` of a record (None: unknown column).
#[must_use]
pub fn column(r: &Record, name: &str) -> Option<f64> {
    Record::COLUMNS
        .iter()
        .position(|c| *c == name)
        .map(|i| r.values()[i])
}

/// The output interval of `t`'s records, s (1 s if it has fewer than two).
fn interval(t: &Trajectory) -> f64 {
    match (t.records.first(), t.records.get(1)) {
        (Some(a), Some(b)) => (b.t_s - a.t_s).max(1e-12),
        _ => 1.0,
    }
}

/// `m >= 1` records of `fine` per output interval of `run`, if `fine.records[i m]` is at
/// `run.records[i]`'s time (checked at the first and the last of the `n` compared).
fn per_interval(run: &Trajectory, fine: &Trajectory, n: usize) -> Option<usize> {
    let m = (interval(run) / interval(fine)).round();
    if !(1.0..=1e6).contains(&m) || n == 0 {
        return None;
    }
    let m = m as usize;
    let same = |i: usize| {
        let f = fine.records.get(i * m)?;
        ((f.t_s - run.records[i].t_s).abs() < 1e-9).then_some(())
    };
    same(0)?;
    same(n - 1)?;
    Some(m)
}

/// The tube a run is judged against: `m` of `tube`'s records per output interval, over `n`.
struct Tube<'a> {
    tube: &'a Trajectory,
    m: usize,
    n: usize,
    dt_tube: f64,
}

impl<'a> Tube<'a> {
    /// The tube of `run` against `reference`, over `fine` where it aligns (module docs).
    fn of(run: &Trajectory, reference: &'a Trajectory, fine: Option<&'a Trajectory>) -> Self {
        let dt = interval(run);
        let n = run.records.len().min(reference.records.len());
        // The tube's records: `tube[i m]` at `run.records[i]`'s time, `dt_tube` apart.
        let (tube, m) = match fine.and_then(|f| Some((f, per_interval(run, f, n)?))) {
            Some((f, m)) => (f, m),
            None => (reference, 1),
        };
        Tube {
            tube,
            m,
            n,
            dt_tube: dt / m as f64,
        }
    }

    /// The signed error of the first `n` records of `run` in signal `name`: above the
    /// tube's top (> 0) or below its bottom (< 0) within `tol.time_s`, 0 inside, infinite
    /// where either side is not finite (never hidden by the NaN-ignoring min/max).
    fn errors(&self, run: &Trajectory, name: &str, tol: &Tolerance) -> Vec<f64> {
        let m = self.m;
        let nt = ((self.n.saturating_sub(1)) * m + 1).min(self.tube.records.len());
        let rt: Vec<f64> = self.tube.records[..nt]
            .iter()
            .map(|r| column(r, name).unwrap_or(f64::NAN))
            .collect();
        let w = (tol.time_s / self.dt_tube).round() as usize;
        run.records[..self.n]
            .iter()
            .enumerate()
            .map(|(i, rec)| {
                let xi = column(rec, name).unwrap_or(f64::NAN);
                let lo = (i * m).saturating_sub(w);
                let hi = (i * m + w).min(nt.saturating_sub(1));
                let (rmin, rmax) = rt
                    .get(lo..=hi)
                    .unwrap_or(&[])
                    .iter()
                    .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                        (a.min(v), b.max(v))
                    });
                if !(xi.is_finite() && rmin.is_finite() && rmax.is_finite()) {
                    f64::INFINITY
                } else if xi > rmax {
                    xi - rmax
                } else if xi < rmin {
                    xi - rmin
                } else {
                    0.0
                }
            })
            .collect()
    }
}

/// Compares `run` with `reference` for every signal in `tolerances`, the tube over `fine`
/// where it falls on `run`'s records (module docs), else over `reference`, which gives the
/// peak, the length and the divergence; with the judged errors, for the plots.
#[must_use]
pub fn compare_fine(
    run: &Trajectory,
    reference: &Trajectory,
    fine: Option<&Trajectory>,
    tolerances: &BTreeMap<String, Tolerance>,
) -> (NumericsReport, JudgedErrors) {
    let tube = Tube::of(run, reference, fine);
    let n = tube.n;
    let mut signals = Vec::new();
    let mut judged = Vec::new();
    for (name, tol) in tolerances {
        let mut max_err = 0.0f64;
        let mut max_t = 0.0;
        let mut sq = 0.0;
        let mut finite = true;
        let errors = tube.errors(run, name, tol);
        for (i, &e) in errors.iter().enumerate() {
            let e = e.abs();
            if !e.is_finite() {
                finite = false;
            }
            if e > max_err || !e.is_finite() {
                max_err = e;
                max_t = run.records[i].t_s;
            }
            sq += e * e;
        }
        let ref_peak = reference.records[..n]
            .iter()
            .map(|r| column(r, name).unwrap_or(f64::NAN))
            .fold(0.0f64, |m, v| m.max(v.abs()));
        let allowed = tol.abs + tol.rel * ref_peak;
        let ratio = if allowed > 0.0 {
            max_err / allowed
        } else if max_err == 0.0 {
            0.0
        } else {
            f64::INFINITY
        };
        let verdict = if !finite || n == 0 {
            Verdict::Fail
        } else {
            Limit {
                warn: 1.0,
                fail: tol.warn_factor,
            }
            .judge(ratio)
        };
        let pts = run.records.iter().zip(errors).map(|(r, e)| (r.t_s, e));
        judged.push((name.clone(), pts.collect()));
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
    let report = NumericsReport {
        verdict,
        run_diverged_at_s: run_div,
        reference_diverged_at_s: ref_div,
        reference: format!(
            "f64 continuous-time reference, control {}{}",
            reference.info.control,
            if tube.m > 1 {
                format!(", tube at {:.1} ms", tube.dt_tube * 1e3)
            } else {
                String::new()
            }
        ),
        signals,
    };
    (report, judged)
}

/// Every `m`-th record of `t` from the first (and the last), the rest as `t`: a run
/// recorded at a finer interval, at the coarser one (`m = 0` is taken as 1).
#[must_use]
pub fn every_nth(t: &Trajectory, m: usize) -> Trajectory {
    let m = m.max(1);
    let last = t.records.len().saturating_sub(1);
    Trajectory {
        records: t
            .records
            .iter()
            .enumerate()
            .filter(|(i, _)| i % m == 0 || *i == last)
            .map(|(_, r)| *r)
            .collect(),
        info: t.info.clone(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wheelset_plant::sim::RunInfo;

    /// 2 s of `u_a` at `dt` (s): 100 V, with a dip to `depth` V over fine ticks
    /// `from..from + 3` of 0.2 ms (`dt` a multiple of 0.2 ms).
    fn u_a(dt: f64, from: usize, depth: f64) -> Trajectory {
        let m = (dt / 2e-4).round() as usize;
        let records = (0..=2 * 5000 / m)
            .map(|i| Record {
                t_s: i as f64 * dt,
                u_a_v: if (from..from + 3).contains(&(i * m)) {
                    depth
                } else {
                    100.0
                },
                ..Record::default()
            })
            .collect();
        let info = RunInfo {
            scenario: "dip".into(),
            source: "test".into(),
            control: "test".into(),
            dt_s: 1e-4,
            steps: 20_000,
            controller_calls: 10_000,
            actuator_clamps: 0,
            diverged_at_s: None,
        };
        Trajectory { records, info }
    }

    fn u_a_tolerance() -> BTreeMap<String, Tolerance> {
        let mut t = crate::budget::default_tolerances();
        t.retain(|k, _| k == "u_a_V");
        t
    }

    #[test]
    fn a_transient_between_records_a_tick_away_is_inside_the_tube_at_the_control_period() {
        let tol = u_a_tolerance();
        // The reference dips over ticks 5001-5003 (between its 1 ms records 5000 and
        // 5005); the device a tick later, over 5002-5004, then 5005-5007: its record at
        // 1.001 s is in the dip.
        let fine = u_a(2e-4, 5001, 40.0);
        let reference = every_nth(&fine, 5);
        assert!(reference.records.iter().all(|r| r.u_a_v == 100.0));
        assert_eq!(reference.records.len(), 2001);
        let run = u_a(1e-3, 5004, 40.0);
        let coarse = compare_fine(&run, &reference, None, &tol).0;
        assert_eq!(coarse.verdict, Verdict::Fail, "{coarse:?}");
        assert!((coarse.signals[0].max_err - 60.0).abs() < 1e-9);
        let at_ticks = compare_fine(&run, &reference, Some(&fine), &tol).0;
        assert_eq!(at_ticks.verdict, Verdict::Pass, "{at_ticks:?}");
        assert_eq!(at_ticks.signals[0].max_err, 0.0);
        // The allowance is the reference's, from its output records: unchanged.
        assert_eq!(at_ticks.signals[0].allowed, coarse.signals[0].allowed);
        assert!(at_ticks.reference.contains("tube at 0.2 ms"));
    }

    #[test]
    fn the_tube_at_the_control_period_still_fails_amplitude_and_timing_errors() {
        let tol = u_a_tolerance();
        let fine = u_a(2e-4, 5001, 40.0);
        let reference = every_nth(&fine, 5);
        // Deeper than the reference ever goes: 20 V below its range.
        let deeper = compare_fine(&run_dip(5004, 20.0), &reference, Some(&fine), &tol).0;
        assert_eq!(deeper.verdict, Verdict::Fail);
        assert!((deeper.signals[0].max_err - 20.0).abs() < 1e-9);
        // The same dip 10 ms late: beyond `tau` (8 ms), an error as before.
        let late = compare_fine(&run_dip(5054, 40.0), &reference, Some(&fine), &tol).0;
        assert_eq!(late.verdict, Verdict::Fail);
        // A fine run that does not land on the records is not used.
        let odd = u_a(6e-4, 5001, 40.0);
        let r = compare_fine(&run_dip(5004, 40.0), &reference, Some(&odd), &tol).0;
        assert_eq!(r.verdict, Verdict::Fail);
        assert!(!r.reference.contains("tube"));
    }

    fn run_dip(from: usize, depth: f64) -> Trajectory {
        u_a(1e-3, from, depth)
    }

    #[test]
    fn every_nth_keeps_the_first_and_the_last() {
        let fine = u_a(2e-4, 0, 0.0);
        let c = every_nth(&fine, 5);
        assert_eq!(c.records.len(), 2001);
        assert!((c.records[1].t_s - 1e-3).abs() < 1e-12);
        assert_eq!(
            c.records.last().map(|r| r.t_s),
            fine.records.last().map(|r| r.t_s)
        );
    }
}
