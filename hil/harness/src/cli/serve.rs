//! `hil serve`: the firmware's runtime behind a pseudo-terminal, a stand-in for a board.

use std::path::PathBuf;

use clap::Args;
use wheelset_report::Verdict;

use super::{input, Failure};

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
    let rt = serve::runtime_at(a.rate_hz).map_err(input)?;
    let opts = serve::ServeOptions {
        rate_hz: a.rate_hz,
        duration,
        cpu_hz: a.cpu_hz,
        want: if a.no_rt {
            wheelset_targets::realtime::os::Want::none()
        } else {
            wheelset_targets::realtime::os::Want::all(a.cpu.or_else(|| {
                wheelset_targets::realtime::os::allowed_cpus()
                    .first()
                    .copied()
            }))
        },
    };
    let (mut master, slave, path) = serve::open_pty().map_err(|e| Failure {
        code: 3,
        msg: format!("cannot create a pseudo-terminal: {e}"),
    })?;
    // The path first, alone on its line, for whoever starts the stand-in.
    say!("{path}");
    let _ = std::io::stdout().flush();
    eprintln!(
        "hil serve: the runtime (fixed point) free-running at {} Hz on {path};          `hil run --target serial:{path}`",
        a.rate_hz
    );
    let stop = std::sync::atomic::AtomicBool::new(false);
    let rep = serve::serve(&mut master, rt, &opts, &stop).map_err(|e| Failure {
        code: 3,
        msg: format!("{path}: {e}"),
    })?;
    drop(slave);
    eprintln!(
        "hil serve: {} ticks, {} late, {} skipped (max lateness {:.1} us), rx {} B, tx {} B, \
         {} frames dropped, {} Hz at the end; real-time scheduling obtained: {}",
        rep.ticks,
        rep.late,
        rep.skipped,
        rep.max_lateness_ns as f64 * 1e-3,
        rep.rx_bytes,
        rep.tx_bytes,
        rep.tx_dropped,
        rep.rate_hz,
        rep.realtime
    );
    if let Some(p) = &a.json {
        let text = serde_json::to_string_pretty(&rep).unwrap_or_default();
        std::fs::write(p, text + "\n")
            .map_err(|e| input(format!("{}: cannot write: {e}", p.display())))?;
    }
    Ok(Verdict::Pass)
}
