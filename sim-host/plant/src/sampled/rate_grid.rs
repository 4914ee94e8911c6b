//! The rate grid and the choice: every candidate base rate and divisor pair over the
//! robustness grid of creep and conicity, the link each needs, and the rule that picks one.

use super::*;
use crate::params::Params;
use nalgebra::Complex;
use wheelset_control::{Config, YawMode};

/// Creep coefficients of the robustness grid (f11 = f22), N.
pub const CREEP_GRID: [f64; 6] = [1e6, 2e6, 3e6, 5e6, 7e6, 10e6];

/// Conicities of the robustness grid.
pub const CONICITY_GRID: [f64; 5] = [0.05, 0.1, 0.2, 0.3, 0.4];

/// The nominal point (docs/model.md defaults): 10 MN, conicity 0.2.
pub const NOMINAL: (f64, f64) = (10e6, 0.2);

/// Link budget: a Sensor frame in, an Actuation frame out, sequential within one period
/// ([`wheelset_proto::link`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkBudget {
    /// Sensor frame bytes on the wire (`wheelset_proto::SENSOR_ONE_LATERAL_MAX_FRAME`).
    pub bytes_in: u32,
    /// Actuation frame bytes (`wheelset_proto::ACTUATION_MAX_FRAME`).
    pub bytes_out: u32,
    /// One-way latency, ns (the round trip takes it twice).
    pub latency_ns: u64,
    /// Largest acceptable share of the period, permille (the design target,
    /// [`wheelset_proto::link::LINK_SHARE_WARN_PERMILLE`]).
    pub share_permille: u32,
    /// The baud the table quotes utilisation at.
    pub baud: u32,
}

impl Default for LinkBudget {
    fn default() -> Self {
        Self {
            bytes_in: wheelset_proto::SENSOR_ONE_LATERAL_MAX_FRAME as u32,
            bytes_out: wheelset_proto::ACTUATION_MAX_FRAME as u32,
            latency_ns: 5_000,
            share_permille: wheelset_proto::link::LINK_SHARE_WARN_PERMILLE,
            baud: 2_000_000,
        }
    }
}

impl LinkBudget {
    /// Fraction of the period `1/base_hz` the round trip takes at `baud`
    /// ([`wheelset_proto::link::round_trip_ns`]).
    pub fn utilisation(&self, base_hz: f64, baud: f64) -> f64 {
        let rt = wheelset_proto::link::round_trip_ns(
            baud as u32,
            self.bytes_in,
            self.bytes_out,
            self.latency_ns,
        );
        rt as f64 * base_hz / 1e9
    }
    /// The smallest baud that keeps the round trip within `share_permille`
    /// ([`wheelset_proto::link::min_baud`]; infinite if none does).
    pub fn min_baud(&self, base_hz: f64) -> f64 {
        wheelset_proto::link::min_baud(
            base_hz as u32,
            self.bytes_in,
            self.bytes_out,
            self.latency_ns,
            self.share_permille,
        )
        .map_or(f64::INFINITY, f64::from)
    }
    /// [`Self::share_permille`] as a fraction.
    pub fn max_utilisation(&self) -> f64 {
        f64::from(self.share_permille) / 1000.0
    }
}

/// Where on the grid, and which mode.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct GridMode {
    /// Creep coefficient, N.
    #[serde(rename = "creep_n")]
    pub creep: f64,
    /// Conicity.
    pub lambda: f64,
    /// The mode.
    pub freq_hz: f64,
    /// Its damping ratio.
    pub zeta: f64,
}

/// One row of the rate table (its JSON adds `yaw_hz`).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct RateRow {
    /// Base rate, Hz.
    pub base_hz: u32,
    /// Yaw divisor.
    pub yaw_divisor: u16,
    /// Traction divisor.
    pub traction_divisor: u16,
    /// Delay, ticks.
    pub delay_ticks: usize,
    /// Current loop (armature + PI alone): radius per base tick of its fast mode.
    pub current_radius: f64,
    /// Current loop: damping ratio of its fast mode (continuous: 1, real pole).
    pub current_zeta: f64,
    /// Least-damped mode of the sampled loop over the grid.
    pub worst_sampled: GridMode,
    /// Least-damped mode of the continuous loop over the grid.
    pub worst_continuous: GridMode,
    /// Least-damped sampled mode where the continuous loop is stable (the rate's responsibility).
    pub worst_sampled_stable_region: GridMode,
    /// Largest damping loss `zeta_cont - zeta_sampled` of the worst modes, per grid point.
    pub max_damping_loss: f64,
    /// Grid points stable in continuous time but unstable sampled.
    pub newly_unstable: usize,
    /// Grid points unstable in continuous time already (the control law's own limit).
    pub unstable_continuous: usize,
    /// Worst sampled damping at the nominal point.
    pub nominal_zeta: f64,
    /// Spectral radius per base tick, worst over the grid (free rolling excluded).
    pub max_radius: f64,
    /// Link utilisation at `LinkBudget::baud`.
    pub link_utilisation: f64,
    /// Smallest baud for `LinkBudget::max_utilisation`.
    pub min_baud: f64,
}

/// Damping ratios closer than this are the same mode's, equal but for roundoff.
const ZETA_TIE: f64 = 1e-9;

/// Whether `zeta` is worse than `worst` beyond roundoff (of ties, the first in grid order).
fn worse(zeta: f64, worst: f64) -> bool {
    zeta < worst - ZETA_TIE
}

/// The `(zeta, freq_hz)` of least `zeta` from `first` on (ties: the earliest).
fn least(first: (f64, f64), rest: impl Iterator<Item = (f64, f64)>) -> (f64, f64) {
    rest.fold(first, |a, z| if z.0 < a.0 { z } else { a })
}

fn worst_continuous(ev: &[Complex<f64>]) -> (f64, f64) {
    let oscillating = (ev.iter().filter(|e| e.im.abs() > 1e-9))
        .map(|e| (zeta_of(*e), e.im.abs() / (2.0 * std::f64::consts::PI)));
    let real_unstable =
        (ev.iter().filter(|e| e.im.abs() <= 1e-9 && e.re >= 0.0)).map(|e| (-1.0 - e.re, 0.0));
    least((1.0, 0.0), oscillating.chain(real_unstable))
}

fn worst_sampled(cl: &ClosedLoop) -> (f64, f64) {
    let real_unstable = (cl.modes.iter())
        .filter(|m| m.freq_hz <= 1e-6 && m.radius >= 1.0)
        .map(|m| (-1.0 - (m.radius - 1.0), 0.0));
    least((cl.worst.zeta, cl.worst.freq_hz), real_unstable)
}

/// The current loop's fast mode: the PI of `cfg` on the armature circuit alone with
/// `delay_ticks` of delay, the slowest of the modes faster than 50 rad/s (not the PI's
/// own pole near `-1/Ti`). A `radius` of 1 or more is a limit cycle at `freq_hz`.
pub fn current_loop_mode(
    armature: &LinearPlant,
    cfg: &Config,
    delay_ticks: usize,
) -> Result<Mode, String> {
    let cur = closed_loop(
        armature,
        &Config {
            yaw_mode: YawMode::Passive,
            traction_enabled: true,
            // 1: the hyper-period (and so the equivalent damping) free of aliasing.
            yaw_divisor: 1,
            yaw_predict_ticks: 0.0,
            ..*cfg
        },
        delay_ticks,
    )?;
    Ok(cur
        .modes
        .iter()
        .filter(|m| m.s.norm() > 50.0)
        .max_by(|a, b| a.radius.total_cmp(&b.radius))
        .copied()
        .unwrap_or(cur.worst))
}

/// Evaluate one candidate timing over the grid. `plant(creep, lambda, yaw_spring)` gives
/// the linear plant; `armature` the current-loop plant alone.
pub fn rate_row(
    base: &Config,
    candidate: (u32, u16, u16),
    delay_ticks: usize,
    plant: &dyn Fn(f64, f64, bool) -> LinearPlant,
    armature: &LinearPlant,
    link: &LinkBudget,
) -> Result<RateRow, String> {
    let mut cfg = Config {
        base_rate_hz: candidate.0,
        yaw_divisor: candidate.1,
        traction_divisor: candidate.2,
        ..*base
    };
    if cfg.yaw_predict_ticks > 0.0 {
        // The matched compensation for this divisor: ZOH + one tick.
        cfg.yaw_predict_ticks = 1.0 + candidate.1 as f64 / 2.0;
    }
    let spring = cfg.yaw_mode == YawMode::Passive;
    let fast = current_loop_mode(armature, &cfg, delay_ticks)?;
    let none = GridMode {
        creep: 0.0,
        lambda: 0.0,
        freq_hz: 0.0,
        zeta: f64::INFINITY,
    };
    let mut row = RateRow {
        base_hz: cfg.base_rate_hz,
        yaw_divisor: cfg.yaw_divisor,
        traction_divisor: cfg.traction_divisor,
        delay_ticks,
        current_radius: fast.radius,
        current_zeta: fast.zeta,
        worst_sampled: none,
        worst_continuous: none,
        worst_sampled_stable_region: none,
        max_damping_loss: f64::NEG_INFINITY,
        newly_unstable: 0,
        unstable_continuous: 0,
        nominal_zeta: f64::NAN,
        max_radius: 0.0,
        link_utilisation: link.utilisation(cfg.base_rate_hz as f64, link.baud as f64),
        min_baud: link.min_baud(cfg.base_rate_hz as f64),
    };
    for &creep in &CREEP_GRID {
        for &lambda in &CONICITY_GRID {
            let p = plant(creep, lambda, spring);
            let cl = closed_loop(&p, &cfg, delay_ticks)?;
            let ct = continuous_closed_loop(&p, &cfg);
            let (zs, fs) = worst_sampled(&cl);
            let (zc, fc) = worst_continuous(&ct);
            let cont_stable = ct.iter().all(|e| e.re < 0.0);
            row.unstable_continuous += (!cont_stable) as usize;
            row.newly_unstable += (cont_stable && !cl.stable()) as usize;
            row.max_damping_loss = row.max_damping_loss.max(zc - zs);
            row.max_radius = row.max_radius.max(cl.spectral_radius);
            let mode = |freq_hz, zeta| GridMode {
                creep,
                lambda,
                freq_hz,
                zeta,
            };
            if worse(zs, row.worst_sampled.zeta) {
                row.worst_sampled = mode(fs, zs);
            }
            if cont_stable && worse(zs, row.worst_sampled_stable_region.zeta) {
                row.worst_sampled_stable_region = mode(fs, zs);
            }
            if worse(zc, row.worst_continuous.zeta) {
                row.worst_continuous = mode(fc, zc);
            }
            if (creep, lambda) == NOMINAL {
                row.nominal_zeta = zs;
            }
        }
    }
    Ok(row)
}

/// The candidate timings: base 1-10 kHz, yaw at divisors giving 0.5-10 kHz, traction at base.
pub fn candidates() -> Vec<(u32, u16, u16)> {
    let mut v = Vec::new();
    for base in [1000u32, 2000, 2500, 4000, 5000, 8000, 10_000] {
        for yd in [1u16, 2, 4, 5, 10] {
            let yaw = base / yd as u32;
            if base % yd as u32 == 0 && (500..=10_000).contains(&yaw) {
                v.push((base, yd, 1));
            }
        }
    }
    v
}

/// The creep coefficient (N) below which the continuous loop of `cfg` is unstable at
/// `lambda` (bisection on 0.1-20 MN); `None` if stable (or unstable) throughout.
pub fn critical_creep(
    cfg: &Config,
    lambda: f64,
    plant: &dyn Fn(f64, f64, bool) -> LinearPlant,
) -> Option<f64> {
    let spring = cfg.yaw_mode == YawMode::Passive;
    let stable = |c: f64| {
        continuous_closed_loop(&plant(c, lambda, spring), cfg)
            .iter()
            .all(|e| e.re < 0.0)
    };
    let (mut lo, mut hi) = (0.1e6, 20e6);
    let s_hi = stable(hi);
    if stable(lo) == s_hi {
        return None;
    }
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if stable(mid) == s_hi {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

/// What a candidate must meet to be chosen.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Criteria {
    /// Largest radius per base tick of the current loop's fast mode.
    pub max_current_radius: f64,
    /// The fastest UART the link may assume, baud.
    pub max_baud: f64,
}

impl Default for Criteria {
    fn default() -> Self {
        Self {
            max_current_radius: 0.75,
            max_baud: 6.0e6,
        }
    }
}

/// One variant of the table: with or without the yaw delay compensation.
#[derive(Debug, Clone)]
pub struct Variant {
    /// Yaw predictor on (matched to each divisor: `1 + yaw_divisor/2` ticks) or off.
    pub predict: bool,
    /// All candidates.
    pub rows: Vec<RateRow>,
    /// The chosen candidate: the lowest base rate meeting the criteria (ties: least damping loss).
    pub chosen: Option<RateRow>,
}

fn choose(rows: &[RateRow], c: &Criteria) -> Option<RateRow> {
    rows.iter()
        .filter(|r| {
            r.current_radius <= c.max_current_radius
                && r.newly_unstable == 0
                && r.min_baud <= c.max_baud
        })
        .min_by(|a, b| {
            (a.base_hz.cmp(&b.base_hz)).then(a.max_damping_loss.total_cmp(&b.max_damping_loss))
        })
        .copied()
}

/// The rate table over [`candidates`] for `base`, with and without the yaw delay compensation.
pub fn rates(
    params: &Params,
    model: Model,
    base: &Config,
    delay_ticks: usize,
    link: &LinkBudget,
    criteria: &Criteria,
) -> Result<RatesReport, String> {
    let plant = |c: f64, l: f64, s: bool| model.plant(params, c, l, s);
    let arm = armature(params.l_a, params.r_a);
    let cfg = *base;
    // Every matrix finite first: a non-finite one is refused with the parameter to blame.
    let corners = |q: &Params| {
        let mut v = vec![armature(q.l_a, q.r_a).a];
        for &c in &[CREEP_GRID[0], CREEP_GRID[CREEP_GRID.len() - 1]] {
            for &l in &[CONICITY_GRID[0], CONICITY_GRID[CONICITY_GRID.len() - 1]] {
                for s in [false, true] {
                    let lp = model.plant(q, c, l, s);
                    let t0 = 1.0 / f64::from(base.base_rate_hz.max(1));
                    let finite = crate::finite::check_finite(&lp.a, "").is_ok()
                        && crate::finite::check_finite(&lp.b, "").is_ok();
                    if finite {
                        let (ad, bd) = zoh(&lp.a, &lp.b, t0);
                        v.extend([ad, bd]);
                    }
                    v.extend([lp.a, lp.b]);
                }
            }
        }
        v
    };
    if let Some(m) = corners(params)
        .iter()
        .find_map(|m| crate::finite::check_finite(m, "a plant matrix").err())
    {
        return Err(match crate::finite::blame_nonfinite(params, corners) {
            Some(key) => format!(
                "{m}; parameter `{key}` is to blame (its default makes the matrices finite)"
            ),
            None => m,
        });
    }
    let critical_creep = CONICITY_GRID
        .iter()
        .map(|&l| (l, critical_creep(&cfg, l, &plant)))
        .collect();
    let mut variants = Vec::new();
    for predict in [false, true] {
        let c = Config {
            yaw_predict_ticks: if predict { 1.5 } else { 0.0 },
            ..cfg
        };
        let rows = candidates()
            .into_iter()
            .map(|cand| rate_row(&c, cand, delay_ticks, &plant, &arm, link))
            .collect::<Result<Vec<_>, _>>()?;
        let chosen = choose(&rows, criteria);
        variants.push(Variant {
            predict,
            rows,
            chosen,
        });
    }
    Ok(RatesReport {
        model,
        mode: base.yaw_mode,
        delay_ticks,
        link: *link,
        criteria: *criteria,
        critical_creep,
        variants,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_tie_within_roundoff_keeps_the_first_grid_point() {
        let first = -0.323_000_000_000_1;
        assert!(worse(first, f64::INFINITY));
        // The same mode at a later grid point, lower only in its last bits: not worse.
        assert!(!worse(first - 1e-13, first));
        // A lower damping by more than roundoff is.
        assert!(worse(first - 1e-6, first));
        assert!(!worse(f64::NAN, first));
    }
}
