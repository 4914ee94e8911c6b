//! SVG plots for the report (drawn with `wheelset_report::svg`): per controller a Bode figure
//! (magnitude of the three forms, then the gain and phase errors), the headroom of every
//! signal, and the fixed-minus-f64 output error over time per scenario. Frequency axes
//! are `log10(f / Hz)` (the plotting module has linear axes only).

use std::path::Path;

use wheelset_report::svg::{Figure, Plot, Series};

use super::{Audit, AuditError};

fn save(fig: &Figure, dir: &Path, file: &str) -> Result<String, AuditError> {
    let p = dir.join(file);
    fig.save(&p)
        .map_err(|e| AuditError::Io { path: p, source: e })?;
    Ok(file.to_string())
}

/// Write the plots into `dir`; returns `(caption, file name)` of each.
pub fn write_plots(a: &Audit, dir: &Path) -> Result<Vec<(String, String)>, AuditError> {
    let mut out = Vec::new();
    for c in &a.controllers {
        let lf = |f: f64| f.log10();
        let pts = |g: &dyn Fn(&super::FreqPoint) -> f64| -> Vec<(f64, f64)> {
            c.freq_response.iter().map(|p| (lf(p.f_hz), g(p))).collect()
        };
        let db = |x: f64| 20.0 * x.log10();
        let limit = lf(c.worst.below_hz);
        let mag = Plot::new(&format!("{}: |H| ({})", c.name, c.unit))
            .x_label("log10 f (Hz)")
            .y_label("gain (dB)")
            .series(Series::line("continuous", pts(&|p| db(p.continuous.gain))))
            .series(Series::line(
                "discrete f64",
                pts(&|p| db(p.discrete_f64.gain)),
            ))
            .series(Series::line("fixed (measured)", pts(&|p| db(p.fixed.gain))))
            .vline(limit);
        let gerr = Plot::new("gain error (dB); vertical line: the judged limit")
            .x_label("log10 f (Hz)")
            .y_label("dB")
            .series(Series::line(
                "fixed - discrete f64",
                pts(&|p| p.fixed_vs_f64_db),
            ))
            .series(Series::line(
                "discrete f64 - continuous",
                pts(&|p| p.f64_vs_continuous_db),
            ))
            .vline(limit);
        let perr = Plot::new("phase error (deg)")
            .x_label("log10 f (Hz)")
            .y_label("deg")
            .series(Series::line(
                "fixed - discrete f64",
                pts(&|p| p.fixed_vs_f64_deg),
            ))
            .series(Series::line(
                "discrete f64 - continuous",
                pts(&|p| p.f64_vs_continuous_deg),
            ))
            .vline(limit);
        let fixed_only = Plot::new("fixed - discrete f64 alone (gain dB, phase deg)")
            .x_label("log10 f (Hz)")
            .y_label("error")
            .series(Series::line("gain (dB)", pts(&|p| p.fixed_vs_f64_db)))
            .series(Series::line("phase (deg)", pts(&|p| p.fixed_vs_f64_deg)))
            .vline(limit);
        let fig = Figure::new(&format!(
            "{} at {:.0} Hz: Bode and errors",
            c.name, c.rate_hz
        ))
        .panel(mag)
        .panel(gerr)
        .panel(perr)
        .panel(fixed_only);
        let f = save(&fig, dir, &format!("bode_{}.svg", c.name))?;
        out.push((format!("{}: Bode magnitude and errors", c.name), f));
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
            if s.headroom_bits.is_finite() {
                s.headroom_bits
            } else {
                0.0
            }
        })
        .collect();
    let peaks: Vec<(f64, f64)> = sigs
        .iter()
        .enumerate()
        .map(|(i, s)| {
            (
                i as f64 + 0.5,
                s.min_pu.abs().max(s.max_pu.abs()).max(1e-12).log2(),
            )
        })
        .collect();
    let range = a.formats.signal.range().log2();
    // The names of the report's range table, and a y range that holds the format's
    // range line as well as the peaks (the line sits above every peak with headroom).
    let names: Vec<String> = sigs
        .iter()
        .map(|s| format!("{}.{}", s.controller, s.name))
        .collect();
    let (lo, hi) = peaks
        .iter()
        .map(|p| p.1)
        .fold((range, range), |(lo, hi), y| (lo.min(y), hi.max(y)));
    let fig = Figure::new(&format!("Ranges against {}", a.formats.signal))
        .panel(
            Plot::histogram("headroom (bits); line: 1 bit", &edges, &head)
                .x_label("signal")
                .y_label("bits")
                .x_categories(&names)
                .size(1100.0, 560.0)
                .hline(1.0),
        )
        .panel(
            Plot::new(&format!(
                "log2 peak |value| (pu); line: the format's range, {range:.0}"
            ))
            .x_label("signal")
            .y_label("log2 pu")
            .x_categories(&names)
            .size(1100.0, 560.0)
            .y_range(lo - 1.0, hi + 1.0)
            .series(Series::scatter("peak", peaks))
            .hline(range),
        );
    let f = save(&fig, dir, "ranges.svg")?;
    out.push(("Ranges and headroom per signal".to_string(), f));
    for (name, tr) in &a.observed.traces {
        if tr.is_empty() {
            continue;
        }
        let fig = Figure::new(&format!("{name}: fixed minus f64, same inputs (yaw lead)"))
            .panel(
                Plot::new("T_psi error (N m)")
                    .x_label("t (s)")
                    .y_label("N m")
                    .series(Series::line(
                        "T_psi",
                        tr.iter().map(|(t, y, _)| (*t, *y)).collect(),
                    )),
            )
            .panel(
                Plot::new("u_a error (V)")
                    .x_label("t (s)")
                    .y_label("V")
                    .series(Series::line(
                        "u_a",
                        tr.iter().map(|(t, _, u)| (*t, *u)).collect(),
                    )),
            );
        let f = save(&fig, dir, &format!("noise_{name}.svg"))?;
        out.push((format!("{name}: output error over time"), f));
    }
    Ok(out)
}
