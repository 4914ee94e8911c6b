//! `hil serve`: the firmware's runtime behind a pseudo-terminal, a stand-in for a board.

use std::path::PathBuf;

use clap::Args;
use wheelset_report::Verdict;
use wheelset_targets::realtime::os::{self, Want};

use super::{input, unavailable, Failure};

#[derive(Args, Clone)]
pub(crate) struct ServeArgs {
    /// Create a pseudo-terminal and serve on it (the only transport so far).
    #[arg(long, required = true)]
    pty: bool,
    /// Base rate at start, Hz (a host Config frame may change it, as on the board).
    #[arg(long, default_value_t = wheelset_control::DEFAULT_BASE_RATE_HZ)]
    rate_hz: u32,
    /// Stop after this many seconds (default: until killed).
    #[arg(long)]
    duration_s: Option<f64>,
    /// Pin the stand-in to this CPU (default: the first one allowed).
    #[arg(long)]
    cpu: Option<usize>,
    /// Core clock the `exec` field is expressed in, Hz.
    #[arg(long, default_value_t = hil::run::DEFAULT_CPU_HZ)]
    cpu_hz: f64,
    /// Do not ask for SCHED_FIFO, locked memory or a pinned core.
    #[arg(long)]
    no_rt: bool,
    /// Write what the stand-in did (JSON) at the end.
    #[arg(long)]
    json: Option<PathBuf>,
    /// A USB-serial bridge between the stand-in and the host: every byte run, each way,
    /// is held this long, us, in [0, 1e6] (full-speed USB, as the ST-LINK's virtual COM
    /// port: about 1000) [default: 0, no bridge].
    #[arg(long, allow_negative_numbers = true)]
    latency_us: Option<f64>,
    /// The bridge's jitter: each run's delay is the latency plus 0 to this, us, uniform,
    /// in [0, 1e6] [default: 0].
    #[arg(long, allow_negative_numbers = true)]
    jitter_us: Option<f64>,
    /// Seed of the bridge's jitter (the same seed, the same delays run for run).
    #[arg(long, default_value_t = 0)]
    seed: u64,
    /// The UART between the board and the bridge, baud: each run also takes its wire
    /// time (a pseudo-terminal has none) [default: none].
    #[arg(long)]
    baud: Option<u32>,
}

pub(crate) fn cmd_serve(a: &ServeArgs) -> Result<Verdict, Failure> {
    use std::io::Write as _;
    use wheelset_targets::realtime::serve;
    let duration = match a.duration_s {
        None => None,
        Some(d) if d.is_finite() && d > 0.0 => Some(std::time::Duration::from_secs_f64(d)),
        Some(d) => {
            return Err(input(format!(
                "--duration-s {d}: must be a positive number"
            )))
        }
    };
    if !(a.cpu_hz.is_finite() && a.cpu_hz > 0.0) {
        return Err(input("--cpu-hz: must be a positive number"));
    }
    let bridge = wheelset_targets::realtime::bridge::BridgeModel::from_us(
        a.latency_us.unwrap_or(0.0),
        a.jitter_us.unwrap_or(0.0),
        a.seed,
    )
    .map_err(input)?
    .with_baud(match a.baud {
        Some(0) => return Err(input("--baud 0: must be positive")),
        b => b.unwrap_or(0),
    });
    let rt = serve::runtime_at(a.rate_hz).map_err(input)?;
    let opts = serve::ServeOptions {
        rate_hz: a.rate_hz,
        duration,
        cpu_hz: a.cpu_hz,
        bridge,
        want: if a.no_rt {
            Want::none()
        } else {
            Want::all(a.cpu.or_else(|| os::allowed_cpus().first().copied()))
        },
    };
    let (mut master, slave, path) = serve::open_pty()
        .map_err(|e| unavailable(format!("cannot create a pseudo-terminal: {e}")))?;
    // The path first, alone on its line, for whoever starts the stand-in.
    say!("{path}");
    let _ = std::io::stdout().flush();
    let behind = if bridge.is_none() {
        String::new()
    } else {
        format!(
            " behind a modelled USB bridge ({:.1} us + 0 to {:.1} us each way, seed {}{})",
            bridge.latency_ns as f64 * 1e-3,
            bridge.jitter_ns as f64 * 1e-3,
            bridge.seed,
            if bridge.baud > 0 {
                format!(", {} baud on the wire", bridge.baud)
            } else {
                String::new()
            }
        )
    };
    eprintln!(
        "hil serve: the runtime (fixed point) free-running at {} Hz on {path}{behind}; `hil run --target serial:{path}`",
        a.rate_hz
    );
    let stop = std::sync::atomic::AtomicBool::new(false);
    let rep = serve::serve(&mut master, rt, &opts, &stop)
        .map_err(|e| unavailable(format!("{path}: {e}")))?;
    drop(slave);
    eprintln!(
        "hil serve: {} ticks, {} late, {} skipped (max lateness {:.1} us), rx {} B, tx {} B, \
         {} frames dropped, {} Hz and {} tick(s) of delay at the end; real-time scheduling \
         obtained: {}",
        rep.ticks,
        rep.late,
        rep.skipped,
        rep.max_lateness_ns as f64 * 1e-3,
        rep.rx_bytes,
        rep.tx_bytes,
        rep.tx_dropped,
        rep.rate_hz,
        rep.delay_ticks,
        rep.realtime
    );
    if let Some(b) = &rep.bridge {
        eprintln!(
            "hil serve: the bridge delayed {} runs up ({:.1} to {:.1} us; taken by the runtime \
             at most {:.1} us after their release, at its next tick), {} down ({:.1} to {:.1} \
             us; written at most {:.1} us after their release), {} runs dropped",
            b.up.runs,
            b.up.delay_min_ns as f64 * 1e-3,
            b.up.delay_max_ns as f64 * 1e-3,
            b.up.release_late_max_ns as f64 * 1e-3,
            b.down.runs,
            b.down.delay_min_ns as f64 * 1e-3,
            b.down.delay_max_ns as f64 * 1e-3,
            b.down.release_late_max_ns as f64 * 1e-3,
            b.up.dropped + b.down.dropped
        );
    }
    if let Some(p) = &a.json {
        super::written(p, hil::report::write_json(&rep, p))?;
    }
    Ok(Verdict::Pass)
}
