//! Outputs of a run: the verdict JSON (`--json`), the trajectory CSV (`--csv`, the
//! columns of `sim-host`'s run CSV), and a Markdown report with SVG plots (`--report
//! DIR`: `report.md`, `trajectories.svg`, `monitor.svg`, `exec_histogram.svg`). The
//! campaign report of `hil sweep` is [`crate::sweep::document`].

use std::fmt::Write as _;
use std::io;
use std::path::{Path, PathBuf};

use wheelset_plant::sim::{Record, Trajectory};
use wheelset_report::svg::{Figure, Plot, Series, Style};

use crate::check::numerics::column;
use crate::run::{RunOutcome, RunReport};
use crate::sweep::document::value_label;

use wheelset_report::table::Table;

fn create_parent(path: &Path) -> io::Result<()> {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => std::fs::create_dir_all(d),
        _ => Ok(()),
    }
}

/// A document as written (`--json`): pretty JSON, a newline after.
pub fn to_json(doc: &impl serde::Serialize) -> serde_json::Result<String> {
    Ok(serde_json::to_string_pretty(doc)? + "\n")
}

/// Writes a document (the verdict document of a run) as [`to_json`] does.
pub fn write_json(report: &impl serde::Serialize, path: &Path) -> io::Result<()> {
    create_parent(path)?;
    std::fs::write(path, to_json(report).map_err(io::Error::other)?)
}

/// Writes the closed-loop trajectory as CSV (the columns of `sim-host run --csv`).
pub fn write_csv(tr: &Trajectory, path: &Path) -> io::Result<()> {
    create_parent(path)?;
    let f = std::fs::File::create(path)?;
    tr.write_csv(io::BufWriter::new(f))
}

/// A plot of `unit` against time over `[0, end]` s.
fn over_time(title: &str, unit: &str, end: f64) -> Plot {
    Plot::new(title)
        .x_label("t (s)")
        .y_label(unit)
        .x_range(0.0, end)
}

/// The plotted signals: title, symbol, unit, scale, CSV column (the numerics' name).
const SIGNALS: [(&str, &str, &str, f64, &str); 5] = [
    ("Lateral displacement y", "y", "mm", 1e3, "y_m"),
    ("Yaw angle psi", "psi", "mrad", 1e3, "psi_rad"),
    (
        "Control yaw torque T_ctrl",
        "T_ctrl",
        "kN m",
        1e-3,
        "T_ctrl_Nm",
    ),
    ("Armature current i_a", "i_a", "A", 1.0, "i_a_A"),
    ("Armature voltage u_a", "u_a", "V", 1.0, "u_a_V"),
];

/// Colours of the marks: limits that pass, limits that fail, events.
const PASS_COLOUR: &str = "#009E73";
const FAIL_COLOUR: &str = "#D55E00";
const EVENT_COLOUR: &str = "#000000";

/// `trajectories.svg`: each signal, device against reference, and below it the error
/// the numerics judge (outside the reference's time tube) against the allowed error and
/// the fail level.
fn trajectories(out: &RunOutcome) -> Figure {
    let r = &out.report;
    let fault = r.monitor.fault_s;
    let end = out.trajectory.records.last().map_or(1.0, |x| x.t_s);
    // A run stopped as diverged ends early: the reference is drawn over the same span.
    let stopped = out
        .trajectory
        .info
        .diverged_at_s
        .map_or(String::new(), |t| format!(" (diverged at {t:.3} s)"));
    let mut fig = Figure::new(&format!(
        "{} on {}: device vs f64 reference, and the error judged{stopped}",
        r.scenario, r.target
    ));
    let line = |tr: &Trajectory, label: &str, col: &str, k: f64| {
        let at = |x: &Record| column(x, col).unwrap_or(f64::NAN) * k;
        let pts = tr.records.iter().filter(|x| x.t_s <= end);
        Series::line(label, pts.map(|x| (x.t_s, at(x))).collect())
    };
    for (title, symbol, unit, k, col) in SIGNALS {
        let mut p = over_time(title, &format!("{symbol} ({unit})"), end)
            .size(860.0, 260.0)
            .series(line(&out.trajectory, "device", col, k))
            .series(line(&out.reference, "reference", col, k).style(Style::Dashed));
        if let Some(t) = fault {
            p = p.vmark(t, "plant fault", EVENT_COLOUR);
        }
        fig = fig.panel(p);
        let check = r.numerics.signals.iter().find(|c| c.name == col);
        let errors = out.numerics_errors.iter().find(|(n, _)| n == col);
        let (Some(c), Some((_, e))) = (check, errors) else {
            continue;
        };
        let allowed = c.allowed * k;
        let fail = allowed * c.tolerance.warn_factor;
        let pts = e.iter().map(|&(t, v)| (t, v * k)).collect();
        let title = format!(
            "{symbol}: device - reference outside the ±{:.0} ms tube, max {} {unit} at {:.3} s ({})",
            c.tolerance.time_s * 1e3,
            value_label(c.max_err * k),
            c.max_err_t_s,
            c.verdict
        );
        let mut p = over_time(&title, &format!("error ({unit})"), end)
            .size(860.0, 190.0)
            .series(Series::line("judged error", pts).color("#0072B2"));
        for (v, what, colour) in [
            (allowed, "allowed", PASS_COLOUR),
            (fail, "fail above", FAIL_COLOUR),
        ] {
            let label = format!("{what} ±{} {unit}", value_label(v));
            p = p.hmark(v, &label, colour).hmark(-v, "", colour);
        }
        if let Some(t) = fault {
            p = p.vmark(t, "judged up to the fault", EVENT_COLOUR);
        }
        fig = fig.panel(p);
    }
    fig
}

/// `monitor.svg`: `y` and the monitor's mean square (log axis) against the alarm
/// threshold and its release level over the run, then a zoom on the events (the fault,
/// the alarms, the deadline), each marked and labelled.
fn monitor(out: &RunOutcome) -> Figure {
    let r = &out.report;
    let m = &r.monitor;
    let mp = wheelset_control::MonitorParams::default();
    let thr = mp.threshold_m_s * 1e3;
    let rel = thr * mp.release;
    let ms: Vec<(f64, f64)> = out.monitor_ms.iter().map(|&(t, v)| (t, v * 1e6)).collect();
    // Each event: its time, its name, its long name with the time (the zoom's), its colour.
    let mut events: Vec<(f64, String, String, &str)> = Vec::new();
    let mut event = |t: f64, name: String, long: &str, colour| {
        events.push((t, name, format!("{long} {t:.3} s"), colour));
    };
    if let Some(t) = m.fault_s {
        event(t, "fault".into(), "plant fault", EVENT_COLOUR);
    }
    for a in &m.alarms {
        let name = format!("{} alarm", a.kind);
        event(a.t_s, name.clone(), &name, FAIL_COLOUR);
    }
    if let (Some(d), "alarm") = (m.deadline_s, m.expect) {
        event(d, "deadline".into(), "deadline", "#777777");
    }
    let end = out.trajectory.records.last().map_or(1.0, |x| x.t_s);
    let y_mm = out
        .trajectory
        .records
        .iter()
        .map(|x| (x.t_s, x.y_m * 1e3))
        .collect();
    let peak = ms.iter().map(|p| p.1).fold(thr * thr, f64::max);
    // The smallest value above zero sits a decade above the floor; a mean square of exactly
    // zero (below the monitor's resolution) is drawn, in grey, at the floor.
    let smallest = ms
        .iter()
        .map(|p| p.1)
        .filter(|v| *v > 0.0)
        .fold(f64::INFINITY, f64::min)
        .max(thr * thr * 1e-8)
        .min(thr * thr);
    let floor = smallest / 10.0;
    let ms_plot = |title: &str, pts: Vec<(f64, f64)>| {
        let zero: Vec<(f64, f64)> = pts
            .iter()
            .map(|&(t, v)| (t, if v == 0.0 { floor * 1.25 } else { f64::NAN }))
            .collect();
        let mut p = over_time(title, "mean square ((mm/s)^2)", end)
            .log_y()
            .y_range(floor, peak * 3.0)
            .series(Series::line("mean square", pts));
        if zero.iter().any(|z| z.1.is_finite()) {
            p = p.series(
                Series::line("mean square = 0 (drawn at the floor)", zero)
                    .color("#999999")
                    .width(3.0),
            );
        }
        p.hmark(
            thr * thr,
            &format!("alarm threshold: RMS {thr:.0} mm/s"),
            FAIL_COLOUR,
        )
        .hmark(
            rel * rel,
            &format!("release: RMS {rel:.0} mm/s"),
            PASS_COLOUR,
        )
    };
    let mark = |mut p: Plot, zoom: bool| {
        for (t, short, long, c) in &events {
            p = p.vmark(*t, if zoom { long } else { short }, c);
        }
        p
    };
    let alarms = match (m.alarms.len(), m.first_alarm_s) {
        (0, _) | (_, None) => "no alarm".to_string(),
        (1, Some(t)) => format!("1 alarm at {t:.3} s"),
        (n, Some(t)) => format!("{n} alarms, the first at {t:.3} s"),
    };
    let mut fig = Figure::new(&format!(
        "{} on {}: stability monitor ({alarms}; {})",
        r.scenario, r.target, m.verdict
    ))
    .panel(mark(
        over_time("Lateral displacement y", "y (mm)", end).series(Series::line("device", y_mm)),
        false,
    ))
    .panel(mark(
        ms_plot(
            "Band-passed mean square of y' against the hunting alarm's threshold",
            ms.clone(),
        ),
        false,
    ));
    let first = events.iter().map(|e| e.0).fold(f64::INFINITY, f64::min);
    let last = events.iter().map(|e| e.0).fold(f64::NEG_INFINITY, f64::max);
    if first.is_finite() {
        let (t0, t1) = (
            (first - 0.3).max(0.0),
            (last + 0.2).min(end).max(first + 0.1),
        );
        let zoom = ms
            .iter()
            .copied()
            .filter(|p| p.0 >= t0 && p.0 <= t1)
            .collect();
        fig = fig.panel(mark(
            ms_plot(&format!("The events, {t0:.2}-{t1:.2} s"), zoom).x_range(t0, t1),
            true,
        ));
    }
    fig
}

/// `exec_histogram.svg`: the execution time per tick, its distribution on a log count
/// axis (the worst case is one tick), then against the period and the CPU budgets; a
/// device that measures none gets a note, not an empty axis.
fn exec_histogram(r: &RunReport) -> Figure {
    let t = &r.timing;
    let period_us = t.period_ns as f64 * 1e-3;
    let cpu = t.checks.iter().find(|c| c.name == "cpu_max");
    let budgets = |mut p: Plot| {
        p = p.vmark(
            period_us,
            &format!("period T = {} us", value_label(period_us)),
            EVENT_COLOUR,
        );
        if let Some(c) = cpu {
            for (what, f, colour) in [
                ("warn", c.limit.warn, "#E69F00"),
                ("fail", c.limit.fail, FAIL_COLOUR),
            ] {
                let label = format!("CPU {what} {:.0} % of T", f * 100.0);
                p = p.vmark(f * period_us, &label, colour);
            }
        }
        p
    };
    let what = if t.exec_ns.max <= 0.0 {
        "not measured".to_string()
    } else if t.exec_measured {
        let each = value_label(t.exec_ns_per_unit);
        format!("{} at {each} ns each", t.exec_unit)
    } else {
        format!("simulated by the device fault {}", r.device_fault)
    };
    let fig = Figure::new(&format!("Execution time per tick ({}: {what})", r.target));
    // In process (0 ns unless a device fault simulates it): the budgets and a note.
    if t.exec_ns.max <= 0.0 {
        return fig.panel(budgets(
            Plot::new("The period T and the CPU budget a measured tick is held to")
                .x_label("execution time (us)")
                .y_label("ticks")
                .size(860.0, 240.0)
                .x_range(0.0, period_us * 1.25)
                .y_range(0.0, 1.0)
                .note(
                    "not measured in process: --target qemu, xtask fw-bench or a board measure it",
                ),
        ));
    }
    let h = &t.exec_histogram;
    let edges_us: Vec<f64> = h.edges_ns.iter().map(|e| e * 1e-3).collect();
    let counts: Vec<f64> = h.counts.iter().map(|&c| c as f64).collect();
    let worst_us = t.exec_ns.max * 1e-3;
    let worst = format!(
        "worst {} us ({:.1} % of T)",
        value_label(worst_us),
        100.0 * worst_us / period_us
    );
    let top = counts.iter().fold(1.0f64, |a, &b| a.max(b)) * 2.0;
    let lo_us = edges_us.first().copied().unwrap_or(worst_us);
    let hist = |title: &str, x_label: &str| {
        let p = Plot::histogram(title, &edges_us, &counts);
        p.x_label(x_label)
            .y_label("ticks")
            .log_y()
            .y_range(0.5, top)
    };
    let dist = hist(
        "Distribution (log count: the worst tick shows)",
        "execution time (us)",
    )
    .vmark(worst_us, &worst, FAIL_COLOUR);
    let budget = budgets(
        hist(
            "Against the period T and the CPU budget",
            "execution time (us, log axis)",
        )
        .log_x()
        .x_range(lo_us * 0.8, period_us * 1.25),
    );
    fig.panel(dist).panel(budget)
}

/// Writes `report.md` and its SVG plots into `dir`; returns the files written.
pub fn write_report(out: &RunOutcome, dir: &Path, command: &str) -> io::Result<Vec<PathBuf>> {
    write_files(
        dir,
        [
            ("trajectories.svg", trajectories(out).to_svg()),
            ("monitor.svg", monitor(out).to_svg()),
            ("exec_histogram.svg", exec_histogram(&out.report).to_svg()),
            ("report.md", markdown(out, command)),
        ],
    )
}

/// Writes each `(name, text)` into `dir` (created); returns the files written.
pub(crate) fn write_files<'a>(
    dir: &Path,
    files: impl IntoIterator<Item = (&'a str, String)>,
) -> io::Result<Vec<PathBuf>> {
    std::fs::create_dir_all(dir)?;
    files
        .into_iter()
        .map(|(name, text)| {
            let p = dir.join(name);
            std::fs::write(&p, text).map(|()| p)
        })
        .collect()
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
    let mut tb = Table::new(["", ""]);
    let faults = if r.faults.is_empty() {
        "none"
    } else {
        &r.faults
    };
    for (k, v) in [
        ("verdict", format!("**{}**", r.verdict)),
        ("target", format!("{} ({} clock)", r.target, t.clock)),
        (
            "scenario",
            format!("{} ({})", r.scenario, r.scenario_source),
        ),
        ("control", crate::run::law_words(r.control).to_string()),
        ("link faults", faults.to_string()),
        ("device fault", r.device_fault.to_string()),
    ] {
        tb.row([k.to_string(), v]);
    }
    let mut s = format!(
        "# HIL run: {} on {} ({})\n\nReproduce: `{command}`\n\n{tb}\n## Timing ({})\n\n\
         Period T = {} ns, {} periods, {} baud.\n\n",
        r.scenario, r.target, r.verdict, t.verdict, t.period_ns, t.periods, t.baud
    );
    if !t.exec_measured {
        let _ = writeln!(s, "Execution time {}.\n", t.exec_note);
    }
    let shown = t.exec_measured || t.exec_units.max > 0.0;
    let e = &t.exec_units;
    let exec =
        [e.min, e.mean, e.p99, e.max].map(|v| if shown { f(v) } else { "not measured".into() });
    let l = &t.latency_ns;
    let modelled = if t.latency_modelled { ", modelled" } else { "" };
    let mut tb = Table::new(["figure", "min", "mean", "p99", "max"]);
    tb.row(std::iter::once(format!("execution time ({})", t.exec_unit)).chain(exec))
        .row(
            std::iter::once(format!("latency (ns{modelled})"))
                .chain([l.min, l.mean, l.p99, l.max].map(f)),
        );
    let _ = writeln!(
        s,
        "{tb}\nJitter max {} ns (RMS {} ns); missed ticks {}; device tick gaps {}; overruns {}; \
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
    let n = &r.numerics;
    let _ = writeln!(
        s,
        "{tb}\n![execution time](exec_histogram.svg)\n\n## Numerics ({})\n\nAgainst the {}.\n",
        n.verdict, n.reference
    );
    for (t, what, why) in [
        (n.run_diverged_at_s, "closed loop", "run stopped"),
        (n.reference_diverged_at_s, "reference", "no yardstick"),
    ] {
        if let Some(t) = t {
            let _ = writeln!(s, "**The {what} diverged at {t:.3} s** ({why}).\n");
        }
    }
    let mut tb =
        Table::new("signal,max error,at t (s),RMS error,reference peak,allowed,verdict".split(','));
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
    let m = &r.monitor;
    let alarms: Vec<String> = m
        .alarms
        .iter()
        .map(|a| format!("{} at {:.3} s", a.kind, a.t_s))
        .collect();
    let _ = writeln!(
        s,
        "{tb}\n![trajectories](trajectories.svg)\n\n## Stability monitor ({})\n\n\
         Alarms ({}): {}. Expected: {}.{}\n\n![stability monitor](monitor.svg)\n",
        m.verdict,
        m.source,
        if alarms.is_empty() {
            "none".to_string()
        } else {
            alarms.join(", ")
        },
        m.expectation(),
        if m.reason.is_empty() {
            String::new()
        } else {
            format!(" **{}**.", m.reason)
        }
    );
    let fr = &r.frames;
    let mut tb = Table::new("direction,sent,received,rejected,dropped,in flight".split(','));
    for (name, d) in [
        ("host -> device", fr.up),
        ("device -> host", fr.down),
        ("total", fr.total),
    ] {
        tb.row(std::iter::once(name.to_string()).chain(d.counts().map(|v| v.to_string())));
    }
    let _ = write!(
        s,
        "## Frames ({}; source: {})\n\n{tb}",
        r.frames_verdict, fr.source
    );
    if r.device_resets > 0 {
        let _ = writeln!(
            s,
            "\nDevice resets seen by the host: {} (the first at {:.3} s; the Config went out \
             again after each).",
            r.device_resets,
            r.first_reset_s.unwrap_or(f64::NAN)
        );
    }
    if let Some(st) = &r.device_status {
        let _ = writeln!(
            s,
            "\nDevice counters: ticks {}, rx ok {}, seq gaps {}, held ticks {}, safe ticks {} \
             (entries {}, exits {}), yaw saturated {}, traction saturated {}, inputs clamped {}, \
             stack peak {} B; boot {} (last reset: {}){}.",
            st.ticks,
            st.rx_ok,
            st.seq_gaps,
            st.held_ticks,
            st.safe_ticks,
            st.safe_entries,
            st.safe_exits,
            st.yaw_sat,
            st.traction_sat,
            st.input_clamped,
            st.stack_peak,
            st.boot_count,
            reset_cause_name(st.reset_cause),
            if st.flags.has(wheelset_proto::Flags::FAULT_LATCHED) {
                ", fault latched"
            } else {
                ""
            }
        );
    }
    s
}

/// The name of a [`wheelset_proto::reset_cause`] code, as the report prints it.
pub fn reset_cause_name(code: u8) -> &'static str {
    use wheelset_proto::reset_cause as rc;
    match code {
        rc::POWER_ON => "power-on",
        rc::PIN => "reset pin",
        rc::WATCHDOG => "watchdog",
        rc::SOFTWARE => "software",
        rc::FAULT => "fault",
        _ => "unknown",
    }
}

#[cfg(test)]
mod tests {
    use super::reset_cause_name;
    use wheelset_proto::reset_cause as rc;

    #[test]
    fn every_reset_cause_has_its_own_name_and_other_codes_are_unknown() {
        let codes = [
            rc::UNKNOWN,
            rc::POWER_ON,
            rc::PIN,
            rc::WATCHDOG,
            rc::SOFTWARE,
            rc::FAULT,
        ];
        let names: std::collections::BTreeSet<_> =
            codes.iter().map(|&c| reset_cause_name(c)).collect();
        assert_eq!(names.len(), codes.len());
        assert_eq!(reset_cause_name(rc::WATCHDOG), "watchdog");
        assert_eq!(reset_cause_name(200), "unknown");
    }
}
