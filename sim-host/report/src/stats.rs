//! Summary statistics of a sample (min, mean, 99th percentile, max), as every timing
//! table of a report prints them.

use serde::Serialize;

/// Summary statistics of a sample, ns.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Default)]
pub struct Stats {
    /// Samples.
    pub n: u64,
    /// Minimum.
    pub min: f64,
    /// Mean.
    pub mean: f64,
    /// 99th percentile (nearest rank).
    pub p99: f64,
    /// Maximum.
    pub max: f64,
}

impl Stats {
    /// Statistics of `v` (all zero when empty).
    #[must_use]
    pub fn of(v: &[f64]) -> Self {
        if v.is_empty() {
            return Self::default();
        }
        let mut s = v.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        let rank = ((0.99 * n as f64).ceil() as usize).clamp(1, n) - 1;
        Self {
            n: n as u64,
            min: s[0],
            mean: s.iter().sum::<f64>() / n as f64,
            p99: s[rank],
            max: s[n - 1],
        }
    }
}
