//! The grid of a campaign: the `--param` axes, the points in index order and the keys
//! that follow an axis (see the module docs of [`crate::sweep`]).

use std::collections::BTreeSet;
use std::str::FromStr;

use serde::{Deserialize, Serialize};
use wheelset_plant::params::Params;

/// Largest number of values on one axis.
pub const MAX_AXIS_POINTS: usize = 10_000;
/// Largest grid of a campaign, points (its records, about 1 KiB each, stay in memory).
pub const MAX_GRID_POINTS: usize = 100_000;

/// A grid point's values: `(key, value)` in axis order, then the keys that follow one.
pub type Point = Vec<(String, f64)>;

/// One `--param` axis: a parameter key and its values.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Axis {
    /// The parameter key (a TOML key of `Params`).
    pub key: String,
    /// Its values, SI units, in grid order.
    pub values: Vec<f64>,
}

/// The parameter keys (`Params::entries`).
#[must_use]
pub fn keys() -> Vec<&'static str> {
    Params::default()
        .entries()
        .iter()
        .map(|(k, _)| *k)
        .collect()
}

fn number(what: &str, s: &str, spec: &str) -> Result<f64, String> {
    let v: f64 = s.trim().parse().map_err(|_| {
        format!("`{spec}`: {what} `{s}` is not a number (expected KEY=FROM..TO:N, e.g. f11=1e6..1e7:5, or KEY=VALUE)")
    })?;
    if v.is_finite() {
        Ok(v)
    } else {
        Err(format!("`{spec}`: {what} `{s}` is not finite"))
    }
}

impl FromStr for Axis {
    type Err = String;

    /// `KEY=FROM..TO:N` or `KEY=VALUE`. The error says what is wrong with the spec (the
    /// caller names the flag).
    fn from_str(spec: &str) -> Result<Self, Self::Err> {
        let Some((key, range)) = spec.split_once('=') else {
            return Err(format!(
                "`{spec}`: expected KEY=FROM..TO:N (e.g. f11=1e6..1e7:5) or KEY=VALUE"
            ));
        };
        let key = key.trim();
        let known = keys();
        if !known.contains(&key) {
            return Err(format!(
                "`{spec}`: unknown parameter `{key}` (the keys: {})",
                known.join(", ")
            ));
        }
        let values = match range.split_once("..") {
            None => vec![number("VALUE", range, spec)?],
            Some((from, rest)) => {
                let Some((to, n)) = rest.split_once(':') else {
                    return Err(format!(
                        "`{spec}`: a range needs its number of points, FROM..TO:N (e.g. {key}={from}..{}:5)",
                        if rest.is_empty() { "TO" } else { rest }
                    ));
                };
                let (a, b) = (number("FROM", from, spec)?, number("TO", to, spec)?);
                let n: usize = n
                    .trim()
                    .parse()
                    .map_err(|_| format!("`{spec}`: N `{n}` is not a whole number of points"))?;
                if n == 0 {
                    return Err(format!(
                        "`{spec}`: N must be at least 1 (points along {key})"
                    ));
                }
                if n > MAX_AXIS_POINTS {
                    return Err(format!(
                        "`{spec}`: N = {n} is above the largest axis of {MAX_AXIS_POINTS} points"
                    ));
                }
                if n == 1 && a != b {
                    return Err(format!(
                        "`{spec}`: one point cannot span {a}..{b}; give N >= 2 or {key}={a}"
                    ));
                }
                (0..n)
                    .map(|j| {
                        if j + 1 == n {
                            b
                        } else {
                            a + (b - a) * j as f64 / (n - 1).max(1) as f64
                        }
                    })
                    .collect()
            }
        };
        Ok(Axis {
            key: key.to_string(),
            values,
        })
    }
}

/// The axis indices of grid point `index`: `index` in the mixed radix of the axis
/// lengths, the last axis fastest.
pub(crate) fn axis_indices(axes: &[Axis], index: usize) -> Vec<usize> {
    let mut rest = index;
    let mut idx = vec![0; axes.len()];
    for (k, a) in axes.iter().enumerate().rev() {
        idx[k] = rest % a.values.len().max(1);
        rest /= a.values.len().max(1);
    }
    idx
}

/// The grid's points: `(index, values in axis order with the followers)`.
#[must_use]
pub fn points(axes: &[Axis], follows: &[(String, String)]) -> Vec<Point> {
    let n: usize = axes.iter().map(|a| a.values.len()).product();
    (0..n)
        .map(|i| {
            let mut p: Vec<(String, f64)> = axes
                .iter()
                .zip(axis_indices(axes, i))
                .map(|(a, j)| (a.key.clone(), a.values[j]))
                .collect();
            for (follower, leader) in follows {
                if let Some(&(_, v)) = p.iter().find(|(k, _)| k == leader) {
                    p.push((follower.clone(), v));
                }
            }
            p
        })
        .collect()
}

/// The keys that follow an axis: `f22` follows `f11` unless it is an axis itself.
#[must_use]
pub fn followers(axes: &[Axis]) -> Vec<(String, String)> {
    let has = |k: &str| axes.iter().any(|a| a.key == k);
    if has("f11") && !has("f22") {
        vec![("f22".into(), "f11".into())]
    } else {
        Vec::new()
    }
}

/// Checks the axes as a whole: at least one, no key twice, the grid not above
/// [`MAX_GRID_POINTS`]. The error names `--param`.
pub fn check_axes(axes: &[Axis]) -> Result<usize, String> {
    if axes.is_empty() {
        return Err("--param: a sweep needs at least one axis, e.g. --param f11=1e6..1e7:5".into());
    }
    let mut seen = BTreeSet::new();
    for a in axes {
        if !seen.insert(a.key.as_str()) {
            return Err(format!("--param {}: the key is given twice", a.key));
        }
    }
    let n = axes
        .iter()
        .fold(1, |n: usize, a| n.saturating_mul(a.values.len()));
    if n > MAX_GRID_POINTS {
        return Err(format!(
            "--param: the grid has {n} points, above the largest campaign of {MAX_GRID_POINTS}; \
             use fewer points per axis"
        ));
    }
    Ok(n)
}
