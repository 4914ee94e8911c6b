//! Opening the device of a run: the transport of each target (in process, QEMU lock-step
//! or free-running, a serial board in lock-step or real time), the run's Config frame,
//! and the rate the run asks of it (the link check before a run).

use wheelset_control::Fx;
use wheelset_plant::params::Params;
use wheelset_runtime::RuntimeConfig;

use super::{RunError, RunOptions, Target, QEMU_FREE_BAUD, QEMU_FREE_RATE_HZ};
use wheelset_loop::inproc::InProc;
use wheelset_loop::transport::{Transport, TransportError};
use wheelset_targets::qemu::target::QemuTarget;
use wheelset_targets::realtime::{Port, RealTime, RealTimeOptions};
use wheelset_targets::serial::{Pace, Serial};

/// Opens the transport for `opts.target`; an in-process device is built from `rt`.
pub fn open_transport(
    opts: &RunOptions,
    rt: RuntimeConfig,
) -> Result<Box<dyn Transport>, RunError> {
    match &opts.target {
        Target::InProc => {
            let mut t = InProc::<Fx>::try_new(rt, &opts.link, opts.device_fault)
                .map_err(|e| RunError::Input(e.to_string()))?;
            let cfg = wheelset_loop::device_loop::run_config(&rt, opts.wsp, opts.monitor_safe);
            t.configure(&cfg).map_err(|why| {
                RunError::Target(TransportError::Unavailable(
                    wheelset_loop::device_loop::DeviceError::Refused(why, cfg).to_string(),
                ))
            })?;
            Ok(Box::new(t))
        }
        Target::Qemu => {
            let t = QemuTarget::start_with(
                opts.machine,
                opts.qemu_link,
                opts.link.baud,
                opts.cpu_hz,
                opts.timeout,
            )
            .map_err(RunError::Target)?;
            Ok(Box::new(t))
        }
        Target::QemuAt(port) => {
            let t = QemuTarget::connect(*port, opts.link.baud, opts.cpu_hz, opts.timeout)
                .map_err(RunError::Target)?;
            Ok(Box::new(t))
        }
        Target::Serial(p) if opts.pace == Pace::RealTime => {
            Ok(Box::new(open_realtime(p, opts, &rt)?))
        }
        Target::QemuFree => Ok(Box::new(open_qemu_free(opts, &rt)?)),
        Target::Serial(p) => {
            let t = Serial::open(p, opts.link.baud, opts.cpu_hz, opts.timeout)
                .map_err(RunError::Target)?;
            Ok(Box::new(t))
        }
    }
}

/// The Config frame that puts a free-running device elsewhere on `rt` (law, hold
/// ticks, rates) with the protection `wsp` and the monitor's response `monitor_safe`
/// (`wheelset_loop::device_loop::run_config` with the rates).
pub fn device_config(
    rt: &RuntimeConfig,
    wsp: bool,
    monitor_safe: bool,
) -> Result<wheelset_proto::Config, RunError> {
    let rates = wheelset_runtime::rates_for::<wheelset_control::Fx>(rt)
        .map_err(|e| RunError::Input(format!("--rate-hz {}: {e}", rt.control.base_rate_hz)))?;
    Ok(wheelset_proto::Config {
        rates: Some(rates),
        ..wheelset_loop::device_loop::run_config(rt, wsp, monitor_safe)
    })
}

/// Opens a free-running device on `path`, configures it and locks onto its tick.
pub(super) fn open_realtime(
    path: &str,
    opts: &RunOptions,
    rt: &RuntimeConfig,
) -> Result<RealTime, RunError> {
    let cfg = device_config(rt, opts.wsp, opts.monitor_safe)?;
    let mut t = RealTime::open(
        path,
        realtime_options(opts, rt, opts.link.baud, opts.cpu_hz),
    )
    .map_err(RunError::Target)?;
    t.prepare(&cfg).map_err(RunError::Target)?;
    Ok(t)
}

fn realtime_options(
    opts: &RunOptions,
    rt: &RuntimeConfig,
    baud: u32,
    cpu_hz: f64,
) -> RealTimeOptions {
    RealTimeOptions {
        period_ns: 1_000_000_000 / u64::from(rt.control.base_rate_hz.max(1)),
        baud,
        cpu_hz,
        timeout: opts.timeout,
        want: opts.realtime,
        // 5/8 of the period: under QEMU, whose UART is slow both ways, a Sensor frame
        // needs most of half the period to reach the tick (docs: "QEMU free-running").
        lead_num: 5,
    }
}

/// Starts the free-running firmware under QEMU (no `-icount`), configures it and locks
/// onto its tick. Its `exec` is SysTick counts of the 25 MHz clock.
pub(super) fn open_qemu_free(opts: &RunOptions, rt: &RuntimeConfig) -> Result<RealTime, RunError> {
    let cfg = device_config(rt, opts.wsp, opts.monitor_safe)?;
    let qcfg = wheelset_targets::qemu::QemuConfig {
        timeout: opts.timeout,
        realtime: true,
        ..wheelset_targets::qemu::QemuConfig::free_running()
    };
    let q = wheelset_targets::qemu::Qemu::start(&qcfg)
        .map_err(|e| RunError::Target(TransportError::Unavailable(e.to_string())))?;
    let stream = q
        .tcp_stream()
        .map_err(|e| RunError::Target(TransportError::Unavailable(e.to_string())))?;
    let o = realtime_options(
        opts,
        rt,
        QEMU_FREE_BAUD,
        wheelset_targets::qemu::target::MPS2_CPU_HZ,
    );
    let mut t = RealTime::on("qemu-free", Port::Tcp(stream, Some(q)), o);
    t.prepare(&cfg).map_err(RunError::Target)?;
    Ok(t)
}

/// The base rate of a run: `opts.rate_hz` or the control core's default, a whole number
/// of ns per period in process, of us elsewhere (the firmware's ticker), then the link
/// against it ([`link_fits`]; not under lock-step: the frames are the device's clock).
pub(super) fn run_rate(opts: &RunOptions, default_hz: u32) -> Result<u32, RunError> {
    let hz = opts.rate_hz.unwrap_or(if opts.target == Target::QemuFree {
        QEMU_FREE_RATE_HZ
    } else {
        default_hz
    });
    let unit = if opts.target == Target::InProc {
        1_000_000_000
    } else {
        1_000_000
    };
    if hz == 0 || unit % u64::from(hz) != 0 {
        return Err(RunError::Input(format!(
            "--rate-hz {hz}: the period must be a whole number of {} (a divisor of {unit} Hz)",
            if unit == 1_000_000 {
                "microseconds on a device's ticker"
            } else {
                "nanoseconds"
            }
        )));
    }
    let lockstep = matches!(opts.target, Target::Qemu | Target::QemuAt(_))
        || (matches!(opts.target, Target::Serial(_)) && opts.pace == Pace::LockStep);
    if !lockstep {
        let baud = if opts.target == Target::QemuFree {
            QEMU_FREE_BAUD
        } else {
            opts.link.baud
        };
        let latency_ns = if opts.target == Target::InProc {
            opts.link.latency_ns
        } else {
            wheelset_loop::sim_link::DEFAULT_LATENCY_NS
        };
        link_fits(baud, hz, latency_ns, opts.delay_ticks).map_err(RunError::Input)?;
    }
    Ok(hz)
}

/// The link against the rate, before a run: the worst-case exchange (the Sensor frame
/// with one lateral value up, the Actuation frame down) must fit the link budget
/// ([`wheelset_loop::sim_link::check_budget`]); the refusal names the budget's numbers,
/// the lowest baud this rate needs and the highest rate this baud carries.
fn link_fits(baud: u32, rate_hz: u32, latency_ns: u64, delay_ticks: u8) -> Result<(), String> {
    let period_ns = 1_000_000_000 / u64::from(rate_hz.max(1));
    wheelset_loop::sim_link::check_budget(
        wheelset_proto::SENSOR_ONE_LATERAL_MAX_FRAME,
        wheelset_proto::ACTUATION_MAX_FRAME,
        baud,
        latency_ns,
        period_ns,
        u32::from(delay_ticks),
    )
    .map(|_| ())
    .map_err(|e| {
        format!(
            "--baud {baud} cannot carry --rate-hz {rate_hz}: {e}; at {baud} baud the highest \
             rate is {} Hz",
            e.max_rate_hz()
        )
    })
}

/// The parameter keys that set the device's gains and motor constants
/// (`wheelset_loop::device_loop::control_config`): lead, pure gain, traction PI, motor.
pub const DEVICE_KEYS: &[&str] = &[
    "k_active",
    "lead_gain",
    "lead_zero",
    "lead_pole",
    "pi_kp",
    "pi_ti",
    "k_m",
    "n_gear",
];

/// A device outside this process has its gains compiled in (a Config frame carries the
/// rates with their coefficients, the law and the limits, not the gains): parameters that
/// change them ([`DEVICE_KEYS`]) are refused there, named, rather than not followed.
pub fn remote_gains(p: &Params, target: &Target) -> Result<(), RunError> {
    let d = Params::default();
    let (given, default) = (p.entries(), d.entries());
    let changed: Vec<String> = given
        .iter()
        .zip(&default)
        .filter(|((k, a), (_, b))| DEVICE_KEYS.contains(k) && a != b)
        .map(|((k, a), _)| format!("{k} = {a}"))
        .collect();
    if changed.is_empty() {
        return Ok(());
    }
    Err(RunError::Input(format!(
        "parameters {}: they set the device's gains, which a device on {target} has compiled \
         in (its Config frame carries the rates, the law and the limits, not the gains); \
         run them with --target inproc",
        changed.join(", ")
    )))
}

#[cfg(test)]
mod tests {
    use super::link_fits;
    use wheelset_proto::link::{max_rate_hz, min_baud, LINK_SHARE_MAX_PERMILLE};
    use wheelset_proto::{ACTUATION_MAX_FRAME, SENSOR_ONE_LATERAL_MAX_FRAME};

    #[test]
    fn the_refusal_names_the_budget_s_edges() {
        let (up, down) = (
            SENSOR_ONE_LATERAL_MAX_FRAME as u32,
            ACTUATION_MAX_FRAME as u32,
        );
        let (lat, s) = (2_000, LINK_SHARE_MAX_PERMILLE);
        let r = max_rate_hz(921_600, up, down, lat, s);
        let b = min_baud(5_000, up, down, lat, s).unwrap_or(0);
        let e = link_fits(921_600, 5_000, lat, 1).err().unwrap_or_default();
        assert!(e.contains("link budget exceeded"), "{e}");
        assert!(e.contains(&format!("highest rate is {r} Hz")), "{e}");
        assert!(e.contains(&format!("at least {b},")), "{e}");
        assert!(link_fits(wheelset_loop::sim_link::DEFAULT_BAUD, 5_000, lat, 1).is_ok());
        assert!(link_fits(b, 5_000, lat, 1).is_ok());
        assert!(link_fits(b - 1, 5_000, lat, 1).is_err());
        assert!(link_fits(921_600, r, lat, 1).is_ok());
        // Pipelined: a round trip of 2.8 ms at 1 kHz needs four ticks.
        assert!(link_fits(921_600, 1_000, 1_000_000, 3).is_err());
        assert!(link_fits(921_600, 1_000, 1_000_000, 4).is_ok());
    }
}
