//! The subcommands of `hil`, one module each with its arguments beside it (`hil audit`'s
//! are in `wheelset_audit`), and what they share: the failure type with its exit code, the
//! `--params` loader and the common argument parsers.

mod golden;
mod run;
mod serve;
mod soak;
mod sweep;

pub(crate) use golden::{cmd_golden, GoldenArgs};
pub(crate) use run::{cmd_run, RunArgs};
pub(crate) use serve::{cmd_serve, ServeArgs};
pub(crate) use soak::{cmd_soak, SoakArgs};
pub(crate) use sweep::{cmd_sweep, SweepCmd};

use clap::ValueEnum;
use hil::run::{Law, RunError, Target};
use wheelset_loop::sim_link::Faults;
use wheelset_plant::params::Params;
use wheelset_targets::qemu::Channel;

/// A failure with its exit code.
pub(crate) struct Failure {
    pub(crate) code: u8,
    pub(crate) msg: String,
}

pub(crate) fn input(msg: impl Into<String>) -> Failure {
    Failure {
        code: 2,
        msg: msg.into(),
    }
}

/// The target could not be used (exit code 3).
pub(crate) fn unavailable(msg: impl ToString) -> Failure {
    Failure {
        code: 3,
        msg: msg.to_string(),
    }
}

/// `r`, or the failure to write `path` (exit code 2).
pub(crate) fn written<T>(path: &std::path::Path, r: std::io::Result<T>) -> Result<T, Failure> {
    r.map_err(|e| input(format!("{}: cannot write: {e}", path.display())))
}

/// The parameters of `--params FILE` (the paper's without it); a bad file names the
/// flag, the file and the key.
pub(crate) fn load_params(path: Option<&std::path::Path>) -> Result<Params, Failure> {
    match path {
        Some(p) => Params::from_file(p).map_err(|e| input(format!("--params: {e}"))),
        None => Ok(Params::default()),
    }
}

pub(crate) fn run_error(e: RunError) -> Failure {
    match e {
        RunError::Input(m) => input(m),
        RunError::Target(e) => unavailable(e),
    }
}

#[derive(Clone, Copy, ValueEnum)]
pub(crate) enum Control {
    /// Passive: the mechanical yaw spring in the plant, no yaw torque from the device.
    Passive,
    /// Pure gain `T = K y'`.
    Gain,
    /// Phase lead `K 7.5 (s+37)/(s+274)` on `y'`.
    Lead,
}

impl Control {
    /// The law; a scenario meant for other laws (its `laws` key) warns first.
    pub(crate) fn law_for(self, scenario: &str, params: &Params) -> Law {
        let law = match self {
            Self::Passive => Law::Passive,
            Self::Gain => Law::Gain,
            Self::Lead => Law::Lead,
        };
        if let Ok(sc) = wheelset_plant::scenario::Scenario::load(scenario, params) {
            if let Some(w) = sc.law_warning(law) {
                eprintln!("hil: warning: {w}");
            }
        }
        law
    }
}

/// `--qemu-link bulk` only on the QEMU target, `--faults` only on the simulated link.
pub(crate) fn check_link_flags(
    target: &Target,
    qemu_link: Channel,
    faults: &Faults,
) -> Result<(), Failure> {
    if *target != Target::Qemu && qemu_link != Channel::Uart {
        return Err(input(format!(
            "--qemu-link bulk: the bulk channel is the QEMU target's, not {target}'s"
        )));
    }
    if *target != Target::InProc && *faults != Faults::none() {
        return Err(input(format!(
            "--faults: the fault injection is part of the simulated link; target {target} has a real one"
        )));
    }
    Ok(())
}

pub(crate) fn inproc_or_qemu(s: &str, by_hand: &str, other: &str) -> Result<Target, String> {
    match s.parse::<Target>()? {
        t @ (Target::InProc | Target::Qemu) => Ok(t),
        Target::QemuAt(_) => Err(by_hand.into()),
        Target::Serial(_) | Target::QemuFree => Err(other.into()),
    }
}
