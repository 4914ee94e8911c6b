//! Axis ticks and their labels, XML escaping, and the decimation of long polylines.

use std::cmp::Ordering::Equal;

/// Escapes text for SVG.
pub fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}

/// "Nice" tick positions (1-2-5 steps) covering `[lo, hi]`, about `n` of them.
pub fn nice_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo || n == 0 {
        return vec![];
    }
    let raw = (hi - lo) / n as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 2.5, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| *s >= raw)
        .unwrap_or(10.0 * mag);
    let start = (lo / step).ceil() as i64;
    let end = (hi / step).floor() as i64;
    (start..=end).map(|k| k as f64 * step).collect()
}

/// Ticks of a logarithmic axis spanning `[lo, hi]` in `log10` units: the decades inside
/// it (every second one beyond 8), and 2 and 5 times them when fewer than three decades
/// fall inside (so a short log axis still has labels).
pub(crate) fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo {
        return vec![];
    }
    let (a, b) = (lo.floor() as i32, hi.ceil() as i32);
    let inside = |t: &f64| *t >= lo - 1e-9 && *t <= hi + 1e-9;
    let decades: Vec<f64> = (a..=b).map(f64::from).filter(inside).collect();
    if decades.len() >= 3 {
        let step = if decades.len() > 8 { 2 } else { 1 };
        return decades.into_iter().step_by(step).collect();
    }
    (a..=b)
        .flat_map(|d| [1.0, 2.0, 5.0].map(|m: f64| f64::from(d) + m.log10()))
        .filter(inside)
        .collect()
}

/// A value on a logarithmic axis as an engineer writes it: `0.02`, `5`, `300`, `1e6`.
pub(crate) fn fmt_log(v: f64) -> String {
    if (1e-3..1e5).contains(&v.abs()) {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        let e = v.abs().log10().floor() as i32;
        let m = v / 10f64.powi(e);
        if (m.round() - m).abs() < 1e-6 && m.round() == 1.0 {
            format!("1e{e}")
        } else {
            format!("{}e{e}", (m * 10.0).round() / 10.0)
        }
    }
}

/// Decimal places needed to write multiples of `step` exactly (at most 12).
pub(crate) fn decimals(step: f64) -> usize {
    (0..12)
        .find(|&d| {
            let x = step * 10f64.powi(d as i32);
            (x - x.round()).abs() < 1e-6 * x.abs().max(1.0)
        })
        .unwrap_or(12)
}

pub(crate) fn fmt_tick(v: f64, ticks: &[f64]) -> String {
    let step = if ticks.len() > 1 {
        (ticks[1] - ticks[0]).abs()
    } else {
        v.abs().max(1.0)
    };
    let big = ticks.iter().fold(0f64, |a, t| a.max(t.abs()));
    if v == 0.0 {
        return "0".into();
    }
    if !(1e-3..1e5).contains(&big) {
        let e = big.log10().floor() as i32;
        return format!(
            "{:.*}e{e}",
            decimals(step / 10f64.powi(e)),
            v / 10f64.powi(e)
        );
    }
    format!("{v:.*}", decimals(step))
}

/// Keeps at most about `max` points by taking min/max pairs per bucket (so peaks stay).
pub(crate) fn decimate(p: &[(f64, f64)], max: usize) -> Vec<(f64, f64)> {
    if p.len() <= max.max(4) {
        return p.to_vec();
    }
    let buckets = (max / 2).max(2);
    let per = p.len().div_ceil(buckets);
    let mut out = Vec::with_capacity(buckets * 2 + 1);
    let by_y = |a: &&(f64, f64), b: &&(f64, f64)| a.1.partial_cmp(&b.1).unwrap_or(Equal);
    for chunk in p.chunks(per) {
        // The first lowest and the first highest (`max_by` keeps the last: reversed).
        let lo = *chunk.iter().min_by(by_y).unwrap_or(&chunk[0]);
        let hi = *chunk.iter().rev().max_by(by_y).unwrap_or(&chunk[0]);
        if lo.0 <= hi.0 {
            out.push(lo);
            out.push(hi);
        } else {
            out.push(hi);
            out.push(lo);
        }
    }
    if let Some(&last) = p.last() {
        out.push(last);
    }
    out
}
