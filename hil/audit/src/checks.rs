//! The checks: every figure of a [`Core`] judged against the [`Tolerances`].

use wheelset_control::Config;

use super::bounds::Proofs;
use super::closed::LimitCycleReport;
use super::margins::Margin;
use super::model::ControllerAudit;
use super::ranges::{self, Observed};
use super::verdict::{judge, Check, Status, Tolerances};
use super::Core;

/// Judge one controller's figures.
pub fn controller_checks(a: &ControllerAudit, tol: &Tolerances, cfg: &Config) -> Vec<Check> {
    let n = &a.name;
    let mut v = Vec::new();
    for c in &a.coefficients {
        v.push(judge(
            n,
            &format!("coefficient {} relative quantisation error", c.name),
            c.rel_err,
            tol.coef_rel,
            "",
            "relative error",
        ));
    }
    for (i, s) in a.poles_zeros.shift_quantisation_rel.iter().enumerate() {
        v.push(judge(
            n,
            &format!("root {i} relative shift (quantised vs f64)"),
            *s,
            tol.root_rel,
            "",
            "relative shift",
        ));
    }
    if let Some(r) = a.dc_gain.fixed_vs_continuous_rel {
        v.push(judge(
            n,
            "DC gain, fixed (measured) vs continuous",
            r,
            tol.dc_rel,
            "",
            "relative error",
        ));
    }
    let w = &a.worst;
    v.push(judge(
        n,
        &format!(
            "gain error fixed vs f64 below {:.0} Hz (worst at {:.3} Hz)",
            w.below_hz, w.fixed_gain_db.1
        ),
        w.fixed_gain_db.0,
        tol.fixed_gain_db,
        "dB",
        "gain error",
    ));
    v.push(judge(
        n,
        &format!(
            "phase error fixed vs f64 below {:.0} Hz (worst at {:.3} Hz)",
            w.below_hz, w.fixed_phase_deg.1
        ),
        w.fixed_phase_deg.0,
        tol.fixed_phase_deg,
        "deg",
        "phase error",
    ));
    if n == "yaw_predictor" {
        // The predictor approximates an ideal advance by design; its deviation from it
        // is the sampled-data analysis' business, not a numerics figure: not judged.
        return v;
    }
    v.push(judge(
        n,
        &format!(
            "gain error discrete f64 vs continuous below {:.0} Hz (worst at {:.3} Hz)",
            w.below_hz, w.discrete_gain_db.1
        ),
        w.discrete_gain_db.0,
        tol.discrete_gain_db,
        "dB",
        "discretisation gain error",
    ));
    v.push(judge(
        n,
        &format!(
            "phase error discrete f64 vs continuous below {:.0} Hz (worst at {:.3} Hz)",
            w.below_hz, w.discrete_phase_deg.1
        ),
        w.discrete_phase_deg.0,
        tol.discrete_phase_deg,
        "deg",
        "discretisation phase error",
    ));
    let wire = match n.as_str() {
        "traction_pi" => cfg.wire.voltage,
        _ => cfg.wire.torque,
    };
    for lc in &a.limit_cycles {
        v.push(judge(
            n,
            &format!("limit cycle amplitude, hold {}", lc.hold),
            lc.amplitude_si / wire,
            tol.limit_cycle_wire_lsb,
            "wire LSB",
            "sustained oscillation amplitude",
        ));
        v.push(judge(
            n,
            &format!("dead-band offset vs f64, hold {}", lc.hold),
            lc.offset_si / wire,
            tol.limit_cycle_wire_lsb,
            "wire LSB",
            "final offset",
        ));
    }
    v
}

/// Judge ranges and noise.
pub fn observed_checks(o: &Observed, tol: &Tolerances) -> Vec<Check> {
    let mut v = Vec::new();
    for s in &o.signals {
        if s.samples == 0 {
            continue;
        }
        let mut c = judge(
            &s.controller,
            &format!("{} overflows (outside the signal format)", s.name),
            s.overflows as f64,
            (0.0, 0.0),
            "samples",
            "overflowed samples",
        );
        if s.overflows > 0 {
            c.reason = format!(
                "{} overflows: {} samples outside the signal format (peak {:.3} pu, headroom \
                 {:.2} bits) in scenario {}",
                s.name,
                s.overflows,
                s.min_pu.abs().max(s.max_pu.abs()),
                s.headroom_bits,
                s.worst_scenario
            );
        }
        v.push(c);
        let h = s.headroom_bits;
        let status = if h < tol.headroom_bits.1 {
            Status::Fail
        } else if h < tol.headroom_bits.0 {
            Status::Warn
        } else {
            Status::Pass
        };
        v.push(Check {
            controller: s.controller.clone(),
            item: format!("{} headroom", s.name),
            value: h,
            warn: tol.headroom_bits.0,
            fail: tol.headroom_bits.1,
            unit: "bits".into(),
            status,
            reason: format!(
                "headroom {h:.2} bits (warn below {} bits, fail below {})",
                tol.headroom_bits.0, tol.headroom_bits.1
            ),
        });
    }
    for nz in &o.noise {
        let ctrl = if nz.output == "u_a" {
            "traction_pi".to_string()
        } else {
            format!("yaw_{}", nz.yaw_mode)
        };
        v.push(match nz.phase {
            ranges::Phase::Normal => judge(
                &ctrl,
                &format!("{} max error vs f64, scenario {}", nz.output, nz.scenario),
                nz.max_wire_lsb,
                tol.noise_wire_lsb,
                "wire LSB",
                "max quantisation error",
            ),
            ranges::Phase::SafeRamp => judge(
                &ctrl,
                &format!(
                    "{} max error vs f64 during the safe-state ramps, scenario {}",
                    nz.output, nz.scenario
                ),
                nz.max_of_limit,
                tol.ramp_of_limit,
                "of the output limit",
                "ramp-profile error (quantised per-step increment, accumulated)",
            ),
        });
    }
    v
}

/// Every check of a core run: per controller, then ranges and noise.
pub fn all_checks(c: &Core, tol: &Tolerances, cfg: &Config) -> Vec<Check> {
    let mut v: Vec<Check> = c
        .controllers
        .iter()
        .flat_map(|a| controller_checks(a, tol, cfg))
        .collect();
    v.extend(observed_checks(&c.observed, tol));
    v
}

/// Judge the proofs: overflow freedom proven (smallest margin, bits), no observed value
/// above its proven bound (a failure would be a wrong proof), and the proven output
/// errors against the noise tolerance (wire LSBs).
pub fn proof_checks(p: &Proofs, tol: &Tolerances) -> Vec<Check> {
    let mut v = Vec::new();
    let (margin, worst) = p
        .bounds
        .iter()
        .map(|b| (b.margin_bits, b.signal.as_str()))
        .fold((f64::INFINITY, ""), |a, b| if b.0 < a.0 { b } else { a });
    let status = if !p.overflow_free || margin.is_nan() || margin <= 0.0 {
        Status::Fail
    } else {
        Status::Pass
    };
    v.push(Check {
        controller: "all".into(),
        item: "proven: no overflow for any input within the clamps".into(),
        value: margin,
        warn: 0.0,
        fail: 0.0,
        unit: "bits".into(),
        status,
        reason: format!(
            "smallest margin of a proven bound to the format's range {margin:.2} bits ({worst}); \
             fail at or below 0"
        ),
    });
    let over: Vec<&str> = p
        .bounds
        .iter()
        .filter(|b| b.observed_max.is_some_and(|o| o > b.proven_max))
        .map(|b| b.signal.as_str())
        .collect();
    let mut c = judge(
        "all",
        "observed values above their proven bound",
        over.len() as f64,
        (0.0, 0.0),
        "signals",
        "signals above the proof",
    );
    if !over.is_empty() {
        c.reason = format!("observed above the proven bound: {}", over.join(", "));
    }
    v.push(c);
    let eo = p
        .error_bounds
        .iter()
        .filter(|e| e.observed > e.proven)
        .count();
    v.push(judge(
        "all",
        "observed rounding errors above their proven bound",
        eo as f64,
        (0.0, 0.0),
        "outputs",
        "outputs above the proof",
    ));
    for e in p
        .error_bounds
        .iter()
        .filter(|e| !e.output.starts_with("i_ref"))
    {
        v.push(judge(
            "all",
            &format!("proven rounding error {}", e.output),
            e.proven_wire_lsb,
            tol.noise_wire_lsb,
            "wire LSB",
            "proven worst-case error",
        ));
    }
    v
}

/// Judge the closed loop: the straight-track limit cycle's amplitude in wire LSBs of the
/// torque (against the limit-cycle tolerance: a self-sustained cycle of several LSB is a
/// warning, a dither within the proven rounding bound passes) and the margins' loss by
/// quantisation (informational: the change in dB / degrees, judged against the
/// discretisation tolerances).
pub fn closed_loop_checks(lc: &LimitCycleReport, m: &[Margin], cfg: &Config) -> Vec<Check> {
    let mut v = Vec::new();
    let lsb = cfg.wire.torque;
    let mut c = judge(
        "yaw_lead",
        "closed-loop limit cycle on straight track (device in the loop, curve 17-20 s)",
        lc.amplitude / lsb,
        // A self-sustained cycle (above twice the proven rounding bound or one wire
        // LSB, the dither limit of `closed`) warns; the loop stays bounded, so no fail.
        ((2.0 * lc.dither_limit_nm).max(lsb) / lsb, f64::INFINITY),
        "wire LSB peak to peak",
        "torque peak to peak",
    );
    c.reason = format!(
        "{}; attribution (p2p with the source removed): {}",
        lc.classification,
        lc.attribution
            .iter()
            .map(|(k, a)| format!("{k} {a:.2} N m"))
            .collect::<Vec<_>>()
            .join(", ")
    );
    v.push(c);
    for x in m {
        if let (Some(a), Some(b)) = (x.phase_deg_ideal, x.phase_deg_quantised) {
            v.push(judge(
                &x.loop_name,
                "phase margin change by quantisation",
                b - a,
                (0.1, 1.0),
                "deg",
                "phase margin change",
            ));
        }
        if let (Some(a), Some(b)) = (x.gain_db_ideal, x.gain_db_quantised) {
            v.push(judge(
                &x.loop_name,
                "gain margin change by quantisation",
                b - a,
                (0.01, 0.1),
                "dB",
                "gain margin change",
            ));
        }
    }
    v
}
