//! The checks: every figure of a [`Core`] judged against the [`Tolerances`], each with
//! the remedy to follow when it does not pass ([`Check::remedy`]).

use wheelset_control::Config;

use super::bounds::Proofs;
use super::closed::LimitCycleReport;
use super::closed::Margin;
use super::model::ControllerAudit;
use super::ranges::{self, Observed};
use super::tolerances::{judge, Check, Status, Tolerances};
use super::Core;

/// Remedy of a coefficient's quantisation (its error, the roots and DC gain it moves).
const COEF_REMEDY: &str = "more coefficient fraction bits (audit a candidate with --coef-q \
     I.F), or hold the coefficient with its own shift as the control core holds Ki \
     (`wheelset_control::sample`)";
/// Remedy of rounding in the signal path (response errors, noise, dead bands).
const SIGNAL_REMEDY: &str = "more signal fraction bits (audit a candidate with --signal-q \
     I.F; the word-length sweep of the report gives the fewest that pass), or error \
     feedback on the rounding of the state update that sustains it (as the monitor's mean \
     square has, `wheelset_control::monitor`)";
/// Remedy of a range (overflow, headroom).
const RANGE_REMEDY: &str = "more integer bits for the signal (audit a candidate with \
     --signal-q I.F, a larger I), or a smaller full scale or input clamp for it \
     (`wheelset_control::Config` `scales`, `limits`)";
/// Remedy of the discretisation's own error (not the fixed point's).
const DISCRETE_REMEDY: &str = "a higher rate for the loop (--rate, or a smaller divisor), \
     or a discretisation prewarped at the frequency that matters (the discretisation is \
     `wheelset_control`'s `LeadParams::discretise` / `PiParams::discretise`)";
/// Remedy of a proof contradicted by an observation.
const PROOF_REMEDY: &str = "the proof is unsound for this signal: fix its bound in \
     `hil::audit::bounds` (the observation is the counterexample) before trusting the \
     other proven figures";

pub fn controller_checks(a: &ControllerAudit, tol: &Tolerances, cfg: &Config) -> Vec<Check> {
    let n = &a.name;
    let coef = |item: String, value: f64, limit, what| {
        judge(n, &item, value, limit, "", what).with_remedy(COEF_REMEDY)
    };
    let mut v: Vec<Check> = a
        .coefficients
        .iter()
        .map(|c| {
            let item = format!("coefficient {} relative quantisation error", c.name);
            coef(item, c.rel_err, tol.coef_rel, "relative error")
        })
        .collect();
    v.extend(
        a.poles_zeros
            .shift_quantisation_rel
            .iter()
            .enumerate()
            .map(|(i, s)| {
                let item = format!("root {i} relative shift (quantised vs f64)");
                coef(item, *s, tol.root_rel, "relative shift")
            }),
    );
    v.extend(a.dc_gain.fixed_vs_continuous_rel.map(|r| {
        let item = "DC gain, fixed (measured) vs continuous".to_string();
        coef(item, r, tol.dc_rel, "relative error")
    }));
    let w = &a.worst;
    let both = format!("{COEF_REMEDY}; or {SIGNAL_REMEDY}");
    let fixed = [
        (w.fixed_gain_db, tol.fixed_gain_db),
        (w.fixed_phase_deg, tol.fixed_phase_deg),
    ];
    let discrete = [
        (w.discrete_gain_db, tol.discrete_gain_db),
        (w.discrete_phase_deg, tol.discrete_phase_deg),
    ];
    // The predictor's deviation from an ideal advance is by design: only its fixed point.
    let predictor = n == "yaw_predictor";
    let kinds = [
        ("fixed vs f64", "", fixed, both.as_str()),
        (
            "discrete f64 vs continuous",
            "discretisation ",
            discrete,
            DISCRETE_REMEDY,
        ),
    ];
    for (versus, of, figures, remedy) in kinds.into_iter().take(if predictor { 1 } else { 2 }) {
        for ((what, unit), ((err, at), limit)) in
            [("gain", "dB"), ("phase", "deg")].into_iter().zip(figures)
        {
            let item = format!(
                "{what} error {versus} below {:.0} Hz (worst at {at:.3} Hz)",
                w.below_hz
            );
            v.push(
                judge(n, &item, err, limit, unit, &format!("{of}{what} error")).with_remedy(remedy),
            );
        }
    }
    if predictor {
        return v;
    }
    let wire = match n.as_str() {
        "traction_pi" => cfg.wire.voltage,
        _ => cfg.wire.torque,
    };
    for lc in &a.limit_cycles {
        for (item, si, figure) in [
            (
                "limit cycle amplitude",
                lc.amplitude_si,
                "sustained oscillation amplitude",
            ),
            ("dead-band offset vs f64", lc.offset_si, "final offset"),
        ] {
            let item = format!("{item}, hold {}", lc.hold);
            let c = judge(
                n,
                &item,
                si / wire,
                tol.limit_cycle_wire_lsb,
                "wire LSB",
                figure,
            );
            v.push(c.with_remedy(SIGNAL_REMEDY));
        }
    }
    v
}

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
        )
        .with_remedy(RANGE_REMEDY);
        if s.overflows > 0 {
            c.reason = format!(
                "{} overflows: {} samples outside the signal format (peak {:.3} pu, headroom \
                 {:.2} bits) in scenario {}",
                s.name,
                s.overflows,
                s.peak(),
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
        let (warn, fail) = tol.headroom_bits;
        let reason = format!("headroom {h:.2} bits (warn below {warn} bits, fail below {fail})");
        let item = format!("{} headroom", s.name);
        let c = Check::new(
            &s.controller,
            &item,
            h,
            (warn, fail),
            "bits",
            status,
            reason,
        );
        v.push(c.with_remedy(RANGE_REMEDY));
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
            )
            .with_remedy(SIGNAL_REMEDY),
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
            )
            .with_remedy(
                "a finer per-tick increment of the safe-state ramp (its quantised step \
                 accumulates over the ramp: `wheelset_control`'s `SafeRamps`), or a ramp \
                 whose step is a whole number of LSBs",
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
    let (margin, worst) = super::bounds::smallest_margin(&p.bounds);
    let status = if p.overflow_free && margin > 0.0 {
        Status::Pass
    } else {
        Status::Fail
    };
    let reason = format!(
        "smallest margin of a proven bound to the format's range {margin:.2} bits ({worst}); \
         fail at or below 0"
    );
    let item = "proven: no overflow for any input within the clamps";
    let c = Check::new("all", item, margin, (0.0, 0.0), "bits", status, reason);
    v.push(c.with_remedy(format!("for {worst}: {RANGE_REMEDY}")));
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
    )
    .with_remedy(PROOF_REMEDY);
    if !over.is_empty() {
        c.reason = format!("observed above the proven bound: {}", over.join(", "));
    }
    v.push(c);
    let eo = p
        .error_bounds
        .iter()
        .filter(|e| e.observed > e.proven)
        .count();
    v.push(
        judge(
            "all",
            "observed rounding errors above their proven bound",
            eo as f64,
            (0.0, 0.0),
            "outputs",
            "outputs above the proof",
        )
        .with_remedy(PROOF_REMEDY),
    );
    for e in p
        .error_bounds
        .iter()
        .filter(|e| !e.output.starts_with("i_ref"))
    {
        v.push(
            judge(
                "all",
                &format!("proven rounding error {}", e.output),
                e.proven_wire_lsb,
                tol.noise_wire_lsb,
                "wire LSB",
                "proven worst-case error",
            )
            .with_remedy(SIGNAL_REMEDY),
        );
    }
    v
}

/// What remains of the limit cycle with each source removed, least first (`without the
/// wire LSB of y' 0.20 N m (95 % less), ...`), and the source whose removal takes most.
#[must_use]
pub fn attribution_words(lc: &LimitCycleReport) -> (String, Option<String>) {
    let base = lc.core_all_sources.torque_p2p_nm;
    let mut rows: Vec<(&str, f64)> = lc
        .removed
        .iter()
        .map(|(n, c)| (n.as_str(), c.torque_p2p_nm))
        .collect();
    rows.sort_by(|a, b| a.1.total_cmp(&b.1));
    let words = rows
        .iter()
        .map(|(n, v)| {
            let less = if base > 0.0 {
                format!(" ({:.0} % less)", (100.0 * (1.0 - v / base)).max(0.0))
            } else {
                String::new()
            };
            format!("without the {n} {v:.2} N m{less}")
        })
        .collect::<Vec<_>>()
        .join(", ");
    let main = rows
        .first()
        .filter(|(_, v)| base > 0.0 && *v < 0.5 * base)
        .map(|(n, _)| n.to_string());
    (words, main)
}

/// The usual robustness guides for a loop's classical margins: 6 dB of gain margin and
/// 30 degrees of phase margin (30-45 degrees is the usual range).
pub const USUAL_MARGINS: (f64, f64) = (6.0, 30.0);

/// Judge the closed loop: the straight-track limit cycle (wire LSBs of torque), the
/// margins' change by quantisation, the margins against [`USUAL_MARGINS`] and each loop's
/// Nyquist stability. `p` is the margins' operating point (its axle torsion frequency
/// names the yaw loop's crossover).
pub fn closed_loop_checks(
    lc: &LimitCycleReport,
    m: &[Margin],
    cfg: &Config,
    p: &wheelset_plant::params::Params,
) -> Vec<Check> {
    let mut v = Vec::new();
    let lsb = cfg.wire.torque;
    let yaw = m.iter().find(|x| x.loop_name.starts_with("yaw"));
    let mut c = judge(
        "yaw_lead",
        "closed-loop limit cycle on straight track (device in the loop, curve 17-20 s)",
        lc.amplitude / lsb,
        // Above the dither limit of `closed` warns; the loop stays bounded, so no fail.
        ((2.0 * lc.dither_limit_nm).max(lsb) / lsb, f64::INFINITY),
        "wire LSB peak to peak",
        "torque peak to peak",
    );
    let (words, main) = attribution_words(lc);
    c.reason = format!(
        "{}; with one source removed the oscillation left is: {words}{}",
        lc.classification,
        main.as_deref()
            .map_or(String::new(), |n| format!(": the {n} sustains it"))
    );
    let margin = yaw
        .and_then(|y| Some((y.gain_db_quantised?, y.phase_crossover_hz?)))
        .map_or(String::new(), |(g, f)| {
            format!(" in a yaw loop with {g:.1} dB of gain margin at {f:.0} Hz")
        });
    let (cause, remove) = match main.as_deref() {
        Some("wire LSB of y'") => (
            format!(
                "it is what the wire LSB of y' ({:.0e} m/s) excites{margin}",
                cfg.wire.y_dot
            ),
            "carry y' with a finer LSB in the Sensor frame, or raise that margin (the yaw \
             margin checks)"
                .to_string(),
        ),
        Some("predictor") => (
            format!("the y' predictor's gain at high frequency sustains it{margin}"),
            "a shorter predictor (audit one with --yaw-predict-ticks), or raise that margin"
                .to_string(),
        ),
        Some("output wire LSB") => (
            format!("the torque's wire LSB ({lsb} N m) sustains it{margin}"),
            "a finer torque LSB in the Actuation frame, or raise that margin".to_string(),
        ),
        Some(n) => (
            format!("the {n} sustains it{margin}"),
            format!("{SIGNAL_REMEDY}; or raise that margin"),
        ),
        None => (
            format!("no single source sustains it{margin}"),
            "raise that margin (the yaw margin checks)".to_string(),
        ),
    };
    c.remedy = format!(
        "{cause}. To remove it: {remove}. To accept it: it is {:.2} % of the torque limit \
         ({} N m) and moves y by {:.1} nm peak to peak",
        100.0 * lc.amplitude / cfg.limits.torque,
        cfg.limits.torque,
        lc.device.y_p2p_m * 1e9
    );
    v.push(c);
    for x in m {
        let coef = "the quantised coefficients move it: more coefficient fraction bits \
                    (--coef-q I.F)";
        for (what, ideal, quantised, limit, unit) in [
            (
                "phase",
                x.phase_deg_ideal,
                x.phase_deg_quantised,
                (0.1, 1.0),
                "deg",
            ),
            (
                "gain",
                x.gain_db_ideal,
                x.gain_db_quantised,
                (0.01, 0.1),
                "dB",
            ),
        ] {
            if let (Some(a), Some(b)) = (ideal, quantised) {
                let item = format!("{what} margin change by quantisation");
                let figure = format!("{what} margin change");
                v.push(judge(&x.loop_name, &item, b - a, limit, unit, &figure).with_remedy(coef));
            }
        }
        v.extend(usual_margin_checks(x, cfg, p));
    }
    v
}

/// What the Nyquist count says of one loop: `P`, `W` and `Z`.
fn nyquist_words(x: &Margin) -> String {
    let p = x.open_loop_unstable_poles;
    let plural = |n: i64, w: &str| format!("{n} {w}{}", if n == 1 { "" } else { "s" });
    let count = format!(
        "{} outside the unit circle, the Nyquist plot of L turns {} round -1 \
         counter-clockwise, so the closed loop has Z = P - W = {}",
        plural(p as i64, "open-loop pole"),
        plural(x.encirclements, "time"),
        plural(x.closed_loop_unstable_poles, "unstable pole")
    );
    if p == 0 {
        format!("The loop has no {count}").replace("no 0 open-loop poles", "no open-loop pole")
    } else {
        format!(
            "The loop's plant has {count}: an open-loop-unstable loop needs a minimum gain, \
             so its margins are a gain interval (how far the gain may drop and rise) and the \
             phase lag and lead that would change the count"
        )
    }
}

/// The margins of one loop against [`USUAL_MARGINS`], with what sets them and what would
/// raise them.
fn usual_margin_checks(x: &Margin, cfg: &Config, p: &wheelset_plant::params::Params) -> Vec<Check> {
    let yaw = x.loop_name.starts_with("yaw");
    let t0 = cfg.base_period();
    // One period of actuation delay plus the zero-order hold's half period.
    let lag_deg = |f_hz: f64| 360.0 * f_hz * 1.5 * t0;
    let torsion_hz = (2.0 * p.k_t() / p.i_w).sqrt() / (2.0 * std::f64::consts::PI);
    let moved = |ideal: Option<f64>, quantised: Option<f64>| Some((quantised? - ideal?).abs());
    let change = moved(x.gain_db_ideal, x.gain_db_quantised)
        .zip(moved(x.phase_deg_ideal, x.phase_deg_quantised))
        .map_or(f64::NAN, |(g, p)| g.max(p));
    let remedy = |fc: f64| {
        let common = format!(
            "the margins are the controller's on this plant, not the fixed point's \
             (quantisation moves them by {change:.0e} dB or deg); the sampling's share at the \
             {fc:.0} Hz crossover is {:.1} deg (one period of delay and the hold)",
            lag_deg(fc)
        );
        if yaw {
            format!(
                "{common}. The yaw loop crosses unity beside the axle's torsion mode \
                 ({torsion_hz:.0} Hz), which the paper's lead does not roll off: to raise \
                 them, notch or roll off the lead there, or lower its high-frequency gain \
                 K a, and confirm with `sim-host rates` and `sim-host modes` that the \
                 kinematic mode stays damped over the conicities. {}",
                nyquist_words(x)
            )
        } else {
            format!(
                "{common}: retune the PI (`pi_kp`, `pi_ti`) for a lower crossover, or run \
                 the loop faster (--rate)"
            )
        }
    };
    let (status, word) = if x.stable {
        (Status::Pass, "stable")
    } else {
        (Status::Fail, "unstable")
    };
    let reason = format!("{} ({word})", nyquist_words(x));
    let item = "closed-loop stability (Nyquist: Z = P - W)";
    let z = x.closed_loop_unstable_poles as f64;
    let stability = Check::new(
        &x.loop_name,
        item,
        z,
        (f64::NAN, 0.5),
        "unstable poles",
        status,
        reason,
    );
    let mut out = vec![stability.with_remedy(remedy(x.gain_crossover_hz.unwrap_or(0.0)))];
    let (gm_usual, pm_usual) = USUAL_MARGINS;
    let db = |v: Option<f64>, none: &str| v.map_or(none.to_string(), |d| format!("{d:+.2} dB"));
    let deg = |v: Option<f64>| v.map_or("none".to_string(), |d| format!("{d:.2} deg"));
    let (down, up) = (
        db(x.gain_reduction_db, "no lower limit"),
        db(x.gain_increase_db, "no upper limit"),
    );
    let (lag, lead) = (deg(x.phase_lag_deg), deg(x.phase_lead_deg));
    let rows = [
        (
            "gain margin against the usual 6 dB",
            x.gain_db_quantised,
            x.phase_crossover_hz,
            gm_usual,
            "dB",
            format!("stable from {down} to {up} of loop gain"),
            "",
        ),
        (
            "phase margin against the usual 30 deg",
            x.phase_deg_quantised,
            x.gain_crossover_hz,
            pm_usual,
            "deg",
            format!("extra lag to instability {lag}, extra lead {lead}"),
            " (30-45 deg is the usual range)",
        ),
    ];
    for (item, value, at_hz, usual, unit, words, range) in rows {
        let Some(value) = value else { continue };
        let (status, side) = if value < usual {
            (Status::Warn, "below")
        } else {
            (Status::Pass, "at or above")
        };
        let at = at_hz.map_or(String::new(), |f| format!(" at {f:.1} Hz"));
        let reason =
            format!("{value:.2} {unit}{at} ({words}), {side} the usual {usual} {unit}{range}");
        let c = Check::new(
            &x.loop_name,
            item,
            value,
            (usual, f64::NAN),
            unit,
            status,
            reason,
        );
        out.push(c.with_remedy(remedy(at_hz.unwrap_or(0.0))));
    }
    out
}
