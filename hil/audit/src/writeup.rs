//! The audit's human outputs: the terminal summary and the Markdown report (with SVG
//! plots when a report directory is given).

use std::fmt::Write as _;
use std::path::Path;

use super::{Audit, AuditError, Status};
use wheelset_report::table::Table;

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or("inf (integrator)".into(), |x| format!("{x:.9e}"))
}

fn headline(a: &Audit) -> String {
    format!(
        "hil audit: base rate {} Hz, signals {}, coefficients {} ({})\n",
        a.base_rate_hz, a.formats.signal, a.formats.coef, a.sample_type
    )
}

fn verdict_line(a: &Audit) -> String {
    let counts = super::counts_words(&a.checks);
    format!(
        "verdict: {} ({counts})\n",
        a.verdict.as_str().to_uppercase()
    )
}

/// One check's line of the terminal and the full text: status, controller, item, `text`.
fn check_line(c: &super::Check, text: &str) -> String {
    format!(
        "  {:<4} {:<12} {}: {text}\n",
        c.status.as_str(),
        c.controller,
        c.item
    )
}

/// The full text: one line per controller with the headline figures, the noise per
/// scenario, the proofs, then every check with its reason and remedy, then the verdict
/// (the report's `audit.txt`).
fn full_text(a: &Audit) -> String {
    let mut s = headline(a);
    for c in &a.controllers {
        let _ = writeln!(
            s,
            "  {:<12} {:>7.0} Hz  DC gain cont {} fixed {}  worst below {:.0} Hz: fixed-f64 {:.2e} dB {:.2e} deg, f64-cont {:.2e} dB {:.2e} deg",
            c.name,
            c.rate_hz,
            fmt_opt(c.dc_gain.continuous),
            fmt_opt(c.dc_gain.fixed),
            c.worst.below_hz,
            c.worst.fixed_gain_db.0,
            c.worst.fixed_phase_deg.0,
            c.worst.discrete_gain_db.0,
            c.worst.discrete_phase_deg.0,
        );
    }
    for n in &a.observed.noise {
        let _ = writeln!(
            s,
            "  noise {:<6} {:<18} ({}, {}): max {:.2} LSB = {:.3e} {} ({:.3} wire LSB), rms {:.2} LSB",
            n.output, n.scenario, n.yaw_mode, n.phase.words(), n.max_lsb, n.max_si, n.unit, n.max_wire_lsb, n.rms_lsb
        );
    }
    let _ = writeln!(s, "  proofs: {}", a.proof_statement);
    if let Some(cl) = &a.closed_loop {
        let _ = writeln!(s, "  closed loop: {}", cl.limit_cycle.classification);
    }
    let _ = writeln!(s, "  {}", a.target.note);
    for c in &a.checks {
        s += &check_line(c, &c.reason_and_remedy());
    }
    s + &verdict_line(a)
}

/// The terminal summary: the configuration, the controllers' worst error and each loop's
/// margins (not when `quiet`), one line per check not passed, where the report went, and
/// the verdict.
pub fn summary(a: &Audit, report: Option<&Path>, quiet: bool) -> String {
    let mut s = headline(a);
    let worst = |f: &dyn Fn(&super::ControllerAudit) -> f64| {
        a.controllers
            .iter()
            .map(f)
            .fold(0.0f64, |m, v| m.max(v.abs()))
    };
    let names: Vec<&str> = a.controllers.iter().map(|c| c.name.as_str()).collect();
    if !quiet {
        let _ = writeln!(
            s,
            "  controllers {}: fixed vs f64 within {:.2e} dB, {:.2e} deg below {:.0} Hz",
            names.join(", "),
            worst(&|c| c.worst.fixed_gain_db.0),
            worst(&|c| c.worst.fixed_phase_deg.0),
            a.controllers.first().map_or(0.0, |c| c.worst.below_hz)
        );
    }
    if let Some(cl) = a.closed_loop.as_ref().filter(|_| !quiet) {
        for m in &cl.margins {
            let deg = |v: Option<f64>| v.map_or("-".to_string(), |d| format!("{d:.1} deg"));
            let counts = format!(
                "open-loop unstable poles P = {}, encirclements W = {}",
                m.open_loop_unstable_poles, m.encirclements
            );
            // A stable loop's gain interval: from the drop (negative) to the rise.
            let gain = match (m.gain_reduction_db, m.gain_increase_db) {
                (Some(d), Some(u)) => format!("from {d:+.2} dB to {u:+.2} dB of loop gain"),
                (None, Some(u)) => format!("up to {u:+.2} dB of loop gain"),
                (Some(d), None) => format!("down to {d:+.2} dB of loop gain"),
                (None, None) => "at any loop gain".to_string(),
            };
            let _ = if m.stable {
                writeln!(
                    s,
                    "  {}: stable ({counts}) {gain}; phase lag {}, lead {}",
                    m.loop_name,
                    deg(m.phase_lag_deg),
                    deg(m.phase_lead_deg)
                )
            } else {
                writeln!(
                    s,
                    "  {}: UNSTABLE ({counts}, Z = {} closed-loop poles outside the unit \
                     circle): no margins",
                    m.loop_name, m.closed_loop_unstable_poles
                )
            };
        }
    }
    for c in a.checks.iter().filter(|c| c.status != Status::Pass) {
        let value = if c.not_run {
            c.reason_and_remedy()
        } else {
            format!("{:.3} {}", c.value, c.unit)
        };
        s += &check_line(c, &value);
    }
    let _ = match report {
        Some(d) => writeln!(
            s,
            "  report: {} (every check with its reason and remedy; the full text in {})",
            d.join("audit.md").display(),
            d.join("audit.txt").display()
        ),
        None => writeln!(
            s,
            "  the reasons and remedies: --report DIR (audit.md, audit.txt)"
        ),
    };
    s + &verdict_line(a)
}

/// Write `audit.md`, `audit.txt` (the full text) and the plots into `dir`.
pub fn write_report(a: &Audit, dir: &Path) -> Result<(), AuditError> {
    std::fs::create_dir_all(dir).map_err(AuditError::io(dir))?;
    let plots = super::plots::write_plots(a, dir)?;
    let md = markdown(a, &plots);
    super::write(&dir.join("audit.txt"), &full_text(a))?;
    super::write(&dir.join("audit.md"), &md)
}

/// The Markdown report; `plots` = `(caption, file name)` of the SVGs written beside it.
pub fn markdown(a: &Audit, plots: &[(String, String)]) -> String {
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(
        w,
        "# Fixed-point audit of the control core\n\nCommand: `{}`\n\nVerdict: **{}** ({}). Base rate {} Hz; signals {} (LSB {:.3e} pu), coefficients \
         {} (LSB {:.3e}); sample type: {}.\n",
        a.command,
        a.verdict.as_str().to_uppercase(),
        super::counts_words(&a.checks),
        a.base_rate_hz,
        a.formats.signal,
        a.formats.signal.lsb(),
        a.formats.coef,
        a.formats.coef.lsb(),
        a.sample_type
    );
    let bad: Vec<String> = not_passed(a, true).collect();
    if !bad.is_empty() {
        let _ = writeln!(w, "Checks not passed:\n\n{}\n", bad.join("\n"));
    }
    let tol = &a.tolerances;
    let mut t = Table::new(["figure", "warn", "fail"]);
    let rows: [(&str, (f64, f64)); 11] = [
        (
            "fixed (measured) vs discrete f64 gain, dB",
            tol.fixed_gain_db,
        ),
        ("fixed vs discrete f64 phase, deg", tol.fixed_phase_deg),
        ("discrete f64 vs continuous gain, dB", tol.discrete_gain_db),
        (
            "discrete f64 vs continuous phase, deg",
            tol.discrete_phase_deg,
        ),
        ("coefficient relative error", tol.coef_rel),
        ("pole/zero relative shift (quantised vs f64)", tol.root_rel),
        ("DC gain relative error, fixed vs continuous", tol.dc_rel),
        ("headroom, bits (below)", tol.headroom_bits),
        ("max output error vs f64, wire LSBs", tol.noise_wire_lsb),
        (
            "limit-cycle amplitude / dead band, wire LSBs",
            tol.limit_cycle_wire_lsb,
        ),
        (
            "max output error during the safe-state ramps, fraction of the limit",
            tol.ramp_of_limit,
        ),
    ];
    for (n, (a_, b)) in rows {
        t.row([n.to_string(), format!("{a_:.1e}"), format!("{b:.1e}")]);
    }
    let _ = writeln!(
        w,
        "## Tolerances (warn / fail)\n\n{t}\nFrequency-response errors are judged for f <= {} x \
         the controller's rate.\n",
        tol.frac_fs
    );
    for c in &a.controllers {
        let coefficients = table(
            &c.coefficients,
            &[
                ("name", &|r| r.name.clone()),
                ("unit", &|r| r.unit.clone()),
                ("ideal (f64)", &|r| format!("{:.12e}", r.ideal)),
                ("quantised", &|r| format!("{:.12e}", r.quantised)),
                ("abs error", &|r| format!("{:.3e}", r.abs_err)),
                ("rel error", &|r| format!("{:.3e}", r.rel_err)),
            ],
        );
        let pz = &c.poles_zeros;
        let forms = [
            ("continuous", &pz.continuous),
            ("discrete f64", &pz.discrete_f64),
            ("discrete quantised", &pz.discrete_quantised),
        ];
        let roots = table(
            forms,
            &[
                ("form", &|(n, _)| n.to_string()),
                ("poles (z)", &|(_, r)| list(&r.poles_z)),
                ("zeros (z)", &|(_, r)| list(&r.zeros_z)),
                ("poles (rad/s)", &|(_, r)| list(&r.poles_s)),
                ("zeros (rad/s)", &|(_, r)| list(&r.zeros_s)),
            ],
        );
        let d = &c.dc_gain;
        let _ = writeln!(
            w,
            "## Controller `{}` ({:.0} Hz)\n\nLaw: {}. Gain unit: {}.\n\n### Coefficients\n\n\
             {coefficients}\n### Poles, zeros, DC gain\n\n{roots}\nShifts: quantisation \
             (z-plane) {}; quantisation (relative, rad/s) {}; discretisation (rad/s, \
             Tustin-mapped minus continuous) {}.\n\nDC gain ({}): continuous {}, discrete f64 \
             {}, discrete quantised {}, fixed (measured) {}; fixed vs continuous {}.\n",
            c.name,
            c.rate_hz,
            c.law,
            c.unit,
            list(&pz.shift_quantisation_z),
            list(&pz.shift_quantisation_rel),
            list(&pz.shift_discretisation_s),
            c.unit,
            fmt_opt(d.continuous),
            fmt_opt(d.discrete_f64),
            fmt_opt(d.discrete_quantised),
            fmt_opt(d.fixed),
            d.fixed_vs_continuous_rel
                .map_or("n/a".into(), |r| format!("{r:.3e} relative"))
        );
        let gp = |r: &super::model::GainPhase| format!("{:.6e} / {:.3} deg", r.gain, r.phase_deg);
        let response = table(
            c.freq_response.iter().filter(|p| p.named),
            &[
                ("f (Hz)", &|p| p.f_hz.to_string()),
                ("continuous", &|p| gp(&p.continuous)),
                ("discrete f64", &|p| gp(&p.discrete_f64)),
                ("fixed (measured)", &|p| gp(&p.fixed)),
                ("fixed-f64 dB", &|p| format!("{:.2e}", p.fixed_vs_f64_db)),
                ("fixed-f64 deg", &|p| format!("{:.2e}", p.fixed_vs_f64_deg)),
                ("f64-cont dB", &|p| {
                    format!("{:.2e}", p.f64_vs_continuous_db)
                }),
                ("f64-cont deg", &|p| {
                    format!("{:.2e}", p.f64_vs_continuous_deg)
                }),
            ],
        );
        let cycles = table(
            &c.limit_cycles,
            &[
                ("hold input", &|l| l.hold.clone()),
                ("value (SI)", &|l| format!("{:.3e}", l.hold_input_si)),
                ("moves (definition: wheelset_audit::closed)", &|l| {
                    l.classification.clone()
                }),
                ("p2p (LSB)", &|l| format!("{:.2}", l.p2p_lsb)),
                ("amplitude", &|l| {
                    format!("{:.3e} {}", l.amplitude_si, l.unit)
                }),
                ("period (samples)", &|l| {
                    l.period_samples.map_or("-".into(), |p| format!("{p:.1}"))
                }),
                ("offset vs f64", &|l| {
                    format!("{:.3e} {}", l.offset_si, l.unit)
                }),
                ("offset (LSB)", &|l| format!("{:.2}", l.offset_lsb)),
            ],
        );
        let wo = &c.worst;
        let _ = writeln!(
            w,
            "### Frequency response\n\nFixed point measured on the running controller: input {} ({}), fitted sine + \
             cosine + constant over whole periods. The named frequencies:\n\n{response}\nWorst \
             on the dense grid ({} points) below {:.0} Hz: fixed vs f64 {:.3e} dB (at \
             {:.3} Hz), {:.3e} deg (at {:.3} Hz); discrete f64 vs continuous {:.3e} dB (at \
             {:.3} Hz), {:.3e} deg (at {:.3} Hz). The measurement's own error (f64 measured \
             vs analytic) is at most {:.1e} dB.\n\n### Limit cycles and dead bands\n\nAfter \
             0.2 s of random input, the input is held for 2 s; last second observed.\n\n\
             {cycles}",
            c.measure_amplitude,
            if c.name == "traction_pi" {
                "A of current error"
            } else {
                "m/s of y'"
            },
            c.freq_response.len(),
            wo.below_hz,
            wo.fixed_gain_db.0,
            wo.fixed_gain_db.1,
            wo.fixed_phase_deg.0,
            wo.fixed_phase_deg.1,
            wo.discrete_gain_db.0,
            wo.discrete_gain_db.1,
            wo.discrete_phase_deg.0,
            wo.discrete_phase_deg.1,
            wo.measurement_gain_db
        );
    }
    let o = &a.observed;
    let mut t = Table::new(["name", "ticks", "source"]);
    for (n, src, k) in &a.scenarios {
        t.row([n.to_string(), k.to_string(), src.to_string()]);
    }
    let _ = write!(w, "## Scenarios\n\n{t}");
    for n in &a.scenario_notes {
        let _ = writeln!(w, "\nNote: {n}.");
    }
    let t = table(
        o.signals.iter().filter(|r| r.samples > 0).enumerate(),
        &[
            ("#", &|(i, _)| i.to_string()),
            ("signal", &|(_, r)| r.name.clone()),
            ("controller", &|(_, r)| r.controller.clone()),
            ("state", &|(_, r)| if r.state { "yes" } else { "" }.into()),
            ("min (SI)", &|(_, r)| format!("{:.4e}", r.min_si)),
            ("max (SI)", &|(_, r)| format!("{:.4e}", r.max_si)),
            ("unit", &|(_, r)| r.unit.clone()),
            ("peak (pu)", &|(_, r)| format!("{:.4}", r.peak())),
            ("headroom (bits)", &|(_, r)| {
                format!("{:.2}", r.headroom_bits)
            }),
            ("overflows", &|(_, r)| r.overflows.to_string()),
            ("worst scenario", &|(_, r)| r.worst_scenario.clone()),
        ],
    );
    let c = &o.clamps;
    let _ = writeln!(
        w,
        "\nEach scenario runs twice (yaw lead, yaw gain; traction on), fixed point and f64 \
         in lock-step on the same quantised inputs.\n\n## Ranges and headroom\n\n{t}\n\
         Designed clamps counted by the controller (not overflows): y' {}, current {}, \
         speed {}, demand {}, torque limit {}, voltage limit {}, integrator (anti-windup) {}. \
         Saturating operations inside the arithmetic (instrumented run): {}.\n",
        c.y_dot,
        c.current,
        c.speed,
        c.demand,
        c.yaw_torque,
        c.voltage,
        c.integrator,
        o.arithmetic_saturations
            .map_or("not counted".into(), |n| n.to_string())
    );
    let t = table(
        &o.noise,
        &[
            ("output", &|n| n.output.clone()),
            ("scenario", &|n| n.scenario.clone()),
            ("yaw mode", &|n| n.yaw_mode.clone()),
            ("ticks", &|n| match n.phase {
                super::ranges::Phase::Normal => "normal".into(),
                super::ranges::Phase::SafeRamp => "safe-state ramps".into(),
            }),
            ("max (LSB)", &|n| format!("{:.2}", n.max_lsb)),
            ("rms (LSB)", &|n| format!("{:.2}", n.rms_lsb)),
            ("max (SI)", &|n| format!("{:.3e} {}", n.max_si, n.unit)),
            ("rms (SI)", &|n| format!("{:.3e} {}", n.rms_si, n.unit)),
            ("max (wire LSB)", &|n| format!("{:.3}", n.max_wire_lsb)),
            ("bits lost", &|n| format!("{:.2}", n.bits_lost)),
        ],
    );
    let _ = write!(
        w,
        "## Quantisation noise (fixed minus f64, same inputs)\n\n{t}"
    );
    super::writeup_sections::proofs_and_findings(a, w);
    let _ = writeln!(
        w,
        "\n## Recommended formats\n\nFrom the proven bounds: integer bits hold the proven maximum (no overflow for any \
         input within the clamps); fraction bits keep the proven rounding error of the \
         chain's output (T_psi, u_a) within half a wire LSB.\n"
    );
    if let Some(sw) = &a.sweep {
        let _ = writeln!(
            w,
            "A weaker, empirical statement: bisection over the signal fraction bits at {} integer bits (synthetic \
             scenarios, named frequencies): smallest format with no failing check: {} (no overflow or error bound is implied). Tried: {}.\n\nCoefficients: \
             {} fraction bits are needed for every coefficient's relative error to stay \
             within {:.0e} (the audited format has {}).\n",
            a.formats.signal.int_bits,
            sw.min_signal_frac_bits.map_or("none up to 32 bits".into(), |f| format!(
                "Q{}.{f}",
                a.formats.signal.int_bits
            )),
            sw.tried
                .iter()
                .map(|(f, ok, why)| match ok {
                    true => format!("F={f} pass"),
                    false => format!("F={f} fail ({why})"),
                })
                .collect::<Vec<_>>()
                .join("; "),
            sw.min_coef_frac_bits,
            a.tolerances.coef_rel.0,
            a.formats.coef.frac_bits
        );
    }
    let t = table(
        &a.recommendations,
        &[
            ("signal", &|r| r.signal.clone()),
            ("controller", &|r| r.controller.clone()),
            ("observed peak (pu)", &|r| {
                let peak = format!("{:.4}", r.peak_pu);
                if r.observed {
                    peak
                } else {
                    "-".into()
                }
            }),
            ("proven max (pu)", &|r| format!("{:.4}", r.proven_max_pu)),
            ("recommended", &|r| r.format.clone()),
            ("word", &|r| r.word.to_string()),
            ("guarantee", &|r| r.guarantee.clone()),
        ],
    );
    let _ = writeln!(w, "{t}\n## Target (QEMU)\n\n{}.\n", a.target.note);
    if !a.target.runs.is_empty() {
        let pair = |(x, y): (f64, f64)| format!("{x:.1}, {y:.1}");
        let t = table(
            &a.target.runs,
            &[
                ("scenario", &|r| r.scenario.clone()),
                ("from tick", &|r| r.from_tick.to_string()),
                ("ticks", &|r| r.ticks.to_string()),
                ("frames differing", &|r| r.mismatches.to_string()),
                ("max code diff (T_psi dNm, u_a cV)", &|r| {
                    format!("{}, {}", r.max_code_diff.0, r.max_code_diff.1)
                }),
                ("target vs f64 (wire LSB)", &|r| {
                    pair(r.target_vs_f64_wire_lsb)
                }),
                ("host vs f64 (wire LSB)", &|r| pair(r.host_vs_f64_wire_lsb)),
                ("mean instructions/tick", &|r| format!("{:.0}", r.mean_exec)),
            ],
        );
        let _ = writeln!(
            w,
            "{t}\nThe target's outputs are visible only as wire codes (0.1 N m, 10 mV), so its \
             error against f64 is stated in wire LSBs; the host's internal-resolution figures \
             are in the noise table above.\n"
        );
    }
    if !plots.is_empty() {
        let _ = writeln!(w, "## Plots\n");
        for (cap, f) in plots {
            let _ = writeln!(w, "![{cap}]({f})\n");
        }
    }
    let t = table(
        &a.checks,
        &[
            ("status", &|c| c.status.as_str().into()),
            ("controller", &|c| c.controller.clone()),
            ("item", &|c| c.item.clone()),
            ("reason", &|c| c.reason.clone()),
        ],
    );
    let _ = write!(w, "## Checks\n\n{t}");
    s
}

/// A Markdown list item per check not passed: status (in bold when `bold`), controller,
/// item, reason and remedy.
pub(crate) fn not_passed(a: &Audit, bold: bool) -> impl Iterator<Item = String> + '_ {
    let bad = a.checks.iter().filter(|c| c.status != Status::Pass);
    bad.map(move |c| {
        let st = if c.not_run {
            "not run"
        } else {
            c.status.as_str()
        };
        let st = if bold { format!("**{st}**") } else { st.into() };
        format!(
            "- {st} `{}` {}: {}",
            c.controller,
            c.item,
            c.reason_and_remedy()
        )
    })
}

/// The Markdown table of `rows`, one column per `(header, cell)`.
pub(crate) fn table<R>(rows: impl IntoIterator<Item = R>, cols: &[Col<'_, R>]) -> Table {
    let mut t = Table::new(cols.iter().map(|c| c.0));
    for r in rows {
        t.row(cols.iter().map(|c| c.1(&r)));
    }
    t
}

/// A column of a [`table`]: its header and a row's cell.
pub(crate) type Col<'a, R> = (&'a str, &'a dyn Fn(&R) -> String);

fn list(v: &[f64]) -> String {
    if v.is_empty() {
        "-".into()
    } else {
        v.iter()
            .map(|x| format!("{x:.9e}"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}
