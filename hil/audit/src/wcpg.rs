//! Worst-case peak gain (WCPG) of a single-input single-output discrete LTI system, with
//! a rigorous bound on the truncated tail.
//!
//! The system is
//!
//! ```text
//! s[n+1] = A s[n] + B u[n],     y[n] = C s[n] + D u[n]
//! ```
//!
//! with impulse response `h[0] = D`, `h[k] = C A^(k-1) B`. For any input with
//! `|u[n]| <= U` and zero initial state, `|y[n]| <= WCPG U` with
//!
//! ```text
//! WCPG = |D| + sum_{k>=0} |C A^k B|
//! ```
//!
//! and the bound is attained (the input `sign h[n-k]`), so it is the smallest such
//! constant. The sum is infinite unless the spectral radius of `A` is below 1.
//!
//! **Tail bound.** With `||.||` the induced infinity norm, find the smallest `N` with
//! `theta = ||A^N|| <= 1/2` (exists iff `rho(A) < 1`; searched up to [`MAX_POWER`]) and
//! `M = max_{0<=r<N} ||A^r||`. Every `k = pN + r` has `||A^k|| <= theta^p M`, so
//!
//! ```text
//! sum_{k>=pN} |C A^k B| <= ||C||_1 ||B||_inf N M theta^p / (1 - theta)
//! ```
//!
//! The sum is taken exactly up to `K = pN` terms, with `p` grown until that tail is below
//! `1e-12` of the partial sum, and the tail is added. **Floating-point allowance**: the
//! partial sum and the powers are computed in f64; the result is enlarged by the
//! relative factor `4 (K + n) n 2^-52` (a standard a-priori bound on the accumulated
//! rounding of `K` matrix-vector products and additions of dimension `n`), so the
//! returned value is an upper bound of the true WCPG.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Largest power of `A` searched for a contraction.
pub const MAX_POWER: usize = 1_000_000;

/// A SISO system `(A, B, C, D)`, `A` square `n x n` (row major), `n` may be 0.
#[derive(Clone, Debug, PartialEq)]
pub struct Siso {
    /// `A`, rows.
    pub a: Vec<Vec<f64>>,
    /// `B`, length `n`.
    pub b: Vec<f64>,
    /// `C`, length `n`.
    pub c: Vec<f64>,
    /// `D`.
    pub d: f64,
}

impl Siso {
    /// A static gain `y = d u`.
    pub fn gain(d: f64) -> Self {
        Self {
            a: vec![],
            b: vec![],
            c: vec![],
            d,
        }
    }

    /// The first-order recursion `y[n] = a y[n-1] + b u[n]` (state `y[n-1]`).
    pub fn recursive(a: f64, b: f64) -> Self {
        Self {
            a: vec![vec![a]],
            b: vec![b],
            c: vec![a],
            d: b,
        }
    }

    /// The same system with the output scaled by `k` (`C k`, `D k`).
    pub fn scaled(&self, k: f64) -> Self {
        Self {
            a: self.a.clone(),
            b: self.b.clone(),
            c: self.c.iter().map(|v| v * k).collect(),
            d: self.d * k,
        }
    }
}

/// The WCPG and how it was bounded.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Wcpg {
    /// Upper bound of `|D| + sum_k |C A^k B|` (tail and float allowance included).
    pub value: f64,
    /// Terms summed exactly (`K`).
    pub terms: usize,
    /// The tail bound added for `k >= K`.
    pub tail_bound: f64,
    /// `N`: the power with `||A^N||_inf <= 1/2` (0 for a static gain).
    pub contraction_power: usize,
    /// `theta = ||A^N||_inf`.
    pub theta: f64,
}

/// The WCPG of `s`, or `None` when it is infinite (or not provably finite: no power of
/// `A` up to [`MAX_POWER`] contracts to 1/2, or a non-finite entry).
pub fn wcpg(s: &Siso) -> Option<Wcpg> {
    let n = s.a.len();
    let finite =
        s.a.iter()
            .flatten()
            .chain(&s.b)
            .chain(&s.c)
            .all(|v| v.is_finite())
            && s.d.is_finite();
    if !finite || s.b.len() != n || s.c.len() != n || s.a.iter().any(|r| r.len() != n) {
        return None;
    }
    if n == 0 {
        return Some(Wcpg {
            value: s.d.abs(),
            terms: 0,
            tail_bound: 0.0,
            contraction_power: 0,
            theta: 0.0,
        });
    }
    let a = DMatrix::from_fn(n, n, |i, j| s.a[i][j]);
    let norm_inf = |x: &DMatrix<f64>| x.abs().column_sum().max();
    // Smallest N with ||A^N|| <= 1/2, and M = max_{r<N} ||A^r|| (||A^0|| = 1).
    let mut p = a.clone();
    let mut m = 1.0f64;
    let mut big_n = 0;
    for k in 1..=MAX_POWER {
        let nk = norm_inf(&p);
        if !nk.is_finite() {
            return None;
        }
        if nk <= 0.5 {
            big_n = k;
            break;
        }
        m = m.max(nk);
        p = &p * &a;
    }
    if big_n == 0 {
        return None;
    }
    let theta = norm_inf(&p);
    let c1: f64 = s.c.iter().map(|v| v.abs()).sum();
    let binf = s.b.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let tail_of =
        |blocks: usize| c1 * binf * big_n as f64 * m * theta.powi(blocks as i32) / (1.0 - theta);
    let mut sum = s.d.abs();
    let mut v = DVector::from_column_slice(&s.b);
    let mut k = 0usize;
    let mut blocks = 0usize;
    loop {
        for _ in 0..big_n {
            sum +=
                s.c.iter()
                    .zip(v.iter())
                    .map(|(a, b)| a * b)
                    .sum::<f64>()
                    .abs();
            v = &a * &v;
            k += 1;
        }
        blocks += 1;
        let t = tail_of(blocks);
        if t <= 1e-12 * sum.max(f64::MIN_POSITIVE) || blocks >= 2000 || t == 0.0 {
            let allowance = 4.0 * (k + n) as f64 * n as f64 * f64::EPSILON;
            return Some(Wcpg {
                value: sum * (1.0 + allowance) + t,
                terms: k,
                tail_bound: t,
                contraction_power: big_n,
                theta,
            });
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn first_order_low_pass_has_the_geometric_sum() {
        // y[n] = a y[n-1] + b u[n]: s = y[n-1], y = a s + b u: h = b, a b, a^2 b, ...
        let (a, b) = (0.9, 0.3);
        let w = wcpg(&Siso::recursive(a, b)).unwrap();
        let exact = b / (1.0 - a);
        assert!(
            w.value >= exact && w.value - exact < 1e-9,
            "{w:?} vs {exact}"
        );
        assert!(w.tail_bound > 0.0);
    }

    #[test]
    fn oscillating_second_order_sums_absolute_values() {
        // Poles 0.9 e^{+-j 1}: the impulse response changes sign, so the WCPG exceeds
        // the DC gain; compare with a long direct sum.
        let (r, th) = (0.9f64, 1.0f64);
        let a = vec![vec![2.0 * r * th.cos(), -r * r], vec![1.0, 0.0]];
        let s = Siso {
            a: a.clone(),
            b: vec![1.0, 0.0],
            c: vec![1.0, 0.0],
            d: 0.0,
        };
        let w = wcpg(&s).unwrap();
        let (mut x, mut total): (Vec<f64>, f64) = (vec![1.0, 0.0], 0.0);
        for _ in 0..5000 {
            total += x[0].abs();
            x = vec![a[0][0] * x[0] + a[0][1] * x[1], x[0]];
        }
        let dc = 1.0 / (1.0 - 2.0 * r * th.cos() + r * r);
        assert!(w.value >= total && w.value - total < 1e-9 * total);
        assert!(total > dc);
    }

    #[test]
    fn an_integrator_has_no_finite_wcpg() {
        assert!(wcpg(&Siso::recursive(1.0, 1.0)).is_none());
        assert_eq!(wcpg(&Siso::gain(-2.5)).unwrap().value, 2.5);
    }
}
