//! SVG plots for the report (drawn with `wheelset_report::svg`): per controller a Bode figure
//! (gain and phase of the three forms, then the discretisation's and the fixed point's
//! gain and phase errors, each against its tolerance), the headroom of every signal, and
//! the fixed-minus-f64 output error over time per scenario against the noise tolerance.
//! Frequency axes are logarithmic, in Hz.

use std::path::Path;

use wheelset_report::svg::{Figure, Plot, Series};

use super::{Audit, AuditError};

/// Colours of the marks: the warn level, the fail level, the judged band's edge.
const WARN_COLOUR: &str = "#E69F00";
const FAIL_COLOUR: &str = "#D55E00";
const EDGE_COLOUR: &str = "#555555";

/// A phase trace (degrees, in frequency order) without its jumps of 360 degrees.
fn unwrap(v: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    let mut out = Vec::with_capacity(v.len());
    let mut shift = 0.0;
    let mut prev: Option<f64> = None;
    for (f, ph) in v {
        if let Some(p) = prev {
            let d = ph + shift - p;
            shift -= 360.0 * (d / 360.0).round();
        }
        let u = ph + shift;
        prev = Some(u);
        out.push((f, u));
    }
    out
}

fn save(fig: &Figure, dir: &Path, file: &str) -> Result<String, AuditError> {
    let p = dir.join(file);
    fig.save(&p).map_err(AuditError::io(&p))?;
    Ok(file.to_string())
}

/// Write the plots into `dir`; returns `(caption, file name)` of each.
pub fn write_plots(a: &Audit, dir: &Path) -> Result<Vec<(String, String)>, AuditError> {
    let mut out = Vec::new();
    let tol = &a.tolerances;
    for c in &a.controllers {
        let pts = |g: &dyn Fn(&super::FreqPoint) -> f64| -> Vec<(f64, f64)> {
            c.freq_response.iter().map(|p| (p.f_hz, g(p))).collect()
        };
        let db = |x: f64| 20.0 * x.log10();
        let limit = c.worst.below_hz;
        let judged = format!("judged below {limit:.0} Hz");
        let f_lo = c.freq_response.first().map_or(limit, |p| p.f_hz);
        let plain = |title: &str, unit: &str| {
            Plot::new(title)
                .x_label("f (Hz)")
                .y_label(unit)
                .log_x()
                .size(860.0, 280.0)
        };
        let bode = |title: &str, unit: &str| plain(title, unit).vmark(limit, &judged, EDGE_COLOUR);
        // The forms nearly coincide: continuous wide and pale, f64 translucent, fixed thin.
        let forms = |p: Plot, unwrap_phase: bool, g: &dyn Fn(&super::GainPhase) -> f64| {
            let u = |v: Vec<(f64, f64)>| if unwrap_phase { unwrap(v) } else { v };
            p.series(
                Series::line("continuous (wide)", u(pts(&|x| g(&x.continuous))))
                    .color("#9ECAE1")
                    .width(6.0),
            )
            .series(
                Series::line("discrete f64", u(pts(&|x| g(&x.discrete_f64))))
                    .color("#D55E00")
                    .width(3.5)
                    .opacity(0.5),
            )
            .series(
                Series::line("fixed (measured, thin)", u(pts(&|x| g(&x.fixed))))
                    .color("#000000")
                    .width(1.2),
            )
        };
        // Warn at +-w, fail at +-f over the band the check judges (none where not judged).
        let error = |title: &str, unit: &str, tol: Option<(f64, f64)>, s: Series| match tol {
            Some((w, f)) => [(w, "warn", WARN_COLOUR), (f, "fail", FAIL_COLOUR)]
                .into_iter()
                .fold(bode(title, unit).series(s), |p, (v, word, colour)| {
                    p.hmark(v, &format!("{word} above ±{v} {unit}"), colour)
                        .over(f_lo, limit)
                        .hmark(-v, "", colour)
                        .over(f_lo, limit)
                }),
            None => plain(title, unit).series(s),
        };
        // The predictor's discretisation error is not judged (`checks`): no limits.
        let judged = c.name != "yaw_predictor";
        let disc = |t: (f64, f64)| judged.then_some(t);
        let disc_title = |what: &str| {
            if judged {
                format!("discretisation: discrete f64 - continuous, {what}")
            } else {
                format!(
                    "discretisation: discrete f64 - ideal advance, {what} (not judged: an \
                     approximation by design)"
                )
            }
        };
        let fig = Figure::new(&format!(
            "{} at {:.0} Hz: Bode ({}) and errors",
            c.name, c.rate_hz, c.unit
        ))
        .panel(forms(bode("gain |H|", "dB"), false, &|g| db(g.gain)))
        .panel(forms(bode("phase arg H (unwrapped)", "deg"), true, &|g| {
            g.phase_deg
        }))
        .panel(error(
            &disc_title("gain"),
            "dB",
            disc(tol.discrete_gain_db),
            Series::line("gain error", pts(&|p| p.f64_vs_continuous_db)),
        ))
        .panel(error(
            &disc_title("phase"),
            "deg",
            disc(tol.discrete_phase_deg),
            Series::line("phase error", unwrap(pts(&|p| p.f64_vs_continuous_deg))),
        ))
        .panel(error(
            "fixed point: fixed (measured) - discrete f64, gain",
            "dB",
            Some(tol.fixed_gain_db),
            Series::line("gain error", pts(&|p| p.fixed_vs_f64_db)),
        ))
        .panel(error(
            "fixed point: fixed (measured) - discrete f64, phase",
            "deg",
            Some(tol.fixed_phase_deg),
            Series::line("phase error", pts(&|p| p.fixed_vs_f64_deg)),
        ));
        let f = save(&fig, dir, &format!("bode_{}.svg", c.name))?;
        out.push((
            format!("{}: Bode gain and phase, and their errors", c.name),
            f,
        ));
    }
    let sigs: Vec<_> = a
        .observed
        .signals
        .iter()
        .filter(|s| s.samples > 0)
        .collect();
    let edges: Vec<f64> = (0..=sigs.len()).map(|i| i as f64).collect();
    let head: Vec<f64> = sigs
        .iter()
        .map(|s| {
            Some(s.headroom_bits)
                .filter(|h| h.is_finite())
                .unwrap_or(0.0)
        })
        .collect();
    let peaks: Vec<(f64, f64)> = sigs
        .iter()
        .enumerate()
        .map(|(i, s)| (i as f64 + 0.5, s.peak().max(1e-12).log2()))
        .collect();
    let range = a.formats.signal.range().log2();
    // The range table's names; the y range holds the format's range line and the peaks.
    let names: Vec<String> = sigs
        .iter()
        .map(|s| format!("{}.{}", s.controller, s.name))
        .collect();
    let (lo, hi) = peaks
        .iter()
        .map(|p| p.1)
        .fold((range, range), |(lo, hi), y| (lo.min(y), hi.max(y)));
    // The proven headroom (any input within the clamps) where the proofs name the signal.
    let proven: Vec<(f64, f64)> = sigs
        .iter()
        .enumerate()
        .filter_map(|(i, s)| {
            a.bounds
                .iter()
                .find(|b| b.signal == s.name)
                .map(|b| (i as f64 + 0.5, b.margin_bits))
        })
        .collect();
    let fig = Figure::new(&format!(
        "Ranges against {}: signals in per unit (pu = the value over its full scale)",
        a.formats.signal
    ))
    .panel(
        Plot::histogram(
            "headroom (bits) = log2(format range / peak): observed over the scenarios, proven for any input",
            &edges,
            &head,
        )
        .x_label("signal")
        .y_label("bits")
        .x_categories(&names)
        .size(1100.0, 580.0)
        .series(Series::line("bars: observed headroom", Vec::new()).color("#56B4E9").width(6.0))
        .series(
            Series::scatter("proven headroom", proven)
                .style(wheelset_report::svg::Style::Crosses)
                .color("#000000"),
        )
        // The bars fill the width: the warn line is named in the legend, not over them.
        .series(
            Series::line(
                &format!("warn below {} bit (dashed)", tol.headroom_bits.0),
                Vec::new(),
            )
            .style(wheelset_report::svg::Style::Dashed)
            .color(WARN_COLOUR),
        )
        .hmark(tol.headroom_bits.0, "", WARN_COLOUR),
    )
    .panel(
        Plot::new("log2 peak |value| (pu), observed")
            .x_label("signal")
            .y_label("log2 pu")
            .x_categories(&names)
            .size(1100.0, 580.0)
            .y_range(lo - 1.0, hi + 1.0)
            .series(Series::scatter("peak", peaks))
            .hmark(
                range,
                &format!("the format's range: 2^{range:.0} pu"),
                FAIL_COLOUR,
            ),
    );
    let f = save(&fig, dir, "ranges.svg")?;
    out.push(("Ranges and headroom per signal".to_string(), f));
    let wire = wheelset_control::WireLsb::default();
    let (warn_lsb, fail_lsb) = tol.noise_wire_lsb;
    for (name, tr) in &a.observed.traces {
        if tr.is_empty() {
            continue;
        }
        let panel = |title: &str, unit: &str, lsb: f64, pts: Vec<(f64, f64)>| {
            let w = warn_lsb * lsb;
            Plot::new(title)
                .x_label("t (s)")
                .y_label(unit)
                .series(Series::line(title.split(' ').next().unwrap_or(""), pts))
                .hmark(
                    w,
                    &format!(
                        "tolerance ±{warn_lsb} wire LSB = ±{w} {unit} (warn above; fail \
                         above {fail_lsb} LSB)"
                    ),
                    WARN_COLOUR,
                )
                .hmark(-w, "", WARN_COLOUR)
        };
        let fig = Figure::new(&format!("{name}: fixed minus f64, same inputs (yaw lead)"))
            .panel(panel(
                "T_psi error (N m)",
                "N m",
                wire.torque,
                tr.iter().map(|(t, y, _)| (*t, *y)).collect(),
            ))
            .panel(panel(
                "u_a error (V)",
                "V",
                wire.voltage,
                tr.iter().map(|(t, _, u)| (*t, *u)).collect(),
            ));
        let f = save(&fig, dir, &format!("noise_{name}.svg"))?;
        out.push((format!("{name}: output error over time"), f));
    }
    Ok(out)
}
