//! Outputs of a run: the verdict JSON (`--json`), the trajectory CSV (`--csv`, the
//! columns of `sim-host`'s run CSV), and a Markdown report with SVG plots (`--report
//! DIR`: `report.md`, `trajectories.svg`, `exec_histogram.svg`).

use std::fmt::Write as _;
use std::io;
use std::path::{Path, PathBuf};

use sim_host::sim::{Record, Trajectory};
use sim_host::svg::{Figure, Plot, Series, Style};

use crate::run::{RunOutcome, RunReport};
use crate::table::Table;

fn create_parent(path: &Path) -> io::Result<()> {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => std::fs::create_dir_all(d),
        _ => Ok(()),
    }
}

/// Writes the verdict document as pretty JSON.
pub fn write_json(report: &RunReport, path: &Path) -> io::Result<()> {
    create_parent(path)?;
    let text = serde_json::to_string_pretty(report).map_err(io::Error::other)?;
    std::fs::write(path, text + "\n")
}

/// Writes the closed-loop trajectory as CSV (the columns of `sim-host run --csv`).
pub fn write_csv(tr: &Trajectory, path: &Path) -> io::Result<()> {
    create_parent(path)?;
    let f = std::fs::File::create(path)?;
    tr.write_csv(io::BufWriter::new(f))
}

fn series(tr: &Trajectory, label: &str, f: impl Fn(&Record) -> f64) -> Series {
    Series::line(label, tr.records.iter().map(|r| (r.t_s, f(r))).collect())
}

/// The plotted signals: (title, unit label, scale, accessor).
type Signal = (&'static str, &'static str, f64, fn(&Record) -> f64);

const SIGNALS: [Signal; 5] = [
    ("Lateral displacement y", "y (mm)", 1e3, |r| r.y_m),
    ("Yaw angle psi", "psi (mrad)", 1e3, |r| r.psi_rad),
    ("Control yaw torque T_ctrl", "T_ctrl (kN m)", 1e-3, |r| {
        r.t_ctrl_nm
    }),
    ("Armature current i_a", "i_a (A)", 1.0, |r| r.i_a_a),
    ("Armature voltage u_a", "u_a (V)", 1.0, |r| r.u_a_v),
];

/// Writes `report.md` and its SVG plots into `dir`; returns the files written.
pub fn write_report(out: &RunOutcome, dir: &Path, command: &str) -> io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    let r = &out.report;
    let mut files = Vec::new();
    let mut fig = Figure::new(&format!(
        "{} on {}: device (solid) vs f64 continuous reference (dashed)",
        r.scenario, r.target
    ));
    for (title, unit, k, f) in SIGNALS {
        fig = fig.panel(
            Plot::new(title)
                .x_label("t (s)")
                .y_label(unit)
                .series(series(&out.trajectory, "device", |x| f(x) * k))
                .series(series(&out.reference, "reference", |x| f(x) * k).style(Style::Dashed)),
        );
    }
    let p = dir.join("trajectories.svg");
    fig.save(&p)?;
    files.push(p);

    // The monitor: lateral displacement, and the mean square against its threshold.
    let m = &r.monitor;
    let thr2 = {
        let p = wheelset_control::MonitorParams::default();
        p.threshold_m_s * p.threshold_m_s * 1e6
    };
    let ms: Vec<(f64, f64)> = out.monitor_ms.iter().map(|&(t, v)| (t, v * 1e6)).collect();
    let p = dir.join("monitor.svg");
    Figure::new(&format!(
        "{} on {}: stability monitor ({} alarm(s), first {})",
        r.scenario,
        r.target,
        m.alarms.len(),
        m.first_alarm_s
            .map_or("none".to_string(), |t| format!("at {t:.3} s"))
    ))
    .panel(
        Plot::new("Lateral displacement y")
            .x_label("t (s)")
            .y_label("y (mm)")
            .series(series(&out.trajectory, "device", |x| x.y_m * 1e3)),
    )
    .panel(
        Plot::new("Band-passed mean square of y' against the alarm threshold")
            .x_label("t (s)")
            .y_label("mean square ((mm/s)^2)")
            .series(Series::line("mean square", ms))
            .hline(thr2),
    )
    .save(&p)?;
    files.push(p);

    let h = &r.timing.exec_histogram;
    let edges_us: Vec<f64> = h.edges_ns.iter().map(|e| e * 1e-3).collect();
    let counts: Vec<f64> = h.counts.iter().map(|&c| c as f64).collect();
    let p = dir.join("exec_histogram.svg");
    Figure::new(&format!(
        "Execution time per tick ({}; {} ns per {})",
        r.target, r.timing.exec_ns_per_unit, r.timing.exec_unit
    ))
    .panel(if r.timing.exec_ns.max > 0.0 {
        Plot::histogram("Execution time", &edges_us, &counts)
            .x_label("exec (us)")
            .y_label("ticks")
    } else {
        // The in-process device's execution time is simulated as 0 ns (the host's own
        // time per tick is `transport.host_tick_ns`): one bar at 0 would read as a
        // measurement.
        Plot::new("Execution time")
            .x_label("exec (us)")
            .y_label("ticks")
            .note(&format!(
                "not measured: the {} device reports no execution time (every tick 0 ns)",
                r.target
            ))
    })
    .save(&p)?;
    files.push(p);

    let md = markdown(out, command);
    let p = dir.join("report.md");
    std::fs::write(&p, md)?;
    files.push(p);
    Ok(files)
}

fn f(x: f64) -> String {
    if x == 0.0 {
        "0".into()
    } else if x.abs() >= 1e4 || x.abs() < 1e-3 {
        format!("{x:.3e}")
    } else {
        format!("{x:.4}")
    }
}

/// The Markdown text of the report.
#[must_use]
pub fn markdown(out: &RunOutcome, command: &str) -> String {
    let r = &out.report;
    let t = &r.timing;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# HIL run: {} on {} ({})\n",
        r.scenario, r.target, r.verdict
    );
    let _ = writeln!(s, "Reproduce: `{command}`\n");
    let mut tb = Table::new(["", ""]);
    tb.row(["verdict".to_string(), format!("**{}**", r.verdict)])
        .row([
            "target".to_string(),
            format!("{} ({:?} clock)", r.target, t.clock),
        ])
        .row([
            "scenario".to_string(),
            format!("{} ({})", r.scenario, r.scenario_source),
        ])
        .row(["control".to_string(), format!("{:?}", r.control)])
        .row([
            "link faults".to_string(),
            if r.faults.is_empty() {
                "none".to_string()
            } else {
                r.faults.clone()
            },
        ])
        .row(["device fault".to_string(), r.device_fault.to_string()]);
    let _ = writeln!(s, "{tb}");
    let _ = writeln!(s, "## Timing ({})\n", t.verdict);
    let _ = writeln!(
        s,
        "Period T = {} ns, {} periods, {} baud.\n",
        t.period_ns, t.periods, t.baud
    );
    if !t.exec_measured {
        let _ = writeln!(s, "Execution time {}.\n", t.exec_note);
    }
    let shown = t.exec_measured || t.exec_units.max > 0.0;
    let cell = |v: f64| {
        if shown {
            f(v)
        } else {
            "not measured".to_string()
        }
    };
    let mut tb = Table::new(["figure", "min", "mean", "p99", "max"]);
    tb.row([
        format!("execution time ({})", t.exec_unit),
        cell(t.exec_units.min),
        cell(t.exec_units.mean),
        cell(t.exec_units.p99),
        cell(t.exec_units.max),
    ])
    .row([
        format!(
            "latency (ns{})",
            if t.latency_modelled { ", modelled" } else { "" }
        ),
        f(t.latency_ns.min),
        f(t.latency_ns.mean),
        f(t.latency_ns.p99),
        f(t.latency_ns.max),
    ]);
    let _ = writeln!(s, "{tb}");
    let _ = writeln!(
        s,
        "Jitter max {} ns (RMS {} ns); missed ticks {}; device tick gaps {}; overruns {}; \
         CPU mean {:.3} % / max {:.3} %; link {:.1} % ({:.1} + {:.1} bytes per period).\n",
        t.jitter_max_ns.map_or("n/a".into(), f),
        t.jitter_rms_ns.map_or("n/a".into(), f),
        t.missed_ticks,
        t.tick_gaps,
        t.overruns,
        t.cpu_mean * 100.0,
        t.cpu_max * 100.0,
        t.link_utilisation * 100.0,
        t.bytes_up_per_period,
        t.bytes_down_per_period
    );
    let mut tb = Table::new(["budget", "value (of T)", "warn", "fail", "verdict"]);
    for c in &t.checks {
        tb.row([
            format!("timing.{}", c.name),
            f(c.value),
            c.limit.warn.to_string(),
            c.limit.fail.to_string(),
            format!("{}{}", c.verdict, if c.applicable { "" } else { " (n/a)" }),
        ]);
    }
    let _ = write!(s, "{tb}");
    let _ = writeln!(s, "\n![execution time](exec_histogram.svg)\n");
    let n = &r.numerics;
    let _ = writeln!(
        s,
        "## Numerics ({})\n\nAgainst the {}.\n",
        n.verdict, n.reference
    );
    if let Some(t) = n.run_diverged_at_s {
        let _ = writeln!(
            s,
            "**The closed loop diverged at {t:.3} s** (run stopped).\n"
        );
    }
    if let Some(t) = n.reference_diverged_at_s {
        let _ = writeln!(
            s,
            "**The reference diverged at {t:.3} s** (no yardstick).\n"
        );
    }
    let mut tb = Table::new([
        "signal",
        "max error",
        "at t (s)",
        "RMS error",
        "reference peak",
        "allowed",
        "verdict",
    ]);
    for c in &n.signals {
        tb.row([
            c.name.to_string(),
            f(c.max_err),
            format!("{:.3}", c.max_err_t_s),
            f(c.rms_err),
            f(c.ref_peak),
            f(c.allowed),
            c.verdict.to_string(),
        ]);
    }
    let _ = write!(s, "{tb}");
    let _ = writeln!(s, "\n![trajectories](trajectories.svg)\n");
    let fr = &r.frames;
    let _ = writeln!(
        s,
        "## Frames ({}; source: {})\n",
        r.frames_verdict, fr.source
    );
    let mut tb = Table::new([
        "direction",
        "sent",
        "received",
        "rejected",
        "dropped",
        "in flight",
    ]);
    for (name, d) in [("host -> device", fr.up), ("device -> host", fr.down)] {
        tb.row([
            name.to_string(),
            d.sent.to_string(),
            d.received.to_string(),
            d.rejected.to_string(),
            d.dropped.to_string(),
            d.in_flight.to_string(),
        ]);
    }
    tb.row([
        "total".to_string(),
        fr.sent.to_string(),
        fr.received.to_string(),
        fr.rejected.to_string(),
        fr.dropped.to_string(),
        fr.in_flight.to_string(),
    ]);
    let _ = write!(s, "{tb}");
    if let Some(st) = &r.device_status {
        let _ = writeln!(
            s,
            "\nDevice counters: ticks {}, rx ok {}, seq gaps {}, held ticks {}, safe ticks {} \
             (entries {}, exits {}), yaw saturated {}, traction saturated {}, inputs clamped {}.",
            st.ticks,
            st.rx_ok,
            st.seq_gaps,
            st.held_ticks,
            st.safe_ticks,
            st.safe_entries,
            st.safe_exits,
            st.yaw_sat,
            st.traction_sat,
            st.input_clamped
        );
    }
    s
}

/// The axis indices of grid point `index` (the last axis fastest, as
/// [`crate::sweep::points`] numbers them).
fn axis_indices(axes: &[crate::sweep::Axis], index: usize) -> Vec<usize> {
    let mut rest = index;
    let mut idx = vec![0; axes.len()];
    for (k, a) in axes.iter().enumerate().rev() {
        idx[k] = rest % a.values.len().max(1);
        rest /= a.values.len().max(1);
    }
    idx
}

/// A parameter value for a label: 3 significant digits (`1.00e6`, `0.167`).
pub fn value_label(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-2 {
        format!("{v:.2e}")
    } else {
        format!("{}", (v * 1e3).round() / 1e3)
    }
}

const VERDICT_COLOURS: [(crate::budget::Verdict, &str); 3] = [
    (crate::budget::Verdict::Pass, "#009E73"),
    (crate::budget::Verdict::Warn, "#E69F00"),
    (crate::budget::Verdict::Fail, "#D55E00"),
];

/// The heat maps of a campaign: the first axis across, the second (if any) up, one map
/// per combination of the further axes; `cell` colours and labels one record.
fn heat_maps(
    doc: &crate::sweep::SweepDoc,
    title: &str,
    cell: &dyn Fn(&crate::sweep::Record) -> sim_host::svg::heatmap::Cell,
    legend: &[(String, String)],
) -> Vec<sim_host::svg::heatmap::HeatMap> {
    use sim_host::svg::heatmap::{Cell, HeatMap};
    let axes = &doc.sweep.axes;
    let Some(x) = axes.first() else {
        return Vec::new();
    };
    let y = axes.get(1);
    let (nx, ny) = (x.values.len(), y.map_or(1, |a| a.values.len()));
    let per_map = nx * ny;
    let maps = doc.sweep.points / per_map.max(1);
    (0..maps.max(1))
        .map(|m| {
            let mut cells = vec![Cell::new("#eeeeee", "-"); per_map];
            let mut rest_label = String::new();
            for r in &doc.records {
                if r.index / per_map.max(1) != m {
                    continue;
                }
                let idx = axis_indices(axes, r.index);
                let (i, j) = (idx[0], idx.get(1).copied().unwrap_or(0));
                cells[j * nx + i] = cell(r);
                if rest_label.is_empty() && axes.len() > 2 {
                    rest_label = axes[2..]
                        .iter()
                        .zip(&idx[2..])
                        .map(|(a, &k)| format!("{} = {}", a.key, value_label(a.values[k])))
                        .collect::<Vec<_>>()
                        .join(", ");
                }
            }
            let t = if rest_label.is_empty() {
                title.to_string()
            } else {
                format!("{title} at {rest_label}")
            };
            let mut h = HeatMap::new(
                &t,
                x.values.iter().map(|&v| value_label(v)).collect(),
                y.map_or(vec![String::new()], |a| {
                    a.values.iter().map(|&v| value_label(v)).collect()
                }),
            )
            .labels(&x.key, y.map_or("", |a| a.key.as_str()))
            .cells(cells);
            for (c, l) in legend {
                h = h.legend(c, l);
            }
            h
        })
        .collect()
}

/// Writes a campaign's report into `dir`: `report.md` (a table of every point) and the
/// heat maps `verdict.svg` and `peak_y.svg` (peak |y| on a logarithmic colour scale);
/// returns the files written.
pub fn write_sweep_report(
    doc: &crate::sweep::SweepDoc,
    dir: &Path,
    command: &str,
) -> io::Result<Vec<PathBuf>> {
    use sim_host::svg::heatmap::{sequential, stack, Cell};
    std::fs::create_dir_all(dir)?;
    let mut files = Vec::new();
    let h = &doc.sweep;
    let what = format!(
        "{} with {:?} on {}{}",
        h.scenario,
        h.control,
        h.target,
        if h.faults.is_empty() {
            String::new()
        } else {
            format!(", faults {}", h.faults)
        }
    )
    .to_lowercase();
    let colour = |v: crate::budget::Verdict| {
        VERDICT_COLOURS
            .iter()
            .find(|(w, _)| *w == v)
            .map_or("#999999", |(_, c)| c)
    };
    let legend: Vec<(String, String)> = VERDICT_COLOURS
        .iter()
        .map(|(v, c)| ((*c).to_string(), v.to_string()))
        .collect();
    let maps = heat_maps(
        doc,
        &format!("Verdict: {what}"),
        &|r| Cell::new(colour(r.verdict), &r.verdict.to_string()),
        &legend,
    );
    let p = dir.join("verdict.svg");
    std::fs::write(&p, stack("", &maps))?;
    files.push(p);

    // Peak |y| on a log scale between the smallest and the largest peak.
    let peaks: Vec<f64> = doc
        .records
        .iter()
        .map(|r| r.peak_abs_y_m)
        .filter(|p| p.is_finite() && *p > 0.0)
        .collect();
    let lo = peaks.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = peaks.iter().copied().fold(0.0, f64::max);
    let scale = move |p: f64| {
        if !(p.is_finite() && p > 0.0) {
            f64::NAN
        } else if hi > lo {
            (p / lo).ln() / (hi / lo).ln()
        } else {
            0.5
        }
    };
    let legend = if peaks.is_empty() {
        Vec::new()
    } else {
        vec![
            (sequential(0.0), format!("{:.3} mm", lo * 1e3)),
            (sequential(1.0), format!("{:.3} mm", hi * 1e3)),
        ]
    };
    let maps = heat_maps(
        doc,
        &format!("Peak |y| (mm): {what}"),
        &|r| {
            let text = match r.diverged_at_s {
                Some(t) => format!("div {t:.2} s"),
                None => format!("{:.3}", r.peak_abs_y_m * 1e3),
            };
            Cell::new(&sequential(scale(r.peak_abs_y_m)), &text)
        },
        &legend,
    );
    let p = dir.join("peak_y.svg");
    std::fs::write(&p, stack("", &maps))?;
    files.push(p);

    let p = dir.join("report.md");
    std::fs::write(&p, sweep_markdown(doc, command))?;
    files.push(p);
    Ok(files)
}

/// The Markdown text of a campaign's report.
#[must_use]
pub fn sweep_markdown(doc: &crate::sweep::SweepDoc, command: &str) -> String {
    let h = &doc.sweep;
    let mut s = String::new();
    let _ = writeln!(
        s,
        "# HIL sweep: {} with {:?} on {}\n",
        h.scenario, h.control, h.target
    );
    let _ = writeln!(s, "Reproduce: `{command}`\n");
    let axes: Vec<String> = h
        .axes
        .iter()
        .map(|a| {
            format!(
                "{} in {} ({} values)",
                a.key,
                a.values
                    .iter()
                    .map(|&v| value_label(v))
                    .collect::<Vec<_>>()
                    .join(", "),
                a.values.len()
            )
        })
        .collect();
    let _ = writeln!(
        s,
        "{} points: {}{}. Link faults: {}, seed {}. Parameters: {}.\n",
        h.points,
        axes.join("; "),
        h.follows
            .iter()
            .map(|(k, l)| format!("; {k} follows {l}"))
            .collect::<String>(),
        if h.faults.is_empty() {
            "none"
        } else {
            &h.faults
        },
        h.seed,
        h.params_file.as_deref().map_or(
            "the paper's, with the scenario's [params] on top".to_string(),
            |f| { format!("{f}, with the scenario's [params] on top") }
        )
    );
    let sm = &doc.summary;
    let _ = writeln!(
        s,
        "**{} pass, {} warn, {} fail**{}.\n",
        sm.pass,
        sm.warn,
        sm.fail,
        doc.shard.map_or(String::new(), |sh| format!(
            " (shard {sh}: {} of the points)",
            doc.records.len()
        ))
    );
    let _ = writeln!(s, "![verdicts](verdict.svg)\n\n![peak |y|](peak_y.svg)\n");
    let keys: Vec<String> = doc
        .records
        .first()
        .map(|r| r.params.iter().map(|(k, _)| k.clone()).collect())
        .unwrap_or_default();
    let mut t = crate::table::Table::new(
        std::iter::once("#".to_string())
            .chain(keys.iter().cloned())
            .chain(
                [
                    "verdict",
                    "peak |y| (mm)",
                    "diverged at (s)",
                    "checks not passed",
                ]
                .map(String::from),
            ),
    );
    for r in &doc.records {
        let checks = if r.failing.is_empty() {
            "-".to_string()
        } else {
            r.failing
                .iter()
                .map(|c| format!("{} {}: {}", c.check, c.verdict, c.reason))
                .collect::<Vec<_>>()
                .join("; ")
        };
        t.row(
            std::iter::once(r.index.to_string())
                .chain(r.params.iter().map(|(_, v)| value_label(*v)))
                .chain([
                    r.verdict.to_string(),
                    format!("{:.3}", r.peak_abs_y_m * 1e3),
                    r.diverged_at_s.map_or("-".into(), |t| format!("{t:.3}")),
                    checks,
                ]),
        );
    }
    s.push_str(&t.render());
    s
}
