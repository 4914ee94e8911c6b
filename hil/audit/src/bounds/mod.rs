//! Proven ranges and rounding-error bounds of the control core, from the coefficients as
//! the device holds them (quantised), next to what the scenarios observed.
//!
//! # Ranges (no overflow for any input within the clamps)
//!
//! All in per unit (pu); `q` is the signal LSB (`2^-28` for Q4.28). The inputs are
//! clamped first: `|y'| <= Y`, `|i_a| <= I`, `|demand| <= Dm`, `|omega| <= S`.
//!
//! - **Predictor** (interval arithmetic): `y' - y'[n-1]` in `[-2Y, 2Y]` (exact);
//!   `d = round((y' - y'[n-1]) p)` with `p = predict_half`, so `|y' + 2d| <= Y(1 + 4|p|) + q`
//!   before the clamp to `+-P` (2 pu); the lead's input is `|x| <= X = min(P, that)`
//!   (`X = Y` exactly when the predictor is off, `p = 0`).
//! - **Lead** (linear; WCPG, [`super::wcpg`]): state `s[n] = (z[n-1], x[n-1])`,
//!   `a = 1 - kappa`, `h = kappa g/2` (quantised coefficients, exact arithmetic):
//!
//!   ```text
//!   s[n+1] = [[a, h], [0, 0]] s[n] + [h, 1] x[n]
//!   x + x1 = [0, 1] s + 1 x          e = (g/2)(x + x1) - z = [-1, g/2] s + (g/2) x
//!   z[n]   = [a, h] s + h x          x - z[n] = [-a, -h] s + (1 - h) x,   y = K_hf (x - z)
//!   ```
//!
//!   Each signal's exact value is at most `WCPG X`; the fixed-point value differs from
//!   it by at most its rounding-error bound (below), so `proven = WCPG X + error`. The
//!   bumpless start from the steady state of a held input is the response to an input
//!   held forever (within the bound), plus one rounding of `z`, `q/2`, decaying.
//! - **Gain**: `|round(x k)| <= |k| X + q/2`. A law change slews the output between the
//!   old output and the new law's (`|.| <= max(T_max, raw)`); the limit gives `T_max`.
//! - **Traction** (interval arithmetic): target `round(d d2i)`, `|.| <= Dm |d2i| + q/2`;
//!   the ramp moves `i_ref` towards the target by at most one step, so it stays in the
//!   hull of 0 and the targets; the wheel-slip protection only lowers it to a cap in
//!   `[0, i_ref]` ([`wheelset_control::wsp`]); `|e| <= Iref + I`; `|round(Kp e)| <=
//!   |Kp| E + q/2`; the integrator's increment is floored with its remainder carried,
//!   `|.| <= |Ki| E + q`; the integrator is clamped to `[u_min, u_max]` (anti-windup),
//!   so its pre-clamp value is at most `U + |Ki| E + q` and the PI sum `|Kp| E + q/2 +
//!   U`; the output is limited to `U`. The PI's linear part is not BIBO (pole `z = 1`):
//!   only the anti-windup clamp bounds it.
//!
//! # Rounding-error bounds (fixed point vs exact arithmetic on the same quantised
//! coefficients and the same inputs)
//!
//! Every product is rounded to nearest (`|r| <= q/2`); the integrator's increment is
//! floored with error feedback. The error of each signal is a linear filter of the
//! rounding errors (the saturations never act: the ranges above are inside the format):
//!
//! - Lead: `r1` at `(g/2)(x + x1)`, `r2` at `kappa e`, `r3` at `K_hf (x - z)`;
//!   `dz[n] = a dz[n-1] + kappa r1 + r2`, so `|dz| <= W(r1->z) q/2 + W(r2->z) q/2 + q/2`
//!   (WCPGs `1` and `1/kappa`; the last term the bumpless start), `|dy| <= K_hf |dz| + q/2`.
//!   The predictor's rounding `r_p` enters the lead's input twice: `|dx| <= q`, and
//!   adds `W(x->y) q` to the torque.
//! - PI, given its input `e`: `|du| <= q/2 (Kp e) + q (integrator)`. The integrator
//!   bound is an invariant: with `rho` the carried remainder in `[0, q)`, `eps = dI +
//!   rho` stays in `[0, q)` through every step (unclamped: unchanged; clamped: the
//!   clamp is monotone and non-expansive, so `eps` lands between `rho` and its old value).
//! - The reference: the target's rounding (`q/2`) passes through the ramp unchanged in
//!   size (the ramp is monotone in both arguments and commutes with a common shift), so
//!   `|d i_ref| <= q/2`. Open loop, the PI integrates that offset without bound; closed
//!   loop the current loop absorbs it: stated, not bounded here.

mod observed;
mod proven;

pub use observed::observed_errors;
pub use proven::{lead_error_systems, lead_systems, prove, Quantised};
pub(crate) use proven::{qc, quantise};

use serde::Serialize;

use super::model::Recommendation;
use super::wcpg::Wcpg;

/// One signal's observed and proven magnitude (the audit's bound record).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Bound {
    /// Signal name (as in the ranges table; predictor and intermediates added).
    pub signal: String,
    /// Controller.
    pub controller: String,
    /// SI unit of the magnitudes.
    pub unit: String,
    /// Largest |value| observed over the scenarios, SI (`null`: not observed).
    pub observed_max: Option<f64>,
    /// Proven largest |value| for any input within the clamps, SI.
    pub proven_max: f64,
    /// The audited signal format.
    pub format: String,
    /// `log2(format range / proven_max)`, bits (negative: the proof does not exclude
    /// an overflow).
    pub margin_bits: f64,
    /// How it is proven.
    pub proof: String,
}

/// One output's rounding error, observed and proven (module docs).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ErrorBound {
    /// Output (`T_psi (lead)`, `T_psi (gain)`, `u_a (PI)`, `i_ref`).
    pub output: String,
    /// Largest |fixed - exact| observed over the scenarios.
    pub observed: f64,
    /// Proven bound.
    pub proven: f64,
    /// Unit of `observed` and `proven`.
    pub unit: String,
    /// The proven bound in wire LSBs of the output.
    pub proven_wire_lsb: f64,
    /// Per rounding point: `(where, contribution in unit)`.
    pub rounding_points: Vec<(String, f64)>,
}

/// The WCPG of one linear part, input -> output.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LinearPart {
    /// Part (`lead`, `PI`, `y'' integrator`, lead rounding-error filters).
    pub part: String,
    /// Input -> output.
    pub path: String,
    /// The WCPG (`null`: infinite, e.g. an integrator).
    pub wcpg: Option<Wcpg>,
    /// What it means.
    pub note: String,
}

/// Everything proven.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Proofs {
    /// Per signal.
    pub bounds: Vec<Bound>,
    /// Per output.
    pub error_bounds: Vec<ErrorBound>,
    /// The linear parts' WCPGs.
    pub linear_parts: Vec<LinearPart>,
    /// Recommended formats per signal ([`prove`]).
    pub recommendations: Vec<Recommendation>,
    /// The stated result.
    pub statement: String,
    /// Whether every proven bound lies inside the audited format.
    pub overflow_free: bool,
}

/// The smallest margin of `bounds` (bits) and its signal; `(inf, "")` for none.
pub(crate) fn smallest_margin(bounds: &[Bound]) -> (f64, &str) {
    let m = bounds
        .iter()
        .min_by(|a, b| a.margin_bits.total_cmp(&b.margin_bits));
    m.map_or((f64::INFINITY, ""), |b| (b.margin_bits, b.signal.as_str()))
}

/// Smallest integer bits (incl. sign) with `2^(i-1) > v`.
pub fn int_bits_for(v: f64) -> u32 {
    (1..64).take_while(|&i| 2f64.powi(i - 1) <= v).count() as u32 + 1
}

/// Smallest fraction bits `F` with `err_per_lsb 2^-F <= budget` (both pu).
pub fn frac_bits_for(err_per_lsb: f64, budget: f64) -> u32 {
    if !(err_per_lsb > 0.0 && budget > 0.0) {
        return 0;
    }
    (err_per_lsb / budget).log2().ceil().max(0.0) as u32
}
