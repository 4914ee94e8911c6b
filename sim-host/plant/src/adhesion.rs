//! Adhesion-limited creep forces: Polach's method (Wear 258 (2005) 992-1000) per wheel
//! on the resultant creepage, scaled so the small-creep slopes are `f11` and `f22`
//! (`docs/model.md`, "adhesion-limited creep"). The force keeps the direction of the
//! linear one, `F_vec = F_lin r(e)`, `e = |F_lin| pi / (2 Q mu (kA + kS))`,
//! `r(e) = [kA e / (1 + (kA e)^2) + atan(kS e)] / ((kA + kS) e)`; below `e = 1e-4`
//! its Taylor series `1 - (kA^3 + kS^3/3) e^2 / (kA + kS)` (no 0/0 at zero creepage).

use crate::plant::Scalar;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::fmt;

/// Polach's parameters of one rail condition.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct Polach {
    /// Maximum friction coefficient `mu0` (at zero slip velocity), 1.
    pub mu0: f64,
    /// Ratio of the limit friction coefficient at infinite slip velocity to `mu0`, 1.
    pub a: f64,
    /// Exponential decrease rate of the friction coefficient with slip velocity, s/m.
    pub b: f64,
    /// Reduction factor in the area of adhesion, 1.
    pub ka: f64,
    /// Reduction factor in the area of slip, 1.
    pub ks: f64,
}

/// Below this `e` the reduction factor is evaluated by its Taylor series.
const E_SERIES: f64 = 1e-4;

impl Polach {
    /// The reduction factor `r(e) = F / |F_lin|` (see the module docs), for `e >= 0`.
    #[inline]
    pub fn reduction<S: Scalar>(&self, e: S) -> S {
        let c = S::c;
        let ksum = self.ka + self.ks;
        if e.re().abs() < E_SERIES {
            let k3 = self.ka.powi(3) + self.ks.powi(3) / 3.0;
            return c(1.0) - c(k3 / ksum) * e * e;
        }
        let kae = c(self.ka) * e;
        (kae / (c(1.0) + kae * kae) + (c(self.ks) * e).atan()) / (c(ksum) * e)
    }

    /// `r(e)` for the linear force `(fx, fy)` (N) of a wheel with load `q` (N) and
    /// resultant slip velocity `w` (m/s, `>= 0`), the friction coefficient being
    /// `mu = mu0 [(1 - A) exp(-B w) + A]`.
    #[inline]
    pub fn scale<S: Scalar>(&self, q: f64, fx: S, fy: S, w: S) -> S {
        let c = S::c;
        let mu = c(self.mu0) * (c(1.0 - self.a) * (c(-self.b) * w).exp() + c(self.a));
        let f = (fx * fx + fy * fy).sqrt();
        let e = f * c(PI / (2.0 * q * (self.ka + self.ks))) / mu;
        self.reduction(e)
    }

    /// Force over load `F/Q` of a pure longitudinal creepage `s` at speed `v` (m/s)
    /// with the creep coefficient `f` (N) and wheel load `q` (N): the characteristic.
    pub fn force_over_q(&self, q: f64, f: f64, s: f64, v: f64) -> f64 {
        let r = self.scale(q, f * s, 0.0, s.abs() * v);
        f * s * r / q
    }

    /// The peak `(s_peak, F/Q)` of [`Self::force_over_q`] over creepage `0..=s_max`
    /// (golden-section refinement of a 2 000-point scan).
    pub fn peak(&self, q: f64, f: f64, v: f64, s_max: f64) -> (f64, f64) {
        let n = 2000;
        let g = |s: f64| self.force_over_q(q, f, s, v);
        let (mut best_i, mut best) = (0usize, f64::NEG_INFINITY);
        for i in 0..=n {
            let y = g(s_max * i as f64 / n as f64);
            if y > best {
                best = y;
                best_i = i;
            }
        }
        let h = s_max / n as f64;
        let (mut lo, mut hi) = (
            (best_i as f64 - 1.0).max(0.0) * h,
            (best_i as f64 + 1.0).min(n as f64) * h,
        );
        let phi = (5f64.sqrt() - 1.0) / 2.0;
        for _ in 0..60 {
            let a = hi - phi * (hi - lo);
            let b = lo + phi * (hi - lo);
            if g(a) < g(b) {
                lo = a;
            } else {
                hi = b;
            }
        }
        let s = 0.5 * (lo + hi);
        (s, g(s).max(best))
    }
}

/// A rail condition with its published (or stated) Polach parameters.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Hash)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum Condition {
    /// Dry rail.
    Dry,
    /// Wet rail.
    Wet,
    /// Low adhesion (leaves, contamination).
    Low,
}

impl Condition {
    /// Every condition, in table order.
    pub const ALL: [Condition; 3] = [Condition::Dry, Condition::Wet, Condition::Low];

    /// Lower-case name (`dry`, `wet`, `low`).
    pub fn name(self) -> &'static str {
        match self {
            Condition::Dry => "dry",
            Condition::Wet => "wet",
            Condition::Low => "low",
        }
    }

    /// The condition named `s` (`dry`, `wet`, `low`).
    pub fn from_name(s: &str) -> Option<Condition> {
        Self::ALL.into_iter().find(|c| c.name() == s)
    }

    /// Polach's parameters of this condition (`low` is a project choice: the `wet` shape
    /// with `mu0` scaled to a peak of ~0.06 at 83.3 m/s).
    pub fn polach(self) -> Polach {
        match self {
            Condition::Dry => Polach {
                mu0: 0.55,
                a: 0.40,
                b: 0.60,
                ka: 0.54,
                ks: 0.18,
            },
            Condition::Wet => Polach {
                mu0: 0.30,
                a: 0.40,
                b: 0.29,
                ka: 0.30,
                ks: 0.075,
            },
            Condition::Low => Polach {
                mu0: 0.08,
                a: 0.40,
                b: 0.29,
                ka: 0.30,
                ks: 0.075,
            },
        }
    }

    /// Where the parameters come from.
    pub fn source(self) -> &'static str {
        match self {
            Condition::Dry => {
                "Polach, Wear 258 (2005) 992-1000, validation set: dry rail, SBB Re 460 locomotive"
            }
            Condition::Wet => {
                "Polach, Wear 258 (2005) 992-1000, validation set: wet rail, 12X locomotive"
            }
            Condition::Low => {
                "project choice: Polach 2005 wet shape with mu0 = 0.08 (contaminated rail 0.03-0.08, docs/model.md)"
            }
        }
    }
}

impl fmt::Display for Condition {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.pad(self.name())
    }
}

/// The adhesion law in force on the plant: the condition's parameters and the wheel load.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Adhesion {
    /// Wheel load `Q`, N (per wheel).
    pub q: f64,
    /// The rail condition.
    pub condition: Condition,
    /// Its parameters.
    pub law: Polach,
}

impl Adhesion {
    /// The law of `condition` with wheel load `q` (N).
    pub fn new(condition: Condition, q: f64) -> Self {
        Adhesion {
            q,
            condition,
            law: condition.polach(),
        }
    }

    /// Applies the law to one wheel's linear forces `(fx, fy)` (N) at speed `v` (m/s);
    /// the creepages are `fx/f11`, `fy/f22`.
    #[inline]
    pub fn apply<S: Scalar>(&self, fx: S, fy: S, inv_f11: f64, inv_f22: f64, v: S) -> (S, S) {
        let c = S::c;
        let sx = fx * c(inv_f11);
        let sy = fy * c(inv_f22);
        let w = (sx * sx + sy * sy).sqrt() * v;
        let r = self.law.scale(self.q, fx, fy, w);
        (fx * r, fy * r)
    }

    /// Peak adhesion `F/Q` of a pure longitudinal creepage at speed `v` (m/s) with the
    /// creep coefficient `f11` (N), searched over creepage 0..0.2.
    pub fn peak(&self, f11: f64, v: f64) -> f64 {
        self.law.peak(self.q, f11, v, 0.2).1
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn small_creep_slope_is_the_creep_coefficient() {
        let q = 55_181.0;
        for c in Condition::ALL {
            let p = c.polach();
            for f in [1e6, 10e6] {
                let s = 1e-9;
                let slope = p.force_over_q(q, f, s, 83.3) * q / s;
                assert!((slope / f - 1.0).abs() < 1e-6, "{c}: {slope} vs {f}");
            }
        }
    }

    #[test]
    fn reduction_series_and_closed_form_agree_at_the_switch() {
        for c in Condition::ALL {
            let p = c.polach();
            let a: f64 = p.reduction(E_SERIES * 0.999_999);
            let b: f64 = p.reduction(E_SERIES * 1.000_001);
            assert!((a - b).abs() < 1e-12, "{c}: {a} vs {b}");
            assert_eq!(p.reduction(0.0f64), 1.0);
        }
    }

    #[test]
    fn peaks_are_in_the_published_ranges_and_ordered() {
        let q = 55_181.0;
        let dry = Adhesion::new(Condition::Dry, q).peak(10e6, 83.3);
        let wet = Adhesion::new(Condition::Wet, q).peak(10e6, 83.3);
        let low = Adhesion::new(Condition::Low, q).peak(10e6, 83.3);
        assert!(dry > 0.25 && dry < 0.45, "dry {dry}");
        assert!(wet > 0.1 && wet < 0.25, "wet {wet}");
        assert!(low > 0.03 && low < 0.08, "low {low}");
        // Past the peak the force falls with slip velocity.
        let p = Condition::Wet.polach();
        assert!(p.force_over_q(q, 10e6, 0.2, 83.3) < wet * 0.9);
    }

    #[test]
    fn direction_is_kept() {
        let a = Adhesion::new(Condition::Wet, 55_181.0);
        let (fx, fy) = a.apply(3e4, -2e4, 1e-7, 1e-7, 83.3);
        assert!(fx > 0.0 && fy < 0.0);
        assert!((fx / fy - 3e4 / -2e4).abs() < 1e-12);
    }
}
