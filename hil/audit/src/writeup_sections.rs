//! The Markdown report's sections on the proofs, the closed loop and the findings
//! attributed by experiment ([`super::writeup::markdown`] calls them in place).

use std::fmt::Write as _;

use super::bounds::{Bound, ErrorBound};
use super::writeup::{table, Col};
use super::Audit;
use wheelset_report::table::Table;

/// Write the findings, proven bounds, rounding-error bounds, WCPGs and the closed-loop
/// section of `a` to `w`.
pub(crate) fn proofs_and_findings(a: &Audit, w: &mut String) {
    if let Some(d) = &a.diagnosis {
        let _ = writeln!(w, "\n## Findings attributed by experiment\n");
        if let Some(p) = &d.pi {
            let _ = writeln!(
                w,
                "PI steady error (`u_a` vs f64, scenario `{}`): {:.1} LSB; with the f64 \
                 reference holding the quantised `Ki` {:.1} LSB; also the quantised ramp \
                 steps {:.1} LSB. Shares: {}. `Ki` has {:.1} significant bits in Q1.31 \
                 (held as Ki 2^{}; relative error {:.2e}). Remedy: {}\n",
                p.scenario,
                p.baseline_lsb,
                p.with_quantised_ki_lsb,
                p.with_quantised_ki_and_ramps_lsb,
                p.shares_text(),
                p.ki_significant_bits,
                p.ki_shift,
                p.ki_rel_err,
                p.remedy
            );
        }
        let la = &d.lead_amplitude;
        let t = table(
            &la.points,
            &[
                ("y' amplitude (m/s)", &|p| {
                    format!("{:.0e}", p.amplitude_mps)
                }),
                ("worst gain error (dB)", &|p| format!("{:.2e}", p.gain_db)),
                ("worst phase error (deg)", &|p| {
                    format!("{:.2e}", p.phase_deg)
                }),
            ],
        );
        let _ = write!(
            w,
            "Lead response over the stimulus amplitude (fixed measured vs discrete f64, \
             worst over {:?} Hz): {}.\n\n{t}",
            la.freqs_hz, la.statement
        );
    }
    let mut t = Table::new(["part", "path", "WCPG", "terms", "tail bound", "note"]);
    for l in &a.linear_parts {
        let (v, k, tb) = match &l.wcpg {
            Some(g) => (
                format!("{:.9}", g.value),
                g.terms.to_string(),
                format!("{:.1e}", g.tail_bound),
            ),
            None => ("infinite".into(), "-".into(), "-".into()),
        };
        t.row([l.part.clone(), l.path.clone(), v, k, tb, l.note.clone()]);
    }
    let _ = write!(
        w,
        "\n## Proven bounds\n\n{}\n\nRanges: the worst-case peak gain (WCPG) of each linear part from the \
         quantised coefficients, times the input clamps, plus the rounding-error bound; \
         interval arithmetic through the clamps, ramps, predictor and anti-windup \
         (`wheelset_audit::bounds` states each step). Observed = the largest magnitude over \
         the scenarios.\n\n{}\nRounding error of the fixed-point core against exact \
         arithmetic on the same quantised coefficients and inputs (each rounding point's \
         error filter's peak gain x its rounding step):\n\n{}\nWCPG per linear part (tail \
         bound and terms summed):\n\n{t}",
        a.proof_statement,
        bounds_table(a, Detail::Report),
        error_bounds_table(a, Detail::Report)
    );
    if let Some(cl) = &a.closed_loop {
        let lc = &cl.limit_cycle;
        let runs = [
            ("device (Runtime<Fx>, in-process link)", &lc.device),
            ("continuous f64 reference", &lc.reference),
            ("core in the loop, every source", &lc.core_all_sources),
        ];
        let removed = lc.removed.iter().map(|(n, c)| (format!("without {n}"), c));
        let runs = table(
            runs.map(|(n, c)| (n.to_string(), c))
                .into_iter()
                .chain(removed),
            &[
                ("run", &|(n, _)| n.clone()),
                ("torque p2p (N m)", &|(_, c)| {
                    format!("{:.4}", c.torque_p2p_nm)
                }),
                ("torque RMS (N m)", &|(_, c)| {
                    format!("{:.4}", c.torque_rms_nm)
                }),
                ("frequency (Hz)", &|(_, c)| format!("{:.2}", c.freq_hz)),
                ("y p2p (nm)", &|(_, c)| format!("{:.2}", c.y_p2p_m * 1e9)),
            ],
        );
        let o = |v: Option<f64>| v.map_or("-".into(), |x| format!("{x:.6}"));
        let margins = table(
            &cl.margins,
            &[
                ("loop", &|m| m.loop_name.clone()),
                ("gain margin ideal (dB)", &|m| o(m.gain_db_ideal)),
                ("gain margin quantised (dB)", &|m| o(m.gain_db_quantised)),
                ("phase margin ideal (deg)", &|m| o(m.phase_deg_ideal)),
                (
                    "phase margin quantised (deg)",
                    &|m| o(m.phase_deg_quantised),
                ),
                ("phase / gain crossover (Hz)", &|m| {
                    format!("{} / {}", o(m.phase_crossover_hz), o(m.gain_crossover_hz))
                }),
                ("P, W: closed loop", &|m| {
                    let word = if m.stable { "stable" } else { "unstable" };
                    format!(
                        "{}, {}: {word}",
                        m.open_loop_unstable_poles, m.encirclements
                    )
                }),
                ("gain interval (dB)", &|m| {
                    format!("{} to {}", o(m.gain_reduction_db), o(m.gain_increase_db))
                }),
                ("phase lag / lead (deg)", &|m| {
                    format!("{} / {}", o(m.phase_lag_deg), o(m.phase_lead_deg))
                }),
            ],
        );
        let _ = write!(
            w,
            "\n## Closed loop (device in the loop)\n\n{}: {}.\n\nStraight track `curve` {:.0}-{:.0} s: torque {:.3} N m peak to peak \
             (RMS {:.3} N m) at {:.2} Hz, `y` {:.1} nm peak to peak. Attribution: the core \
             in the loop with every source reproduces the device ({:.3} N m p2p), then one \
             source removed at a time:\n\n{runs}\nStability and margins (plant linearised on \
             straight track, one period of delay, each loop broken with the other closed; see \
             `wheelset_plant::sampled::margins_of`). P counts the open-loop poles outside the \
             unit circle, W the counter-clockwise turns of the Nyquist plot round -1; the \
             closed loop is stable when Z = P - W = 0. A loop with P > 0 needs a minimum \
             gain: its gain margin is the smaller of the reduction and the increase that \
             destabilise it, its phase margin the smaller of the extra lag and lead:\n\n\
             {margins}",
            cl.note,
            lc.classification,
            lc.window_s.0,
            lc.window_s.1,
            lc.device.torque_p2p_nm,
            lc.device.torque_rms_nm,
            lc.device.freq_hz,
            lc.device.y_p2p_m * 1e9,
            lc.core_all_sources.torque_p2p_nm
        );
    }
}

/// How much a proof table says: the README's short form or the report's full one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Detail {
    /// The README's block: the figures with four (bounds) or three (errors) digits.
    Readme,
    /// The report: two more digits plus each bound's format and proof, each error
    /// bound's rounding points.
    Report,
}

impl Detail {
    /// `cols` without those named in `report_only` unless this is the report's detail.
    fn columns<'a, R>(
        self,
        cols: impl IntoIterator<Item = Col<'a, R>>,
        report_only: &[&str],
    ) -> Vec<Col<'a, R>> {
        let keep = |c: &Col<R>| self == Detail::Report || !report_only.contains(&c.0);
        cols.into_iter().filter(keep).collect()
    }
}

/// The proven bounds per signal against the observed ones (one table for the README's
/// block and the report).
pub(crate) fn bounds_table(a: &Audit, d: Detail) -> Table {
    let full = d == Detail::Report;
    let p = if full { 6 } else { 4 };
    let cols: [Col<&Bound>; 7] = [
        ("signal", &|b| match full {
            true => b.signal.clone(),
            false => format!("`{}`", b.signal),
        }),
        ("unit", &|b| b.unit.clone()),
        ("observed max", &|b| {
            b.observed_max.map_or("-".into(), |v| format!("{v:.p$e}"))
        }),
        ("proven max", &|b| format!("{:.p$e}", b.proven_max)),
        ("format", &|b| b.format.clone()),
        ("margin (bits)", &|b| format!("{:.2}", b.margin_bits)),
        ("proof", &|b| b.proof.clone()),
    ];
    table(&a.bounds, &d.columns(cols, &["format", "proof"]))
}

/// The rounding-error bounds per output against the observed errors (one table for the
/// README's block and the report).
pub(crate) fn error_bounds_table(a: &Audit, d: Detail) -> Table {
    let full = d == Detail::Report;
    let p = if full { 4 } else { 3 };
    let first = match full {
        true => "output",
        false => "rounding error vs exact arithmetic",
    };
    let cols: [Col<&ErrorBound>; 6] = [
        (first, &|e| e.output.clone()),
        ("observed", &|e| format!("{:.p$e}", e.observed)),
        ("proven", &|e| format!("{:.p$e}", e.proven)),
        ("unit", &|e| e.unit.clone()),
        ("proven (wire LSB)", &|e| {
            format!("{:.p$}", e.proven_wire_lsb)
        }),
        ("per rounding point", &|e| {
            let points = e
                .rounding_points
                .iter()
                .map(|(n, v)| format!("{n} {v:.2e}"));
            points.collect::<Vec<_>>().join("; ")
        }),
    ];
    table(&a.error_bounds, &d.columns(cols, &["per rounding point"]))
}
