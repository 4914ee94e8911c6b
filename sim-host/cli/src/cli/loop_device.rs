//! `sim-host run --loop device`: the device loop's flags and the firmware runtime over
//! the simulated serial link.

use clap::ValueEnum;
use wheelset_plant::scenario::Scenario;
use wheelset_report::{out, outln};

use super::run::{compared, print_summary, write_plots, write_run_summary, RunArgs};
use super::{create_file, io_fail, warn, Failure};

/// Which controllers close the loop.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub(crate) enum LoopKind {
    /// The continuous-time reference controllers (extra ODE states).
    Continuous,
    /// The firmware runtime (fixed point) over the simulated serial link.
    Device,
    /// The control core in f64 on the plant, no link (one period of delay, wire
    /// quantisation of the inputs): the reference of the device, protection included.
    Core,
}

/// Wheel-slip protection switch.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub(crate) enum OnOff {
    /// On.
    On,
    /// Off.
    Off,
}

/// The device loop's options (`--loop device`). All but `--loop` apply to the device
/// loop only: given without `--loop device` they are refused, naming the flag.
#[derive(clap::Args)]
pub(crate) struct DeviceArgs {
    /// Loop kind.
    #[arg(long = "loop", value_enum, default_value = "continuous")]
    pub(crate) loop_kind: LoopKind,
    /// Wheel-slip protection (default on): of the f64 control core (`--loop core`), or of
    /// the device (`--loop device`: the host sets `Config.wsp` before the run).
    #[arg(long, value_enum)]
    pub(crate) wsp: Option<OnOff>,
    /// Link faults, e.g. `ber=1e-3,drop=0.1,outage=8.0:0.05` (keys: ber, drop, byte_drop,
    /// outage=START_S:LEN_S[:up|down], burst=RATE_HZ:LEN_BYTES, dir=both|up|down);
    /// default none.
    #[arg(long, allow_hyphen_values = true)]
    pub(crate) faults: Option<String>,
    /// Seed of the link's fault injection [default: 1].
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) seed: Option<u64>,
    /// Link baud rate (10 bits per byte) [default: 5000000].
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) baud: Option<u32>,
    /// One-way link latency, us, in [0, 1e6] [default: 2].
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) latency_us: Option<f64>,
    /// Device base rate, Hz (default: the control core's).
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) rate_hz: Option<u32>,
    /// Ticks from a sample to its actuation, 1 to the longest designed [default: 1]: the host applies each
    /// actuation that many periods after its sample (a pipelined link, for a link whose
    /// round trip is longer than a period), and the device runs the gains designed for
    /// the rate and this delay.
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) delay_ticks: Option<u8>,
    /// Ticks the device bridges a missing sensor frame before its safe state
    /// [default: the runtime's].
    #[arg(long, allow_negative_numbers = true)]
    pub(crate) hold_ticks: Option<u16>,
    /// What the Sensor frames carry of the lateral motion: `velocity` (y') or
    /// `acceleration` (y'', integrated on the device with a wash-out) [default: velocity].
    #[arg(long, value_enum)]
    pub(crate) lateral: Option<Lateral>,
}

impl DeviceArgs {
    /// The device-loop flags that were given (for refusing them on the continuous loop).
    pub(crate) fn given(&self) -> Vec<&'static str> {
        [
            ("--faults", self.faults.is_some()),
            ("--seed", self.seed.is_some()),
            ("--baud", self.baud.is_some()),
            ("--latency-us", self.latency_us.is_some()),
            ("--rate-hz", self.rate_hz.is_some()),
            ("--delay-ticks", self.delay_ticks.is_some()),
            ("--hold-ticks", self.hold_ticks.is_some()),
            ("--lateral", self.lateral.is_some()),
        ]
        .into_iter()
        .filter(|(_, g)| *g)
        .map(|(f, _)| f)
        .collect()
    }
}

/// `--latency-us` (of `run --loop device` and `rates`) in ns, refused outside `[0, 1e6]`
/// us (1 s: a link slower than that cannot carry any control rate).
pub(crate) fn latency_ns(us: f64) -> Result<u64, Failure> {
    if !(us.is_finite() && (0.0..=1e6).contains(&us)) {
        return Err(Failure::bad(format!(
            "--latency-us {us:e}: must be a finite value in [0, 1e6] us"
        )));
    }
    Ok((us * 1e3).round() as u64)
}

/// Lateral sensing over the link.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
pub(crate) enum Lateral {
    /// Lateral velocity `y'`.
    Velocity,
    /// Lateral acceleration `y''`.
    Acceleration,
}

/// `--loop device`: the firmware runtime over the simulated link; prints the frame
/// accounting and the deviation from the continuous reference.
pub(crate) fn cmd_run_device(a: &RunArgs, sc: &Scenario) -> Result<(), Failure> {
    use wheelset_loop::device_loop::{run_device, DeviationAcc, DeviceOptions, CURVE_WINDOWS};
    use wheelset_plant::control::ContinuousController;
    use wheelset_plant::sim::{run_continuous_each, Trajectory};
    let d = &a.device;
    let wsp = d.wsp != Some(OnOff::Off);
    let latency_us = d.latency_us.unwrap_or(2.0);
    let latency_ns = latency_ns(latency_us)?;
    let baud = d.baud.unwrap_or(wheelset_loop::sim_link::DEFAULT_BAUD);
    if baud == 0 {
        return Err(Failure::bad("--baud 0: must be positive".into()));
    }
    if d.rate_hz == Some(0) {
        return Err(Failure::bad("--rate-hz 0: must be positive".into()));
    }
    let delay_ticks = d.delay_ticks.unwrap_or(1);
    let max_delay = wheelset_control::design::DESIGNED
        .iter()
        .map(|p| p.delay_ticks)
        .max()
        .unwrap_or(1);
    if !(1..=max_delay).contains(&delay_ticks) {
        return Err(Failure::bad(format!(
            "--delay-ticks {delay_ticks}: must be 1 ..= {max_delay} (the delays the \
                 device's gains are designed for)"
        )));
    }
    let faults_spec = d.faults.clone().unwrap_or_default();
    let faults: wheelset_loop::sim_link::Faults = faults_spec
        .parse()
        .map_err(|e: wheelset_loop::sim_link::FaultSpecError| Failure::bad(e.to_string()))?;
    let opt = DeviceOptions {
        link: wheelset_loop::sim_link::LinkConfig {
            baud,
            latency_ns,
            faults,
            seed: d.seed.unwrap_or(1),
        },
        hold_ticks: d.hold_ticks.unwrap_or(wheelset_runtime::DEFAULT_HOLD_TICKS),
        base_rate_hz: d.rate_hz,
        delay_ticks,
        lateral: match d.lateral.unwrap_or(Lateral::Velocity) {
            Lateral::Velocity => wheelset_loop::device_loop::LateralSensing::Velocity,
            Lateral::Acceleration => wheelset_loop::device_loop::LateralSensing::Acceleration,
        },
        wsp,
        ..DeviceOptions::default()
    };
    let hz = d
        .rate_hz
        .unwrap_or(wheelset_control::Config::default().base_rate_hz);
    let period_ns = 1_000_000_000 / u64::from(hz.max(1));
    let kept = 2 + a.compare.iter().filter(|&&c| c != a.control).count() as u64;
    wheelset_plant::memory::check_runs(sc.duration_ns, sc.output_dt_ns, Some(period_ns), kept)
        .map_err(|msg| Failure::bad(format!("{}: {msg}", sc.source)))?;
    let rt = wheelset_loop::device_loop::runtime_config(sc, a.control, &opt);
    if let Some(why) = wheelset_loop::device_loop::base_rate_refusal(&rt) {
        return Err(Failure::bad(if delay_ticks > 1 {
            format!("--rate-hz {hz} --delay-ticks {delay_ticks}: {why}")
        } else {
            format!("--rate-hz {hz}: {why}")
        }));
    }
    if let Some(w) = wheelset_loop::rate_check::warning(sc, a.control, hz, delay_ticks) {
        warn(&w);
    }
    let mut run = run_device(sc, a.control, &opt).map_err(|e| Failure::bad(e.to_string()))?;
    print_summary(sc, &run.trajectory);
    let mut verdict = super::run::judge_divergence(a, &run.trajectory);
    if let Some(s) = &run.report.device {
        outln!(
            "wheel-slip protection {} (Config.wsp): {} events, {} ticks acting (device status)",
            if wsp { "on" } else { "off" },
            s.wsp_events,
            s.wsp_ticks
        );
    }
    outln!("{}", monitor_line(&run));
    let drive = run
        .report
        .device
        .as_ref()
        .is_some_and(|s| s.drive_alarms > 0);
    if drive && verdict.is_ok() && !a.expect_divergence {
        verdict = Err(Failure::failed(
            "the traction current loop limit-cycled (the device's drive alarm, \
                  above); add --expect-divergence if that is the run's point"
                .into(),
        ));
    }
    write_run_summary(&a.json, sc, &run.trajectory, Some(wsp))?;
    outln!(
        "link: {} baud, latency {} us, period {} us, faults `{}` (seed {})",
        opt.link.baud,
        latency_us,
        run.period_ns as f64 / 1e3,
        if faults_spec.is_empty() {
            "none"
        } else {
            &faults_spec
        },
        opt.link.seed
    );
    out!("{}", run.report);
    outln!();
    // Without a CSV the link log is freed before the reference trajectory is made.
    if a.csv.is_none() {
        run.link = Vec::new();
    }
    // The reference is compared as it runs; it is kept only for the plots.
    let mut reference = Vec::new();
    let mut acc = DeviationAcc::new(CURVE_WINDOWS);
    let mut own = run.trajectory.records.iter();
    let info = run_continuous_each(sc, ContinuousController::new(&sc.params, a.control), |r| {
        if let Some(mine) = own.next() {
            acc.push(mine, &r);
        }
        if a.plot.is_some() {
            reference.push(r);
        }
    });
    outln!("vs continuous reference: {}", acc.finish());
    if let Some(path) = &a.csv {
        run.write_csv(create_file(path)?)
            .map_err(|e| io_fail(path, e))?;
        outln!(
            "csv: {} ({} rows)",
            path.display(),
            run.trajectory.records.len()
        );
    }
    if a.plot.is_some() {
        let reference = Trajectory {
            records: reference,
            info,
        };
        let mut runs = vec![run.trajectory, reference];
        runs.extend(compared(a, sc));
        write_plots(a, &runs)?;
    }
    verdict
}

/// The device monitor's alarms: each one's first instant (host side), the Status's counts.
fn monitor_line(run: &wheelset_loop::device_loop::DeviceRun) -> String {
    use wheelset_runtime::Flags;
    let kinds = [
        (
            Flags::DRIVE_OSC,
            "drive (the traction current loop oscillates)",
        ),
        (Flags::ACTUATOR_FAULT, "yaw actuator"),
        (Flags::HUNTING, "hunting"),
    ];
    let parts: Vec<String> = kinds
        .iter()
        .filter_map(|&(bit, name)| {
            let first = run.link.iter().find(|l| Flags(l.flags).has(bit))?;
            Some(format!(
                "{name} from {:.3} s",
                (first.t_ns + run.period_ns) as f64 * 1e-9
            ))
        })
        .collect();
    let counts = run.report.device.as_ref().map_or(String::new(), |s| {
        format!(
            " (device status: {} drive, {} actuator, {} hunting alarms)",
            s.drive_alarms, s.act_alarms, s.hunt_alarms
        )
    });
    if parts.is_empty() {
        format!("monitor: no alarm{counts}")
    } else {
        format!("monitor alarms: {}{counts}", parts.join(", "))
    }
}
