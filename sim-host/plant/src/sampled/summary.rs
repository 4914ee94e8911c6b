//! The rate table as JSON and as text.

use super::*;
use crate::control::YawLaw;
use serde_json::{json, Value};
use wheelset_control::YawMode;

/// The rate table.
#[derive(Debug, Clone)]
pub struct RatesReport {
    /// The plant.
    pub model: Model,
    /// Yaw mode analysed.
    pub mode: YawMode,
    /// Delay in ticks.
    pub delay_ticks: usize,
    /// Link assumptions.
    pub link: LinkBudget,
    /// Selection criteria.
    pub criteria: Criteria,
    /// `(lambda, creep below which the continuous loop is unstable)`.
    pub critical_creep: Vec<(f64, Option<f64>)>,
    /// Without and with the delay compensation.
    pub variants: Vec<Variant>,
}

fn row_json(r: &RateRow) -> Value {
    let mut v = json!(r);
    v["yaw_hz"] = json!(r.base_hz as f64 / r.yaw_divisor as f64);
    v
}

impl RatesReport {
    /// The report as JSON.
    pub fn to_json(&self) -> Value {
        json!({
            "model": self.model.name(),
            "control": YawLaw::from(self.mode).name(),
            "delay_ticks": self.delay_ticks,
            "grid": {"creep_n": CREEP_GRID, "conicity": CONICITY_GRID},
            "nominal": {"creep_n": NOMINAL.0, "lambda": NOMINAL.1},
            "link": {
                "bytes_in": self.link.bytes_in,
                "bytes_out": self.link.bytes_out,
                "latency_ns": self.link.latency_ns,
                "max_utilisation": self.link.max_utilisation(),
                "baud": self.link.baud,
            },
            "criteria": self.criteria,
            "critical_creep_n": self.critical_creep.iter().map(|(l, c)| json!({"lambda": l, "creep_n": c})).collect::<Vec<_>>(),
            "variants": self.variants.iter().map(|v| json!({
                "yaw_predict": if v.predict { "1 + yaw_divisor/2 ticks" } else { "off" },
                "rows": v.rows.iter().map(row_json).collect::<Vec<_>>(),
                "chosen": v.chosen.as_ref().map(row_json),
            })).collect::<Vec<_>>(),
        })
    }

    /// The report as a text table.
    pub fn render(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "sampled-data rate analysis: {} plant, {} yaw control, ZOH + {} tick(s) of delay",
            self.model.name(),
            YawLaw::from(self.mode).name(),
            self.delay_ticks
        );
        let _ = writeln!(
            s,
            "grid: creep {:?} MN x conicity {:?}; free-rolling mode excluded",
            CREEP_GRID.map(|c| c / 1e6),
            CONICITY_GRID
        );
        for (l, c) in &self.critical_creep {
            let _ = match c {
                Some(c) => writeln!(
                    s,
                    "continuous loop: stability changes at creep {:.2} MN (conicity {l})",
                    c / 1e6
                ),
                None => writeln!(
                    s,
                    "continuous loop: no crossing in 0.1-20 MN (conicity {l})"
                ),
            };
        }
        let _ = writeln!(
            s,
            "link: {} + {} bytes x 10 bits + 2 x {:.0} us latency per period, <= {:.0} % (utilisation quoted at {} baud)",
            self.link.bytes_in,
            self.link.bytes_out,
            self.link.latency_ns as f64 * 1e-3,
            self.link.max_utilisation() * 100.0,
            self.link.baud
        );
        for v in &self.variants {
            let _ = writeln!(
                s,
                "\n== yaw delay compensation {}",
                if v.predict {
                    "on (1 + yaw_divisor/2 ticks)"
                } else {
                    "off"
                }
            );
            let _ = writeln!(
                s,
                "{:>6} {:>4} {:>6} | {:>7} {:>6} | {:>26} | {:>7} | {:>5} {:>5} | {:>7} | {:>5} {:>9}",
                "base", "yaw/", "yaw Hz", "cur r", "zeta", "worst zeta (stable region)", "loss", "new", "cont", "nominal", "util", "min baud"
            );
            for r in &v.rows {
                let w = &r.worst_sampled_stable_region;
                let _ = writeln!(
                    s,
                    "{:>6} {:>4} {:>6.0} | {:>7.3} {:>6.3} | {:>+7.3} {:>5.1} Hz {:>3.0} MN {:>4} | {:>7.4} | {:>5} {:>5} | {:>+7.3} | {:>5.2} {:>9.2e}",
                    r.base_hz,
                    r.yaw_divisor,
                    r.base_hz as f64 / r.yaw_divisor as f64,
                    r.current_radius,
                    r.current_zeta,
                    w.zeta,
                    w.freq_hz,
                    w.creep / 1e6,
                    w.lambda,
                    r.max_damping_loss,
                    r.newly_unstable,
                    r.unstable_continuous,
                    r.nominal_zeta,
                    r.link_utilisation,
                    r.min_baud
                );
            }
            let _ = match &v.chosen {
                Some(r) => writeln!(
                    s,
                    "chosen: base {} Hz, yaw divisor {}, traction divisor {} (current-loop radius {:.3} <= {}, no grid point destabilised, {:.2e} baud <= {:.1e})",
                    r.base_hz, r.yaw_divisor, r.traction_divisor, r.current_radius,
                    self.criteria.max_current_radius, r.min_baud, self.criteria.max_baud
                ),
                None => writeln!(
                    s,
                    "chosen: none meets the criteria (current-loop radius <= {}, no grid point destabilised by sampling, link <= {:.1e} baud)",
                    self.criteria.max_current_radius, self.criteria.max_baud
                ),
            };
        }
        let _ = writeln!(
            s,
            "\ncolumns: cur r/zeta = current loop (armature + PI) fast mode per base tick; worst zeta = least-damped \
             sampled mode where the continuous loop is stable; loss = max over the grid of zeta_cont - zeta_sampled \
             (worst modes); new = grid points stable continuous but unstable sampled; cont = grid points unstable in \
             continuous time; nominal = worst sampled zeta at 10 MN, 0.2; util = link utilisation at the quoted baud"
        );
        s
    }
}
