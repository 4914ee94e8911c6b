//! `hil run`: the closed loop of a scenario with the device on a target, its arguments
//! and the summary it prints.

use std::io::IsTerminal;
use std::path::PathBuf;

use clap::{Args, ValueEnum};
use hil::budget::Budgets;
use hil::report;
use hil::run::{run, RunOptions, Target};
use serde::Deserialize as _;
use wheelset_loop::inproc::DeviceFault;
use wheelset_loop::sim_link::{Faults, LinkConfig};
use wheelset_plant::params::Params;
use wheelset_report::Verdict;
use wheelset_targets::qemu::machine::Machine;
use wheelset_targets::realtime::os::{self, Want};

use super::{input, load_params, run_error, written, Control, Failure};

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum PaceArg {
    /// Wall-clock periods.
    Realtime,
    /// Wait for each answer.
    Lockstep,
}

#[derive(Args, Clone)]
pub(crate) struct RunArgs {
    /// Where the device runs: inproc, qemu, qemu:PORT, qemu-free (the free-running
    /// firmware under QEMU without -icount, paced in real time) or serial:PATH.
    #[arg(long, default_value = "inproc")]
    target: Target,
    /// The QEMU target's emulated board: mps2-an386 (Cortex-M4F) or mps2-an385
    /// (Cortex-M3, no FPU; `target/fw/wheelset-qemu-m3.elf`).
    #[arg(long, default_value = "mps2-an386")]
    machine: Machine,
    /// The QEMU target's link: `uart` (UART0 over TCP, byte by byte through the emulated
    /// UART: the faithful path) or `bulk` (semihosting file I/O on two FIFOs, one trap
    /// per frame: the same frames bit for bit, about ten times faster).
    #[arg(long, default_value = "uart", value_parser = parse_channel)]
    qemu_link: wheelset_targets::qemu::Channel,
    /// Built-in scenario (curve, beating, low-adhesion, actuator-fault) or a scenario TOML
    /// file.
    #[arg(long, default_value = "curve")]
    scenario: String,
    /// Parameter file (TOML, any subset of the parameters, as `sim-host --params`); the
    /// scenario's [params] apply on top. The plant, the reference and the device's
    /// configuration follow the result.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Yaw control law of the device (and of the reference).
    #[arg(long, value_enum, default_value = "lead")]
    control: Control,
    /// Link faults, e.g. `ber=1e-4,drop=0.01,outage=8:0.05` (simulated link only).
    #[arg(long, default_value = "")]
    faults: Faults,
    /// Write the verdict document (JSON).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write the closed-loop trajectory (sim-host's CSV columns).
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Write a Markdown report with SVG plots into this directory.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Budget file (TOML; see `hil::budget` for the keys and defaults).
    #[arg(long)]
    budget: Option<PathBuf>,
    /// Override one budget, e.g. `--set timing.cpu_max.fail=0.5` (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// A deliberately broken in-process device: wrong-sign, slow[:EXEC_US], jitter[:MAX_US],
    /// corrupt[:EVERY]; or stall:T (s) for --target qemu-free: the harness sends
    /// InjectStall at T, the firmware's watchdog resets the device, the host sends its
    /// Config again (the new boot drives the safe outputs until a ClearFaults, which
    /// `--clear-faults-at` sends).
    #[arg(long, default_value = "none")]
    device_fault: DeviceFault,
    /// Link baud (10 bits per byte).
    #[arg(long, default_value_t = wheelset_loop::sim_link::DEFAULT_BAUD, allow_negative_numbers = true)]
    baud: u32,
    /// Seed of the simulated link's faults.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    seed: u64,
    /// Serial target pacing: realtime (a board on its own timer) or lockstep (a
    /// frame-clocked device answering each frame).
    #[arg(long, value_enum, default_value = "realtime")]
    pace: PaceArg,
    /// Core clock of the board, Hz (converts its cycle counts to time).
    #[arg(long, default_value_t = hil::run::DEFAULT_CPU_HZ, allow_negative_numbers = true)]
    cpu_hz: f64,
    /// Base rate of the device, Hz (default: the control core's 5000). In process the
    /// device is built at it; a free-running serial device is configured over the wire
    /// (rates and coefficients from `wheelset_runtime::rates_for`). The link is checked
    /// against it before the run.
    #[arg(long)]
    rate_hz: Option<u32>,
    /// Ticks from a sample to its actuation, 1 to the longest designed [default: 1]: the
    /// host pipelines the exchange and applies each actuation that many periods after its
    /// sample (a link whose round trip is longer than a period); the device runs the
    /// gains designed for the rate and this delay.
    #[arg(long, allow_negative_numbers = true)]
    delay_ticks: Option<u8>,
    /// One-way latency of the simulated link (in process), us, in [0, 1e6] [default: 2].
    #[arg(long, allow_negative_numbers = true)]
    latency_us: Option<f64>,
    /// Real-time pacing: pin the harness's loop to this CPU (default: the last one
    /// allowed).
    #[arg(long)]
    rt_cpu: Option<usize>,
    /// Real-time pacing: do not ask for SCHED_FIFO, locked memory or a pinned core.
    #[arg(long)]
    no_rt: bool,
    /// Never show the progress bar.
    #[arg(long)]
    quiet: bool,
    /// Wheel-slip protection of the device, sent as `Config.wsp` before the run
    /// [default: on].
    #[arg(long, value_enum)]
    wsp: Option<OnOffArg>,
    /// A stability alarm holds the device's safe state until `ClearFaults`
    /// (`Config.monitor_safe`; default: the alarm is only reported).
    #[arg(long)]
    monitor_safe: bool,
    /// Send `Command::ClearFaults` (clears FAULT_LATCHED and a held alarm safe state) at
    /// this time of the run, s.
    #[arg(long, value_name = "T_S")]
    clear_faults_at: Option<f64>,
}

/// `--wsp` values.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq)]
pub(crate) enum OnOffArg {
    /// On.
    On,
    /// Off.
    Off,
}

pub(crate) fn parse_channel(s: &str) -> Result<wheelset_targets::qemu::Channel, String> {
    match s {
        "uart" => Ok(wheelset_targets::qemu::Channel::Uart),
        "bulk" => Ok(wheelset_targets::qemu::Channel::Bulk),
        _ => Err(format!("unknown QEMU link `{s}` (expected uart or bulk)")),
    }
}

pub(crate) fn cmd_run(a: &RunArgs, command: &str) -> Result<Verdict, Failure> {
    let budgets = Budgets::load(a.budget.as_deref(), &a.sets).map_err(input)?;
    let params = load_params(a.params.as_deref())?;
    if a.baud == 0 {
        return Err(input("--baud: must be positive"));
    }
    if !(a.cpu_hz.is_finite() && a.cpu_hz > 0.0) {
        return Err(input(format!(
            "--cpu-hz {}: must be a positive number",
            a.cpu_hz
        )));
    }
    let law = a.control.law_for(&a.scenario, &params);
    if a.target != Target::Qemu && a.machine != Machine::default() {
        return Err(input(format!(
            "--machine {}: the emulated board is for --target qemu, not {}",
            a.machine, a.target
        )));
    }
    super::check_link_flags(&a.target, a.qemu_link, &a.faults)?;
    if a.target != Target::InProc
        && a.device_fault != DeviceFault::None
        && !(a.target == Target::QemuFree && matches!(a.device_fault, DeviceFault::Stall { .. }))
    {
        return Err(input(format!(
            "--device-fault: only the in-process device can be broken on purpose (and \
             `stall:T` needs --target qemu-free), not {}",
            a.target
        )));
    }
    let latency_us = a.latency_us.unwrap_or(2.0);
    if !(latency_us.is_finite() && (0.0..=1e6).contains(&latency_us)) {
        return Err(input(format!(
            "--latency-us {latency_us:e}: must be a finite value in [0, 1e6] us"
        )));
    }
    if a.latency_us.is_some() && a.target != Target::InProc {
        return Err(input(format!(
            "--latency-us: the latency is part of the simulated link; target {} has a real one",
            a.target
        )));
    }
    let max_delay = wheelset_control::design::DESIGNED
        .iter()
        .map(|p| p.delay_ticks)
        .max()
        .unwrap_or(1);
    if let Some(d) = a.delay_ticks.filter(|d| !(1..=max_delay).contains(d)) {
        return Err(input(format!(
            "--delay-ticks {d}: must be 1 ..= {max_delay} (the delays the device's gains are \
             designed for)"
        )));
    }
    // The outputs are checked before the run, not found unwritable after it.
    for (flag, p) in [("--json", &a.json), ("--csv", &a.csv)] {
        if let Some(p) = p {
            wheelset_report::output::check_file_flag(flag, p).map_err(input)?;
        }
    }
    if let Some(d) = &a.report {
        wheelset_report::output::check_dir_flag("--report", d).map_err(input)?;
    }
    let opts = RunOptions {
        target: a.target.clone(),
        scenario: a.scenario.clone(),
        control: law,
        // The faults as applied (canonical spec), whichever form the flag took.
        faults_spec: a.faults.to_string(),
        device_fault: a.device_fault,
        budgets,
        link: LinkConfig {
            baud: a.baud,
            faults: a.faults.clone(),
            seed: a.seed,
            latency_ns: (latency_us * 1e3).round() as u64,
        },
        pace: match a.pace {
            PaceArg::Realtime => wheelset_targets::serial::Pace::RealTime,
            PaceArg::Lockstep => wheelset_targets::serial::Pace::LockStep,
        },
        cpu_hz: a.cpu_hz,
        timeout: std::time::Duration::from_secs(5),
        machine: a.machine,
        qemu_link: a.qemu_link,
        progress: !a.quiet && std::io::stderr().is_terminal(),
        rate_hz: a.rate_hz,
        delay_ticks: a.delay_ticks.unwrap_or(1),
        wsp: a.wsp != Some(OnOffArg::Off),
        monitor_safe: a.monitor_safe,
        clear_faults_at_s: a.clear_faults_at,
        realtime: if a.no_rt {
            Want::none()
        } else {
            Want::all(a.rt_cpu.or_else(|| os::allowed_cpus().last().copied()))
        },
        params,
    };
    let out = run(&opts).map_err(run_error)?;
    print_summary(&out.report);
    if let Some(p) = &a.json {
        written(p, report::write_json(&out.report, p))?;
        say!("json: {}", p.display());
    }
    if let Some(p) = &a.csv {
        written(p, report::write_csv(&out.trajectory, p))?;
        say!(
            "csv: {} ({} rows)",
            p.display(),
            out.trajectory.records.len()
        );
    }
    if let Some(d) = &a.report {
        for f in written(d, report::write_report(&out, d, command))? {
            say!("report: {}", f.display());
        }
    }
    Ok(out.report.verdict)
}

pub(crate) fn print_summary(r: &hil::run::RunReport) {
    let t = &r.timing;
    say!(
        "hil run: target {}, scenario {} ({}), control: {}, {} periods of {} ns",
        r.target,
        r.scenario,
        r.scenario_source,
        hil::run::law_words(r.control),
        t.periods,
        t.period_ns
    );
    let exec = if t.exec_measured || t.exec_units.max > 0.0 {
        format!(
            "exec {:.0}/{:.0}/{:.0} {} (min/mean/max)",
            t.exec_units.min, t.exec_units.mean, t.exec_units.max, t.exec_unit
        )
    } else {
        "exec not measured in process (real figures: --target qemu, cargo xtask fw-bench, a board)"
            .to_string()
    };
    say!(
        "timing {}: {exec}, latency max {:.1} us{}, jitter max {}, \
         missed {}, overruns {}, CPU max {:.2} %, link {:.1} %",
        t.verdict,
        t.latency_ns.max * 1e-3,
        if t.latency_modelled {
            " (modelled)"
        } else {
            ""
        },
        t.jitter_max_ns
            .map_or("n/a".to_string(), |j| format!("{:.1} us", j * 1e-3)),
        t.missed_ticks,
        t.overruns,
        t.cpu_max * 100.0,
        t.link_utilisation * 100.0
    );
    for c in t.checks.iter().filter(|c| c.verdict != Verdict::Pass) {
        // What the value is a fraction of.
        let unit = match c.name.as_str() {
            "missed_frac" | "overrun_frac" => "of the periods",
            "link" => "of the link's capacity",
            _ => "of T",
        };
        say!(
            "  timing.{}: {:.4} {} > {} {} (warn {}, fail {})",
            c.name,
            c.value,
            unit,
            c.verdict,
            c.limit.crossed(c.verdict),
            c.limit.warn,
            c.limit.fail
        );
    }
    say!(
        "numerics {} (vs {}):",
        r.numerics.verdict,
        r.numerics.reference
    );
    if let Some(t) = r.numerics.run_diverged_at_s {
        say!("  the closed loop DIVERGED at {t:.3} s (run stopped)");
    }
    if let Some(t) = r.numerics.reference_diverged_at_s {
        say!("  the f64 continuous reference DIVERGED at {t:.3} s (no yardstick)");
    }
    for s in &r.numerics.signals {
        say!(
            "  {:<10} max err {:.3e} (at {:.3} s) of allowed {:.3e}: {}",
            s.name,
            s.max_err,
            s.max_err_t_s,
            s.allowed,
            s.verdict
        );
    }
    let f = &r.frames;
    say!(
        "frames {} ({}): {}{}",
        r.frames_verdict,
        f.source,
        f.total,
        if f.pre_run > 0 {
            format!("; {} frames before the run discarded (pre_run)", f.pre_run)
        } else {
            String::new()
        }
    );
    for (name, d) in [("host -> device", &f.up), ("device -> host", &f.down)] {
        say!("  {name}: {d}");
    }
    let transport = r.transport.as_ref();
    if let Some(h) = transport.and_then(|t| t.get("host")) {
        let obtained = transport
            .and_then(|t| t.get("realtime"))
            .and_then(|v| wheelset_targets::realtime::os::Obtained::deserialize(v).ok());
        say!(
            "host (real time): missed {} of {} deadlines ({} late sends, {} late receives), \
             send lateness p99 {:.1} us; obtained {}",
            h["missed_deadlines"],
            h["periods"],
            h["late_sends"],
            h["late_receives"],
            h["send_lateness_ns"]["p99"].as_f64().unwrap_or(0.0) * 1e-3,
            obtained.map_or_else(|| "nothing reported".to_string(), |o| o.to_string())
        );
    }
    let default = Params::default().entries();
    let changed: Vec<String> = r
        .params
        .entries()
        .iter()
        .zip(&default)
        .filter(|((_, a), (_, b))| a != b)
        .map(|((k, a), _)| format!("{k} = {}", hil::sweep::document::value_label(*a)))
        .collect();
    if !changed.is_empty() {
        say!("parameters (the paper's but): {}", changed.join(", "));
    }
    say!("verdict: {}", r.verdict);
    let m = &r.monitor;
    say!(
        "  monitor ({}): {} alarm(s){}; yaw: expected {}: {}{}",
        m.source,
        m.alarms.len(),
        m.alarms.first().map_or(String::new(), |a| format!(
            ", first at {:.3} s ({})",
            a.t_s,
            alarm_name(a.kind)
        )),
        m.expectation(),
        m.verdict,
        if m.reason.is_empty() {
            String::new()
        } else {
            format!(" ({})", m.reason)
        }
    );
    say!("  {}", drive_line(&m.drive));
}

/// What an alarm kind names, in the summary.
fn alarm_name(kind: &str) -> &'static str {
    match kind {
        "drive" => "the drive: the traction current loop oscillates",
        "actuator" => "the yaw actuator",
        "hunting" => "hunting",
        _ => "unknown",
    }
}

/// The drive check's line of the summary: the current loop's pair, what is due, what
/// came.
fn drive_line(d: &hil::check::alarms::DriveReport) -> String {
    let pair = match (d.current_radius, d.mode_hz) {
        (Some(r), Some(f)) => format!(
            "current loop radius {r:.3} per tick at {f:.0} Hz ({}, l_a = {:.3e} H, delay {} \
             tick(s))",
            if r >= 1.0 { "unstable" } else { "stable" },
            d.l_a_h,
            d.delay_ticks
        ),
        _ => "no current loop".to_string(),
    };
    let due = match (d.expect, d.deadline_s) {
        ("alarm", Some(t)) => format!("a drive alarm by {t:.3} s"),
        _ => "no drive alarm".to_string(),
    };
    let came = d
        .first_alarm_s
        .map_or("none".to_string(), |t| format!("at {t:.3} s"));
    format!("drive: {pair}; expected {due}; drive alarm {came}")
}
