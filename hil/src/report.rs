//! Outputs of a run: the verdict JSON (`--json`), the trajectory CSV (`--csv`, the
//! columns of `sim-host`'s run CSV), and a Markdown report with SVG plots (`--report
//! DIR`: `report.md`, `trajectories.svg`, `exec_histogram.svg`); the campaign report of
//! `hil sweep` (`report/sweep.rs`).

use std::fmt::Write as _;
use std::io;
use std::path::{Path, PathBuf};

use sim_host::sim::{Record, Trajectory};
use sim_host::svg::{Figure, Plot, Series, Style};

use crate::run::{RunOutcome, RunReport};

mod sweep;
use crate::table::Table;
pub use sweep::{sweep_markdown, value_label, write_sweep_report};

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
            format!("{} ({} clock)", r.target, t.clock),
        ])
        .row([
            "scenario".to_string(),
            format!("{} ({})", r.scenario, r.scenario_source),
        ])
        .row(["control".to_string(), r.control.words().to_string()])
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
