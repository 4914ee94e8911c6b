//! `hil run`: one closed loop of the plant with the device on a target, checked.
//!
//! The plant is `run_sampled` with the device as its controller ([`wheelset_loop::exchange`]);
//! the reference `run_continuous` with the same scenario and law (with `[[adhesion]]`:
//! the f64 control core, `wheelset_loop::core`). The parameters are
//! [`RunOptions::params`] with the scenario's `[params]` on top; the device's configuration
//! follows them ([`runtime_config`], as `sim-host run --loop device`; a device elsewhere
//! refuses those that change its gains: [`remote_gains`]).

use std::borrow::Cow;
use std::fmt;
use std::time::Duration;

use indicatif::{ProgressBar, ProgressStyle};
use serde::Serialize;
use wheelset_loop::device_loop::{runtime_config, DeviceOptions};
use wheelset_loop::sim_link::LinkConfig;
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::Trajectory;
use wheelset_proto::Status;
use wheelset_runtime::RuntimeConfig;

use crate::budget::Budgets;
use crate::check::frames::FramesReport;
use crate::check::numerics::{compare_fine, JudgedErrors, NumericsReport};
use crate::check::timing::{analyse, TimingContext, TimingReport};
use wheelset_loop::exchange::{close_loop, LoopSetup};
use wheelset_loop::inproc::DeviceFault;
use wheelset_loop::transport::{Transport, TransportError};
use wheelset_report::Verdict;
use wheelset_targets::realtime::os::{self, Want};
use wheelset_targets::realtime::RealTime;
use wheelset_targets::serial::Pace;

mod open;
mod reference;

pub use open::{device_config, open_transport, remote_gains, DEVICE_KEYS};
use open::{open_qemu_free, open_realtime, run_rate};
use reference::before;

/// Default core clock of the device, Hz: the Nucleo-F446RE build's SYSCLK. A board's
/// `exec` is in cycles of it; the QEMU target's instructions count one cycle each (an
/// estimate: wait states and multi-cycle instructions make the board slower).
pub const DEFAULT_CPU_HZ: f64 = 168e6;

/// Where the device runs.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Target {
    /// In process, over the simulated link.
    InProc,
    /// The firmware under QEMU (mps2-an386), lock-step.
    Qemu,
    /// The firmware under a QEMU started by hand, its UART0 a TCP server on
    /// `127.0.0.1:PORT` (`qemu:PORT`; `cargo xtask qemu-cmd ELF --tcp PORT` prints the
    /// command line), lock-step. The harness connects and leaves QEMU running.
    QemuAt(u16),
    /// The free-running firmware under QEMU (`qemu-free`, `wheelset-qemu-free.elf`) on its
    /// own TIMER0, QEMU's clock following the host's (no `-icount`), paced in real time over
    /// UART0 as a serial board ([`wheelset_targets::realtime`]), at [`QEMU_FREE_RATE_HZ`].
    QemuFree,
    /// A board on a serial port.
    Serial(String),
}

/// The default (and highest) base rate of `--target qemu-free`: what QEMU's CMSDK UART
/// over a TCP chardev carries in real time (the `free-run` build's `LINK_MAX_RATE_HZ`).
pub const QEMU_FREE_RATE_HZ: u32 = 500;

/// The line rate the link check and the timing model assume for `--target qemu-free`
/// (QEMU does not time the UART's bytes): about the byte rate of its slow direction,
/// host -> device, one byte per round trip between QEMU's threads, times 10 bits.
pub const QEMU_FREE_BAUD: u32 = 460_800;

impl std::str::FromStr for Target {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "inproc" => Ok(Self::InProc),
            "qemu" => Ok(Self::Qemu),
            "qemu-free" => Ok(Self::QemuFree),
            _ => match (s.strip_prefix("qemu:"), s.strip_prefix("serial:")) {
                (Some(port), _) => port
                    .parse::<u16>()
                    .ok()
                    .filter(|&p| p > 0)
                    .map(Self::QemuAt)
                    .ok_or_else(|| format!("target `{s}`: `{port}` is not a TCP port (1-65535)")),
                (_, Some(p)) if !p.is_empty() => Ok(Self::Serial(p.to_string())),
                _ => Err(format!(
                    "unknown target `{s}` (expected inproc, qemu, qemu:PORT, qemu-free or serial:PATH)"
                )),
            },
        }
    }
}

impl fmt::Display for Target {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InProc => f.write_str("inproc"),
            Self::Qemu => f.write_str("qemu"),
            Self::QemuAt(port) => write!(f, "qemu:{port}"),
            Self::QemuFree => f.write_str("qemu-free"),
            Self::Serial(p) => write!(f, "serial:{p}"),
        }
    }
}

/// The yaw law of the device (and of the reference).
pub use wheelset_plant::control::YawLaw as Law;

/// The law in an engineer's words: `phase lead`, `pure gain`, `passive yaw spring`.
#[must_use]
pub fn law_words(law: Law) -> &'static str {
    match law {
        Law::Passive => "passive yaw spring",
        Law::Gain => "pure gain",
        Law::Lead => "phase lead",
    }
}

/// Everything a run needs.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// Target.
    pub target: Target,
    /// Built-in scenario name or a scenario file.
    pub scenario: String,
    /// Yaw law.
    pub control: Law,
    /// The text of `--faults`, for the report.
    pub faults_spec: String,
    /// A deliberately broken device (in process only).
    pub device_fault: DeviceFault,
    /// Budgets.
    pub budgets: Budgets,
    /// Link: baud, latency, faults and seed (faults only on the simulated link; the
    /// baud also for the other targets' link utilisation).
    pub link: LinkConfig,
    /// Pacing of the serial target.
    pub pace: Pace,
    /// Core clock of a board, Hz: converts its `exec` cycles to ns (serial target).
    pub cpu_hz: f64,
    /// Longest wait for a lock-step answer.
    pub timeout: Duration,
    /// The emulated board of the QEMU target (`--machine`).
    pub machine: wheelset_targets::qemu::machine::Machine,
    /// The QEMU target's link (`--qemu-link`).
    pub qemu_link: wheelset_targets::qemu::Channel,
    /// Show a progress bar.
    pub progress: bool,
    /// Base rate of the device, Hz (`--rate-hz`; None: the control core's default).
    pub rate_hz: Option<u32>,
    /// Ticks from a sample to its actuation (`--delay-ticks`; 1: lock-step).
    pub delay_ticks: u8,
    /// What the real-time loop asks of the operating system (real-time pacing).
    pub realtime: Want,
    /// The base parameters (`--params FILE`; default: the paper's), under the scenario's.
    pub params: Params,
    /// Wheel-slip protection of the device (`--wsp on|off`, sent as `Config.wsp`; default
    /// on: every firmware build has the protection).
    pub wsp: bool,
    /// An alarm holds the safe state until `ClearFaults` (`--monitor-safe`, `Config.monitor_safe`).
    pub monitor_safe: bool,
    /// Send `Command::ClearFaults` at this time, s (`--clear-faults-at T`).
    pub clear_faults_at_s: Option<f64>,
}

impl Default for RunOptions {
    fn default() -> Self {
        Self {
            target: Target::InProc,
            scenario: "curve".into(),
            control: Law::Lead,
            faults_spec: String::new(),
            device_fault: DeviceFault::None,
            budgets: Budgets::default(),
            link: LinkConfig::default(),
            pace: Pace::RealTime,
            cpu_hz: DEFAULT_CPU_HZ,
            timeout: Duration::from_secs(5),
            machine: wheelset_targets::qemu::machine::Machine::default(),
            qemu_link: wheelset_targets::qemu::Channel::Uart,
            progress: false,
            rate_hz: None,
            delay_ticks: 1,
            realtime: Want::all(os::allowed_cpus().last().copied()),
            params: Params::default(),
            wsp: true,
            monitor_safe: false,
            clear_faults_at_s: None,
        }
    }
}

/// Why a run could not be made (as opposed to a run that fails its checks).
#[derive(Debug)]
pub enum RunError {
    /// Bad input: scenario file, configuration, budget (exit code 2).
    Input(String),
    /// The target could not be used (exit code 3).
    Target(TransportError),
}

impl fmt::Display for RunError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Input(m) => f.write_str(m),
            Self::Target(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for RunError {}

/// The verdict document (`--json`).
#[derive(Debug, Clone, Serialize)]
pub struct RunReport {
    /// Worst of timing, numerics and frames.
    pub verdict: Verdict,
    /// Target.
    pub target: String,
    /// Scenario name.
    pub scenario: String,
    /// Scenario source.
    pub scenario_source: String,
    /// Yaw law.
    pub control: Law,
    /// `--faults` as given.
    pub faults: String,
    /// The deliberately broken device, in its `--device-fault` form (`none`, `slow:300`).
    pub device_fault: String,
    /// Timing.
    pub timing: TimingReport,
    /// Numerics.
    pub numerics: NumericsReport,
    /// Frame accounting.
    pub frames: FramesReport,
    /// Verdict of the frame accounting ([`crate::budget::FrameBudgets`]).
    pub frames_verdict: Verdict,
    /// The device's counters (its Status frame), if it arrived.
    pub device_status: Option<Status>,
    /// Resets of the device the host saw (`DeviceController::device_resets`); the Status
    /// above is then the last boot's.
    pub device_resets: u32,
    /// When the first reset was seen, s of the run.
    pub first_reset_s: Option<f64>,
    /// Host-side values clamped while quantising to the wire.
    pub host_clamped: u64,
    /// Transport-specific figures (informative; e.g. the host's time per tick in process).
    pub transport: Option<serde_json::Value>,
    /// The stability monitor's and actuator check's alarms, checked ([`crate::check::alarms`]).
    pub monitor: crate::check::alarms::MonitorReport,
    /// The parameters the run applied ([`RunOptions::params`]).
    pub params: Params,
}

/// A finished run: the report and both trajectories.
pub struct RunOutcome {
    /// The checks.
    pub report: RunReport,
    /// The closed loop through the device.
    pub trajectory: Trajectory,
    /// The f64 continuous reference.
    pub reference: Trajectory,
    /// The sensor samples the device received (wire codes), one per period from t = 0.
    pub sensor_codes: Vec<wheelset_control::InputCodes>,
    /// The control period, ns.
    pub period_ns: u64,
    /// The monitor's mean square `(t_s, (m/s)^2)` at each of its steps.
    pub monitor_ms: Vec<(f64, f64)>,
    /// The errors the numerics judged.
    pub numerics_errors: JudgedErrors,
    /// The device's configuration as applied (from the parameters, the law and the rate).
    pub runtime: RuntimeConfig,
}

/// Runs the closed loop and the checks.
pub fn run(opts: &RunOptions) -> Result<RunOutcome, RunError> {
    let sc =
        Scenario::load(&opts.scenario, &opts.params).map_err(|e| RunError::Input(e.to_string()))?;
    if opts.target != Target::InProc {
        remote_gains(&sc.params, &opts.target)?;
    }
    let mut rt = runtime_config(&sc, opts.control, &DeviceOptions::default());
    let default = rt.control;
    let hz = run_rate(opts, rt.control.base_rate_hz)?;
    // The gains designed for the rate and delay (a point without a design is refused below).
    let d = opts.delay_ticks.max(1);
    rt = rt.designed(hz, d).unwrap_or_else(|_| {
        let mut r = rt;
        r.control.base_rate_hz = hz;
        r.control.delay_ticks = d;
        r
    });
    if let Some(why) = wheelset_loop::device_loop::base_rate_refusal(&rt) {
        let delay = if d > 1 {
            format!(" --delay-ticks {d}")
        } else {
            String::new()
        };
        return Err(RunError::Input(format!(
            "--rate-hz {}{delay}: {why}",
            rt.control.base_rate_hz
        )));
    }
    let period_ns = 1_000_000_000 / u64::from(rt.control.base_rate_hz.max(1));
    // A free-running device is held concretely: its start-up baseline is needed after.
    let mut realtime = match &opts.target {
        Target::Serial(p) if opts.pace == Pace::RealTime => Some(open_realtime(p, opts, &rt)?),
        Target::QemuFree => Some(open_qemu_free(opts, &rt)?),
        _ => None,
    };
    let is_lockstep_remote = realtime.is_none() && opts.target != Target::InProc;
    let mut other: Box<dyn Transport>;
    let tr: &mut dyn Transport = match realtime.as_mut() {
        Some(r) => r,
        None => {
            other = open_transport(opts, rt)?;
            other.as_mut()
        }
    };
    let progress = opts.progress.then(|| {
        let style = ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} ms simulated");
        ProgressBar::new(sc.duration_ns / 1_000_000)
            .with_style(style.unwrap_or_else(|_| ProgressStyle::default_bar()))
            .with_message(format!("hil run {} {}", tr.name(), sc.name))
    });
    let ctx = TimingContext {
        clock: tr.clock(),
        period_ns,
        delay_ticks: u32::from(d),
        baud: tr.baud(),
        latency_ns: if opts.target == Target::InProc {
            opts.link.latency_ns
        } else {
            0
        },
        exec_unit: tr.exec_unit().0,
        exec_ns_per_unit: tr.exec_unit().1,
        exec_measured: opts.target != Target::InProc,
    };
    let target_name = tr.name();
    let label = format!("{} on {}", opts.control.name(), target_name);
    let wsp = opts.wsp;
    // A lock-step device gets the Config as the run's first frame (the others were
    // configured before), with the design's rates at another rate or delay than its own.
    let other_point = rt.control.base_rate_hz != default.base_rate_hz
        || rt.control.delay_ticks != default.delay_ticks;
    let lockstep_config = match (is_lockstep_remote, other_point) {
        (false, _) => None,
        (true, false) => Some(wheelset_loop::device_loop::run_config(
            &rt,
            wsp,
            opts.monitor_safe,
        )),
        (true, true) => Some(device_config(&rt, wsp, opts.monitor_safe)?),
    };
    // `--device-fault stall:T`: InjectStall at T to a device whose watchdog resets it (the
    // free-running QEMU build), the Config sent again after the reset.
    let stall_at_ns = match (opts.device_fault, &opts.target) {
        (DeviceFault::Stall { at_ns }, Target::QemuFree) => Some(at_ns),
        (DeviceFault::Stall { .. }, t) => {
            return Err(RunError::Input(format!(
                "--device-fault stall:T needs a device with a running watchdog: --target \
                 qemu-free (the free-running QEMU build), not {t}"
            )))
        }
        _ => None,
    };
    let reset_config = stall_at_ns
        .is_some()
        .then(|| wheelset_loop::device_loop::run_config(&rt, wsp, opts.monitor_safe));
    let clear_faults_at_ns = match opts.clear_faults_at_s {
        Some(t) if t.is_finite() && t >= 0.0 => Some((t * 1e9).round() as u64),
        Some(t) => {
            return Err(RunError::Input(format!(
                "--clear-faults-at {t}: must be a time of the run, s (>= 0)"
            )))
        }
        None => None,
    };
    let mut cl = close_loop(
        &sc,
        tr,
        LoopSetup {
            period_ns,
            yaw_spring: opts.control.has_spring(),
            progress,
            label: &label,
            config: lockstep_config,
            clear_faults_at_ns,
            stall_at_ns,
            reset_config,
            delay_ticks: u32::from(d),
            ..LoopSetup::default()
        },
    )
    .map_err(|e| RunError::Input(format!("scenario {}: {e}", sc.source)))?;
    os::release();
    if let Some(e) = cl.rec.error.take() {
        return Err(RunError::Target(e));
    }
    if let (true, Some(cfg)) = (cl.rec.config_refused, lockstep_config) {
        let why = cl
            .rec
            .status
            .as_ref()
            .and_then(|s| wheelset_proto::RefuseReason::from_code(s.refuse_reason))
            .unwrap_or(wheelset_proto::RefuseReason::None);
        return Err(RunError::Target(TransportError::Unavailable(
            wheelset_loop::device_loop::DeviceError::Refused(why, cfg).to_string(),
        )));
    }
    // At another rate or delay the yardstick is the f64 core with the gains designed for it.
    let designed = other_point.then_some(&rt.control);
    let (reference, fine) = reference::make(&sc, opts.control, wsp, period_ns, designed)?;
    let timing = analyse(
        &ctx,
        &cl.rec.periods,
        &cl.rec.actuations,
        (cl.rec.host.bytes_sent, cl.rec.host.bytes_received),
        &opts.budgets.timing,
    );
    // After a plant fault the wheelset hunts by design: judged up to the fault.
    let trajectory = cl.trajectory;
    let (judged, yardstick, fine) = match sc.actuator_fault.map(|f| f.t_on_s()) {
        Some(t) => (
            Cow::Owned(before(&trajectory, t)),
            Cow::Owned(before(&reference, t)),
            fine.map(|r| before(&r, t)),
        ),
        None => (Cow::Borrowed(&trajectory), Cow::Borrowed(&reference), fine),
    };
    let tol = &opts.budgets.numerics;
    let (numerics, numerics_errors) = compare_fine(&judged, &yardstick, fine.as_ref(), tol);
    let (host, mut status) = (cl.rec.host, cl.rec.status);
    let sensor_codes = std::mem::take(&mut cl.rec.sent_codes);
    let transport = tr.extra();
    let link = tr.link_accounting();
    // A free-running device's counters count from its start, not the run's.
    let start = realtime.as_ref().and_then(RealTime::run_start);
    if let (Some(st), Some(s)) = (&start, status.as_mut()) {
        *s = st.relative(s);
    }
    let mut frames = match link {
        Some(l) => FramesReport::from_link(&l),
        None => FramesReport::from_status(status.as_ref(), &host),
    };
    frames.pre_run = start.map_or(0, |s| s.pre_run);
    let frames_verdict = crate::check::frames::judge(&frames, &opts.budgets.frames);
    let mon_params = wheelset_control::MonitorParams::default();
    let monitor_ms = crate::check::alarms::replay(&sensor_codes, period_ns, &rt, &mon_params)
        .unwrap_or_default();
    let flags = cl.rec.actuations.iter().map(|a| (a.at_ns, a.frame.flags));
    let mut monitor = crate::check::alarms::judge(
        &sc,
        opts.control,
        &trajectory,
        &mon_params,
        crate::check::alarms::alarms(flags),
    );
    // The Status's first alarm tick and its sample instant (ticks count from the run's
    // start; a lock-step device's Config frame was one tick before the first sample).
    let pre = u32::from(lockstep_config.is_some());
    monitor.device_first_alarm_tick = status
        .as_ref()
        .map(|s| s.first_alarm_tick)
        .filter(|&n| n > 0);
    monitor.device_first_alarm_s = monitor
        .device_first_alarm_tick
        .map(|n| f64::from(n.saturating_sub(1 + pre)) * period_ns as f64 * 1e-9);
    monitor.drive.device_first_alarm_tick = status
        .as_ref()
        .map(|s| s.first_drive_alarm_tick)
        .filter(|&n| n > 0);
    let end_s = trajectory.records.last().map_or(0.0, |x| x.t_s);
    // The loop's delay: the latency's p99 in whole periods, at least the host's delay.
    let delay = (timing.latency_ns.p99 / period_ns as f64).ceil();
    let delay_ticks = if delay.is_finite() && delay > 1.0 {
        (delay as usize).min(wheelset_plant::sampled::MAX_HYPER_PERIOD)
    } else {
        1
    }
    .max(usize::from(d));
    crate::check::alarms::judge_drive(
        &mut monitor,
        crate::check::alarms::drive_expectation(&sc, &rt, &mon_params, delay_ticks),
        end_s,
    );
    let verdict = timing
        .verdict
        .max(numerics.verdict)
        .max(frames_verdict)
        .max(monitor.verdict);
    Ok(RunOutcome {
        report: RunReport {
            verdict,
            target: target_name,
            scenario: sc.name.clone(),
            scenario_source: sc.source.clone(),
            control: opts.control,
            faults: opts.faults_spec.clone(),
            device_fault: opts.device_fault.to_string(),
            timing,
            numerics,
            frames,
            frames_verdict,
            device_status: status,
            device_resets: cl.rec.device_resets,
            first_reset_s: cl.rec.first_reset_ns.map(|t| t as f64 * 1e-9),
            host_clamped: host.clamped,
            transport,
            monitor,
            params: sc.params.clone(),
        },
        trajectory,
        reference,
        sensor_codes,
        period_ns,
        monitor_ms,
        numerics_errors,
        runtime: rt,
    })
}
