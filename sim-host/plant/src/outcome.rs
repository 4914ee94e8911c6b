//! What a stopped run means: a non-finite number (a numerical failure: which states,
//! when) or growth beyond the flange clearance with finite numbers (an unstable loop).

use crate::sim::{Record, Trajectory};

/// Why a run was stopped.
#[derive(Debug, Clone, PartialEq)]
pub enum Stop {
    /// A value became NaN or infinite at `t_s` (the first output sample that shows it):
    /// the CSV columns that are not finite there.
    Numerical {
        /// Time of the first non-finite output sample, s.
        t_s: f64,
        /// The non-finite columns ([`Record::COLUMNS`] names).
        columns: Vec<&'static str>,
    },
    /// `|y|` grew beyond the divergence limit with finite numbers: the loop is unstable.
    Unstable {
        /// Time it was stopped, s.
        t_s: f64,
        /// `y` there, m.
        y_m: f64,
    },
}

impl std::fmt::Display for Stop {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Stop::Numerical { t_s, columns } => write!(
                f,
                "numerical failure: non-finite {} at t = {t_s:.4} s (a NaN or an overflow in the \
                 integration, not a verdict on stability); stopped there",
                columns.join(", ")
            ),
            Stop::Unstable { t_s, y_m } => write!(
                f,
                "the run diverged (unstable loop): |y| = {:.1} mm at t = {t_s:.3} s; stopped there, \
                 records end at {t_s:.3} s",
                y_m.abs() * 1e3
            ),
        }
    }
}

/// The columns non-finite in `r` but finite in `first` (NaN from the start: not applicable).
fn non_finite(first: &Record, r: &Record) -> Vec<&'static str> {
    Record::COLUMNS
        .iter()
        .zip(first.values().iter().zip(r.values()))
        .filter(|(_, (a, v))| a.is_finite() && !v.is_finite())
        .map(|(c, _)| *c)
        .collect()
}

/// Why `tr` was stopped, or `None` when it ran to the end.
#[must_use]
pub fn stop_of(tr: &Trajectory) -> Option<Stop> {
    let t = tr.info.diverged_at_s?;
    let first = tr.records.first()?;
    let mut numerical = tr.records.iter().map(|r| (r.t_s, non_finite(first, r)));
    if let Some((t_s, columns)) = numerical.find(|(_, c)| !c.is_empty()) {
        return Some(Stop::Numerical { t_s, columns });
    }
    Some(Stop::Unstable {
        t_s: t,
        y_m: tr.records.last().map_or(f64::NAN, |r| r.y_m),
    })
}
