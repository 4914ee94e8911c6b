//! `hil soak`: hours of simulated service in process, or minutes of real time against
//! the free-running firmware under QEMU; its arguments and what it prints.

use std::io::IsTerminal;

use clap::Args;
use hil::report::to_json;
use hil::run::Target;
use hil::soak::inproc::{soak, SoakOptions};
use hil::soak::qemu::soak_qemu;
use hil::soak::service::ServiceOptions;
use wheelset_loop::inproc::DeviceFault;
use wheelset_report::Verdict;

use super::{input, run_error, written, Failure};

#[derive(Args, Clone)]
pub(crate) struct SoakArgs {
    /// Where the device runs: inproc (the runtime over the simulated link, simulated
    /// time) or qemu-free (the free-running firmware under QEMU, real time).
    #[arg(long, default_value = "inproc", value_parser = parse_soak_target)]
    target: Target,
    /// Hours of service to soak (simulated in process; real time under QEMU).
    #[arg(long, conflicts_with = "minutes", allow_negative_numbers = true)]
    hours: Option<f64>,
    /// Minutes of service to soak (instead of --hours).
    #[arg(long, allow_negative_numbers = true)]
    minutes: Option<f64>,
    /// Seed of every random choice (track, faults, Configs): a failure names it, and the
    /// same seed replays the same run.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// A deliberately broken in-process device: corrupt:EVERY (every EVERY-th frame it
    /// sends has a bit flipped), to show that the soak catches it and names the seed.
    #[arg(long, default_value = "none", value_parser = parse_defect)]
    defect: DeviceFault,
    #[command(flatten)]
    service: ServiceOptions,
    /// Print each episode of the service as it starts, and the first second of each
    /// adhesion patch per 0.1 s (what led up to a failure).
    #[arg(long)]
    trace: bool,
    /// Write the figures (JSON).
    #[arg(long, value_name = "FILE")]
    json: Option<std::path::PathBuf>,
}

fn parse_soak_target(s: &str) -> Result<Target, String> {
    match s {
        "inproc" => Ok(Target::InProc),
        "qemu-free" => Ok(Target::QemuFree),
        _ => Err(format!(
            "unknown soak target `{s}` (expected inproc or qemu-free)"
        )),
    }
}

/// `--defect`: the device faults the soak simulates, `none` and `corrupt:EVERY`.
fn parse_defect(s: &str) -> Result<DeviceFault, String> {
    match s.strip_prefix("corrupt:").map(|_| s.parse()) {
        _ if s == "none" => Ok(DeviceFault::None),
        Some(Ok(d)) => Ok(d),
        Some(Err(_)) => Err(format!("{s}: EVERY must be a whole number of frames >= 1")),
        None => Err(format!("unknown defect `{s}` (known: none, corrupt:EVERY)")),
    }
}

/// The soak's length in seconds, from `--hours` or `--minutes` (one of them; positive
/// and at most a week).
fn duration_s(a: &SoakArgs) -> Result<f64, Failure> {
    let s = match (a.hours, a.minutes) {
        (Some(h), None) => h * 3600.0,
        (None, Some(m)) => m * 60.0,
        _ => return Err(input("hil soak: give --hours H or --minutes M")),
    };
    if !(s.is_finite() && s > 0.0 && s <= 7.0 * 86_400.0) {
        return Err(input(
            "hil soak: the length must be positive and at most a week (168 h)",
        ));
    }
    Ok(s)
}

pub(crate) fn cmd_soak(a: &SoakArgs) -> Result<Verdict, Failure> {
    let secs = duration_s(a)?;
    let (json, summary, clean) = match a.target {
        Target::QemuFree if a.defect != DeviceFault::None => {
            return Err(input(
                "hil soak: --defect is the in-process device's (--target inproc)",
            ))
        }
        Target::QemuFree => {
            let r = soak_qemu((secs / 60.0).ceil() as u32).map_err(run_error)?;
            (to_json(&r), r.summary(), r.clean())
        }
        _ => {
            let r = soak(SoakOptions {
                duration_ns: (secs * 1e9).round() as u64,
                seed: a.seed,
                defect: a.defect,
                progress: std::io::stderr().is_terminal() || secs >= 3_600.0,
                trace: a.trace,
                service: a.service,
            })
            .map_err(input)?;
            (to_json(&r), r.summary(), r.failure.is_none())
        }
    };
    if let Some(p) = &a.json {
        let text = json.map_err(|e| input(e.to_string()))?;
        written(p, std::fs::write(p, text))?;
    }
    say!("{}", summary.trim_end());
    Ok(if clean { Verdict::Pass } else { Verdict::Fail })
}
