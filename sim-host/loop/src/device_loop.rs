//! A device-in-the-loop run (`sim-host run --loop device`): the firmware's runtime as an
//! [`InProc`] transport closed with the plant ([`crate::exchange`]), and its deviation.

use std::fmt;

use wheelset_control::Fx;
use wheelset_proto::{Flags, Status};
use wheelset_runtime::{RuntimeConfig, RuntimeError};

pub use crate::exchange::{LinkSample, LINK_COLUMNS};
pub use crate::inproc::{DeviceFault, InProc};
pub use wheelset_proto::LateralSensing;

use crate::exchange::{close_loop, LoopRecords, LoopSetup, Records};
use crate::sim_link::{Accounting, LinkBudgetError, LinkConfig};
use crate::transport::LinkAccounting;
use wheelset_plant::control::YawLaw;
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::{Record, SimError, Trajectory};

// The plant's memory estimate of a device run counts one link record per period.
const _: () = assert!(
    std::mem::size_of::<LinkSample>() as u64 + 16
        == wheelset_plant::memory::DEVICE_BYTES_PER_PERIOD
);

/// Why the device loop cannot be built.
#[derive(Debug, Clone, PartialEq)]
pub enum DeviceError {
    /// The runtime refused its configuration.
    Runtime(RuntimeError),
    /// The link cannot carry one exchange per period.
    Budget(LinkBudgetError),
    /// The base rate does not give a whole number of nanoseconds.
    Rate(u32),
    /// The plant run refused the period (not a multiple of the integration step).
    Sim(SimError),
    /// The device refused the run's Config frame ([`run_config`]).
    Refused(wheelset_proto::RefuseReason, wheelset_proto::Config),
}

impl fmt::Display for DeviceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Runtime(e) => write!(f, "{e}"),
            Self::Budget(e) => write!(f, "{e}"),
            Self::Rate(hz) => write!(
                f,
                "device base rate {hz} Hz: the period must be a whole number of nanoseconds"
            ),
            Self::Sim(e) => write!(f, "device loop: {e}"),
            Self::Refused(why, c) => write!(
                f,
                "the device refused the run's Config (wsp {}, monitor_safe {}): {why}",
                on_off(c.wsp),
                on_off(c.monitor_safe),
            ),
        }
    }
}

impl std::error::Error for DeviceError {}

/// Why a device cannot run at the base rate of `rt`, in words about that rate (not the
/// refusing field, which the user never typed); `None` when it can.
#[must_use]
pub fn base_rate_refusal(rt: &RuntimeConfig) -> Option<String> {
    use wheelset_control::{design, ConfigError};
    let (hz, d) = (rt.control.base_rate_hz, rt.control.delay_ticks);
    let active = rt.control.yaw_mode != wheelset_control::YawMode::Passive;
    if let Some(p) = design::point(hz, d).filter(|p| active && !p.yaw) {
        return Some(format!(
            "the device refuses an active yaw law there: no lead or gain holds the yaw loop \
             at {} Hz with {} tick(s) of delay (only the traction loop is designed: run the \
             passive law, or a rate `sim-host rates` accepts)",
            p.base_rate_hz, p.delay_ticks
        ));
    }
    if design::point(hz, d).is_none() && rt.control.validate().is_ok() {
        let accepted: Vec<String> = design::DESIGNED
            .iter()
            .filter(|p| p.delay_ticks == d && (p.yaw || !active))
            .map(|p| p.base_rate_hz.to_string())
            .collect();
        return Some(format!(
            "the device refuses it: no gains are designed for {hz} Hz with {d} tick(s) of \
             delay (designed: {} Hz); `sim-host rates` names the criterion each refused rate \
             fails",
            accepted.join(", ")
        ));
    }
    let e = wheelset_runtime::RuntimeBits::try_new::<Fx>(rt).err()?;
    Some(match (e, rt.monitor) {
        (
            RuntimeError::Control(ConfigError::Range {
                field: "monitor.rate_hz",
                ..
            }),
            Some(m),
        ) => {
            format!(
                "the device's stability monitor steps at {} Hz, so the base rate must be at \
                 least {} Hz",
                m.rate_hz, m.rate_hz
            )
        }
        (e, _) => format!("the device cannot run at it: {e}"),
    })
}

/// End-of-run report: every frame accounted for, and the device's own counters.
#[derive(Debug, Clone)]
pub struct LinkReport {
    /// Host -> device.
    pub up: Accounting,
    /// Device -> host.
    pub down: Accounting,
    /// The device's counters from its Status frame after the run (None if every try was lost).
    pub device: Option<Status>,
    /// Periods in which the safe flag was set in the applied actuation.
    pub safe_periods: u64,
    /// Transitions into / out of the safe state seen by the host (from the flags).
    pub safe_entries_seen: u64,
    /// See `safe_entries_seen`.
    pub safe_exits_seen: u64,
    /// Inputs clamped while quantising for the wire (host side).
    pub host_clamped: u64,
    /// Mean wire bytes per period, up (sent by the host) and down (received by it).
    pub mean_bytes: (f64, f64),
}

impl LinkReport {
    fn of(rec: &LoopRecords, acc: LinkAccounting) -> Self {
        let mut safe_periods = 0;
        let (mut entries, mut exits) = (0, 0);
        let mut prev = false;
        for s in &rec.log {
            let safe = Flags(s.flags).has(Flags::SAFE);
            safe_periods += u64::from(safe);
            entries += u64::from(safe && !prev);
            exits += u64::from(!safe && prev);
            prev = safe;
        }
        let (n, host) = (rec.log.len().max(1) as f64, &rec.host);
        LinkReport {
            up: acc.up,
            down: acc.down,
            device: rec.status,
            safe_periods,
            safe_entries_seen: entries,
            safe_exits_seen: exits,
            host_clamped: host.clamped,
            mean_bytes: (host.bytes_sent as f64 / n, host.bytes_received as f64 / n),
        }
    }
}

impl fmt::Display for LinkReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "host -> device: {}", self.up)?;
        writeln!(f, "device -> host: {}", self.down)?;
        writeln!(
            f,
            "safe state as the host saw it (the SAFE flag of the actuation in force each \
             period): {} periods, entered {} x, left {} x (a safe state that ends before the \
             link recovers, as in an outage of both directions, is not seen here: the device's \
             own count is its status below); mean bytes per period: {:.1} up, {:.1} down; \
             host-side clamps: {}",
            self.safe_periods,
            self.safe_entries_seen,
            self.safe_exits_seen,
            self.mean_bytes.0,
            self.mean_bytes.1,
            self.host_clamped
        )?;
        match &self.device {
            Some(s) => {
                let [ok, crc, cobs, version, length, postcard, _] = crate::inproc::rx_counts(s);
                write!(
                    f,
                    "device status: ticks {}, rx ok {ok}, rejected crc {crc} cobs {cobs} \
                     version {version} length {length} postcard {postcard}, seq gaps {}, \
                     held ticks {}, safe ticks {}, safe entries {}, exits {}, yaw sat {}, \
                     traction sat {}",
                    s.ticks,
                    s.seq_gaps,
                    s.held_ticks,
                    s.safe_ticks,
                    s.safe_entries,
                    s.safe_exits,
                    s.yaw_sat,
                    s.traction_sat
                )
            }
            None => write!(f, "device status: the status frame was lost"),
        }
    }
}

/// The control core's configuration for a scenario's parameters and yaw `law`.
#[must_use]
pub fn control_config(p: &Params, law: YawLaw, drive: bool) -> wheelset_control::Config {
    let d = wheelset_control::Config::default();
    wheelset_control::Config {
        yaw_mode: law.into(),
        traction_enabled: drive,
        gain_k: p.k_active,
        lead: wheelset_control::LeadParams {
            k: p.k_active,
            a: p.lead_gain,
            w1: p.lead_zero,
            w2: p.lead_pole,
            ..d.lead
        },
        pi: wheelset_control::PiParams {
            kp: p.pi_kp,
            ti: p.pi_ti,
        },
        motor: wheelset_control::Motor {
            k_m: p.k_m,
            n: p.n_gear,
        },
        ..d
    }
}

/// The firmware's default configuration with the gains and motor constants of `p`
/// ([`control_config`]).
#[must_use]
pub fn runtime_for(p: &Params) -> RuntimeConfig {
    let d = RuntimeConfig::default();
    RuntimeConfig {
        control: control_config(p, d.control.yaw_mode.into(), d.control.traction_enabled),
        ..d
    }
}

fn on_off(b: bool) -> &'static str {
    if b {
        "on"
    } else {
        "off"
    }
}

/// The Config frame of a run on `rt` with `wsp` and `monitor_safe`, rates unchanged.
#[must_use]
pub fn run_config(rt: &RuntimeConfig, wsp: bool, monitor_safe: bool) -> wheelset_proto::Config {
    wheelset_proto::Config {
        mode: rt.control.yaw_mode,
        traction: rt.control.traction_enabled,
        enable: rt.enable,
        hold_ticks: rt.hold_ticks,
        rates: None,
        monitor_safe,
        wsp,
    }
}

/// Options of a device-in-the-loop run.
#[derive(Debug, Clone, PartialEq)]
pub struct DeviceOptions {
    /// The link (baud, latency, faults, seed).
    pub link: LinkConfig,
    /// The runtime's hold ticks before the safe state.
    pub hold_ticks: u16,
    /// Base rate override, Hz (None: the control core's default).
    pub base_rate_hz: Option<u32>,
    /// Ticks from a sample to its actuation (1: lock-step), the gains' design delay.
    pub delay_ticks: u8,
    /// `y'` or `y''` in the Sensor frames.
    pub lateral: LateralSensing,
    /// Wheel-slip protection (`Config.wsp`; default on).
    pub wsp: bool,
    /// A stability alarm holds the safe state until `ClearFaults` (default off).
    pub monitor_safe: bool,
    /// Send `Command::ClearFaults` at the first sample instant at or after this time, ns.
    pub clear_faults_at_ns: Option<u64>,
}

impl Default for DeviceOptions {
    fn default() -> Self {
        Self {
            link: LinkConfig::default(),
            hold_ticks: wheelset_runtime::DEFAULT_HOLD_TICKS,
            base_rate_hz: None,
            delay_ticks: 1,
            lateral: LateralSensing::Velocity,
            wsp: true,
            monitor_safe: false,
            clear_faults_at_ns: None,
        }
    }
}

/// A finished device-in-the-loop run.
#[derive(Debug, Clone)]
pub struct DeviceRun {
    /// The plant's trajectory (same records as a continuous run).
    pub trajectory: Trajectory,
    /// One link record per control period.
    pub link: Vec<LinkSample>,
    /// Frame accounting and the device's counters.
    pub report: LinkReport,
    /// Control period, ns.
    pub period_ns: u64,
}

impl DeviceRun {
    /// The link record of the actuation in force at `t_ns`; None before the first.
    #[must_use]
    pub fn link_at(&self, t_ns: u64) -> Option<&LinkSample> {
        let k = (t_ns / self.period_ns).checked_sub(1)?;
        self.link.get(usize::try_from(k).ok()?)
    }

    /// Writes the CSV: the continuous run's columns, then [`LINK_COLUMNS`].
    pub fn write_csv<W: std::io::Write>(&self, w: W) -> std::io::Result<()> {
        use std::fmt::Write as _;
        self.trajectory.write_csv_with(w, &LINK_COLUMNS, |r, line| {
            let t_ns = (r.t_s * 1e9).round() as u64;
            let l = self.link_at(t_ns).copied().unwrap_or_default();
            let _ = write!(
                line,
                ",{},{},{},{},{}",
                l.seq,
                l.seq_echo,
                l.age,
                l.flags,
                u8::from(l.fresh)
            );
        })
    }
}

/// The runtime configuration of a device running `sc` with `law` (every path's rule).
#[must_use]
pub fn runtime_config(sc: &Scenario, law: YawLaw, opt: &DeviceOptions) -> RuntimeConfig {
    let rt = RuntimeConfig {
        control: control_config(&sc.params, law, sc.drive),
        hold_ticks: opt.hold_ticks,
        enable: true,
        ..RuntimeConfig::default()
    };
    let d = opt.delay_ticks.max(1);
    match (opt.base_rate_hz, d) {
        (None, 1) => rt,
        // A point without a design keeps the gains; `base_rate_refusal` names it.
        (hz, d) => {
            let hz = hz.unwrap_or(rt.control.base_rate_hz);
            rt.designed(hz, d).unwrap_or_else(|_| {
                let mut r = rt;
                r.control.base_rate_hz = hz;
                r.control.delay_ticks = d;
                r
            })
        }
    }
}

/// Runs `sc` with the firmware runtime over the simulated link (`t_k`'s actuation from `t_k + T`).
pub fn run_device(
    sc: &Scenario,
    law: YawLaw,
    opt: &DeviceOptions,
) -> Result<DeviceRun, DeviceError> {
    let rt_cfg = runtime_config(sc, law, opt);
    let mut dev = InProc::<Fx>::try_new(rt_cfg, &opt.link, DeviceFault::None)?;
    // The link log only: not the timing records `hil run` checks.
    dev.time_ticks(false);
    let cfg = run_config(&rt_cfg, opt.wsp, opt.monitor_safe);
    dev.configure(&cfg)
        .map_err(|why| DeviceError::Refused(why, cfg))?;
    let period_ns = dev.period_ns();
    let label = format!(
        "{} (device, {} Hz, {} baud)",
        law.name(),
        rt_cfg.control.base_rate_hz,
        opt.link.baud
    );
    let run = close_loop(
        sc,
        &mut dev,
        LoopSetup {
            period_ns,
            yaw_spring: law.has_spring(),
            lateral: opt.lateral,
            label: &label,
            clear_faults_at_ns: opt.clear_faults_at_ns,
            records: Records::LinkLog,
            delay_ticks: u32::from(rt_cfg.control.delay_ticks),
            ..LoopSetup::default()
        },
    )
    .map_err(DeviceError::Sim)?;
    let report = LinkReport::of(&run.rec, dev.accounting());
    Ok(DeviceRun {
        trajectory: run.trajectory,
        link: run.rec.log,
        report,
        period_ns,
    })
}

/// How far a run is from a reference run of the same scenario (same output times).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Deviation {
    /// Per window `[from_s, to_s)`: max relative deviation of `y` and of the creep forces.
    pub windows: [WindowDeviation; 2],
    /// Max `|y - y_ref|` over the whole run, m.
    pub y_max_abs_m: f64,
    /// The same relative to `max |y_ref|` over the run.
    pub y_max_rel: f64,
    /// Max creep-force deviation over the run, N (any of the three).
    pub f_max_abs_n: f64,
    /// The same relative to the largest reference creep force over the run.
    pub f_max_rel: f64,
    /// A value of either run was not finite: the figures above are meaningless.
    pub diverged: bool,
}

/// Deviation in one time window.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WindowDeviation {
    /// Window start, s.
    pub from_s: f64,
    /// Window end, s.
    pub to_s: f64,
    /// Max `|y - y_ref| / |y_ref|`.
    pub y_rel: f64,
    /// Max of `|F - F_ref|` over `Fx_R`, `Fx_L`, `Fy`, relative to the window's largest
    /// reference force (a per-force ratio would measure noise on the ~0 N forces).
    pub f_rel: f64,
}

/// The windows of the acceptance check on `curve`: the constant curve (4-12 s) before the
/// traction step at 5 s (settled: 4.5-5 s) and after it (settled: 10-12 s).
pub const CURVE_WINDOWS: [(f64, f64); 2] = [(4.5, 5.0), (10.0, 12.0)];

/// A run's deviation from a reference: push `(run, reference)` records in time order, then finish.
#[derive(Debug, Clone)]
pub struct DeviationAcc {
    d: Deviation,
    /// Per window: the largest force deviation and the largest reference force.
    window_f: [(f64, f64); 2],
    y_ref_max: f64,
    f_ref_max: f64,
}

impl DeviationAcc {
    /// An empty comparison over the time windows `[from_s, to_s)`.
    #[must_use]
    pub fn new(windows: [(f64, f64); 2]) -> Self {
        let mut d = Deviation::default();
        for (w, &(from_s, to_s)) in d.windows.iter_mut().zip(&windows) {
            w.from_s = from_s;
            w.to_s = to_s;
        }
        Self {
            d,
            window_f: [(0.0, 0.0); 2],
            y_ref_max: 0.0,
            f_ref_max: 0.0,
        }
    }

    /// Takes the run's record `a` and the reference's `b` (skipped if over 1 ns apart).
    pub fn push(&mut self, a: &Record, b: &Record) {
        if (a.t_s - b.t_s).abs() >= 1e-9 {
            return;
        }
        let forces = |r: &Record| [r.fx_r_n, r.fx_l_n, r.fy_n];
        let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-300);
        let d = &mut self.d;
        let (fa, fb) = (forces(a), forces(b));
        for (w, (df, f_scale)) in d.windows.iter_mut().zip(&mut self.window_f) {
            if b.t_s >= w.from_s && b.t_s < w.to_s {
                w.y_rel = w.y_rel.max(rel(a.y_m, b.y_m));
                for (&fa, &fb) in fa.iter().zip(&fb) {
                    *df = df.max((fa - fb).abs());
                    *f_scale = f_scale.max(fb.abs());
                }
            }
        }
        d.diverged |= !(a.y_m.is_finite() && b.y_m.is_finite())
            || fa.iter().chain(&fb).any(|f| !f.is_finite());
        d.y_max_abs_m = d.y_max_abs_m.max((a.y_m - b.y_m).abs());
        self.y_ref_max = self.y_ref_max.max(b.y_m.abs());
        for (&fa, &fb) in fa.iter().zip(&fb) {
            d.f_max_abs_n = d.f_max_abs_n.max((fa - fb).abs());
            self.f_ref_max = self.f_ref_max.max(fb.abs());
        }
    }

    /// The deviation of the pairs pushed so far.
    #[must_use]
    pub fn finish(self) -> Deviation {
        let mut d = self.d;
        for (w, (df, f_scale)) in d.windows.iter_mut().zip(self.window_f) {
            w.f_rel = df / f_scale.max(1e-300);
        }
        d.y_max_rel = d.y_max_abs_m / self.y_ref_max.max(1e-300);
        d.f_max_rel = d.f_max_abs_n / self.f_ref_max.max(1e-300);
        d
    }
}

impl fmt::Display for Deviation {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.diverged {
            return write!(f, "not comparable: a run diverged (NaN or infinite values)");
        }
        for w in &self.windows {
            write!(
                f,
                "{:.1}-{:.1} s: y within {:.3} %, creep forces within {:.3} %; ",
                w.from_s,
                w.to_s,
                w.y_rel * 100.0,
                w.f_rel * 100.0
            )?;
        }
        write!(
            f,
            "whole run: max |dy| {:.4} mm ({:.2} % of max |y|), max |dF| {:.1} N ({:.2} % of max |F|)",
            self.y_max_abs_m * 1e3,
            self.y_max_rel * 100.0,
            self.f_max_abs_n,
            self.f_max_rel * 100.0
        )
    }
}

impl From<LinkBudgetError> for DeviceError {
    fn from(e: LinkBudgetError) -> Self {
        Self::Budget(e)
    }
}

#[cfg(test)]
mod tests;
