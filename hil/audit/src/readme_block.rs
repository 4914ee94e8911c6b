//! The book's generated audit block: the audit's headline figures as Markdown, printed by
//! `hil audit --no-target --readme-block` and checked in `docs/audit.md` by
//! `cargo xtask readme --check`.

use std::fmt::Write as _;

use super::model::{CoefRow, ControllerAudit};
use super::ranges::Phase;
use super::writeup_sections::{bounds_table, error_bounds_table, Detail};
use super::Audit;
use wheelset_report::table::Table;

const COMMAND: &str = "cargo run --release -q -p hil -- audit --no-target --readme-block";

/// The block's body for `a`, what goes between the `<!-- generated:audit -->` markers (every line ends
/// in `\n`).
pub fn block(a: &Audit) -> String {
    let mut s = String::new();
    let w = &mut s;
    let _ = writeln!(
        w,
        "Figures of `{COMMAND}` at {} Hz, signals {}, coefficients {} (generated; a test \
         compares this block with the tool's output).\n",
        a.base_rate_hz, a.formats.signal, a.formats.coef
    );
    let names = ["yaw_lead", "yaw_gain", "traction_pi"];
    let mut t = Table::new(["figure", "yaw lead", "yaw gain", "PI"]);
    // One row: `label`, then each controller's cell (`None`: not audited).
    let mut row = |label: String, cell: &dyn Fn(&str, Option<&ControllerAudit>) -> String| {
        let ctrl = |n: &str| a.controllers.iter().find(|c| c.name == n);
        t.row(std::iter::once(label).chain(names.iter().map(|n| cell(n, ctrl(n)))));
    };
    row("largest coefficient relative error".into(), &|_, c| {
        c.and_then(|c| {
            let rel = |r: &&CoefRow| r.rel_err.abs();
            c.coefficients
                .iter()
                .max_by(|x, y| rel(x).total_cmp(&rel(y)))
        })
        .map_or("-".into(), |r| {
            format!("{:.1e} (`{}`)", r.rel_err.abs(), r.name)
        })
    });
    row(
        "largest pole/zero relative shift (quantised vs f64)".into(),
        &|_, c| {
            c.map(|c| &c.poles_zeros.shift_quantisation_rel)
                .filter(|v| !v.is_empty())
                .map_or("-".into(), |v| {
                    format!("{:.1e}", v.iter().fold(0.0f64, |m, x| m.max(x.abs())))
                })
        },
    );
    row(
        "DC gain continuous / fixed (measured), relative error".into(),
        &|_, c| {
            c.and_then(|c| {
                let d = &c.dc_gain;
                Some(format!(
                    "{:.6e} / {:.6e} ({:.1e})",
                    d.continuous?, d.fixed?, d.fixed_vs_continuous_rel?
                ))
            })
            .unwrap_or("integrator".into())
        },
    );
    let db_deg = |(g, p): (f64, f64)| format!("{:.1e} dB / {:.1e} deg", g.abs(), p.abs());
    row(
        format!(
            "worst gain / phase error fixed vs f64, f <= {:.0} Hz",
            a.tolerances.frac_fs * a.base_rate_hz as f64
        ),
        &|_, c| {
            c.map(|c| db_deg((c.worst.fixed_gain_db.0, c.worst.fixed_phase_deg.0)))
                .unwrap_or_default()
        },
    );
    row("worst error discrete f64 vs continuous".into(), &|_, c| {
        c.map(|c| db_deg((c.worst.discrete_gain_db.0, c.worst.discrete_phase_deg.0)))
            .unwrap_or_default()
    });
    row(
        "largest dead-band offset after a hold (wire LSB)".into(),
        &|n, c| {
            let l = wheelset_control::WireLsb::default();
            let wire = if n == "traction_pi" {
                l.voltage
            } else {
                l.torque
            };
            c.map(|c| {
                let m = c.limit_cycles.iter();
                format!(
                    "{:.4}",
                    m.fold(0.0f64, |m, l| m.max(l.offset_si.abs() / wire))
                )
            })
            .unwrap_or_default()
        },
    );
    let _ = writeln!(
        w,
        "{t}\n{}\n\n{}\n{}",
        a.proof_statement,
        bounds_table(a, Detail::Readme),
        error_bounds_table(a, Detail::Readme)
    );
    // Noise against f64 (coefficients unquantised), normal running.
    for out in ["T_psi", "u_a"] {
        if let Some(n) = a
            .observed
            .noise
            .iter()
            .filter(|n| n.output == out && n.phase == Phase::Normal)
            .max_by(|x, y| x.max_lsb.total_cmp(&y.max_lsb))
        {
            let _ = writeln!(
                w,
                "- Largest `{out}` error vs the f64 core on the same inputs: {:.2} LSB = \
                 {:.3e} {} ({:.4} wire LSB), scenario `{}` ({}).",
                n.max_lsb, n.max_si, n.unit, n.max_wire_lsb, n.scenario, n.yaw_mode
            );
        }
    }
    if let Some(d) = &a.diagnosis {
        if let Some(p) = &d.pi {
            let _ = writeln!(
                w,
                "- The `u_a` error in `{}` by experiment: {}; Ki has {:.1} significant bits \
                 (Q1.31 holding Ki 2^{}; relative error {:.2e}).",
                p.scenario,
                p.shares_text(),
                p.ki_significant_bits,
                p.ki_shift,
                p.ki_rel_err
            );
        }
        let _ = writeln!(
            w,
            "- The lead over the stimulus amplitude: {}.",
            d.lead_amplitude.statement
        );
    }
    if let Some(cl) = &a.closed_loop {
        let lc = &cl.limit_cycle;
        let (words, main) = super::checks::attribution_words(lc);
        let _ = writeln!(
            w,
            "- Closed loop (device in the loop, `curve` {:.0}-{:.0} s): {}. Torque RMS {:.3} \
             N m, `y` {:.1} nm peak to peak. The oscillation left with one source removed \
             (peak to peak): {}{}.",
            lc.window_s.0,
            lc.window_s.1,
            lc.classification,
            lc.device.torque_rms_nm,
            lc.device.y_p2p_m * 1e9,
            words,
            main.map_or(String::new(), |n| format!("; the {n} sustains it"))
        );
        let (gm, pm) = super::checks::USUAL_MARGINS;
        for m in &cl.margins {
            let o = |v: Option<f64>| v.map_or("-".into(), |x| format!("{x:.3}"));
            let low = m.gain_db_quantised.is_some_and(|g| g < gm)
                || m.phase_deg_quantised.is_some_and(|p| p < pm);
            let _ = writeln!(
                w,
                "- Margins, {}: gain {} dB ideal / {} dB quantised, phase {} deg / {} deg; \
                 {} the usual {gm} dB / {pm} deg{}.",
                m.loop_name,
                o(m.gain_db_ideal),
                o(m.gain_db_quantised),
                o(m.phase_deg_ideal),
                o(m.phase_deg_quantised),
                if low { "below" } else { "at or above" },
                if low {
                    " (the margin checks below say why)"
                } else {
                    ""
                }
            );
        }
    }
    for n in &a.scenario_notes {
        let _ = writeln!(w, "- Note: {n}.");
    }
    let _ = writeln!(
        w,
        "\nVerdict: **{}** ({}; `--no-target`).",
        a.verdict.as_str().to_uppercase(),
        super::counts_words(&a.checks)
    );
    for l in super::writeup::not_passed(a, false) {
        let _ = writeln!(w, "{l}");
    }
    s
}
