//! The subcommands of `sim-host`, one module each with its arguments, and what they share.

mod adhesion;
mod loop_device;
mod modes;
mod rates;
mod run;

pub(crate) use adhesion::{cmd_adhesion, AdhesionArgs};
pub(crate) use modes::{cmd_modes, ModesArgs};
pub(crate) use rates::{cmd_rates, RatesArgs};
pub(crate) use run::{cmd_run, RunArgs};

use std::io::{BufWriter, Write};
use std::path::PathBuf;
use wheelset_plant::error::ConfigError;
use wheelset_plant::params::Params;
use wheelset_report::outln;

/// A command failure with its exit code.
pub(crate) struct Failure {
    pub(crate) code: u8,
    pub(crate) msg: String,
}

impl Failure {
    /// Bad usage or input: exit code 2.
    pub(crate) fn bad(msg: String) -> Self {
        Failure { code: 2, msg }
    }

    /// Any other failure: exit code 1.
    pub(crate) fn failed(msg: String) -> Self {
        Failure { code: 1, msg }
    }
}

impl From<ConfigError> for Failure {
    fn from(e: ConfigError) -> Self {
        Failure::bad(e.to_string())
    }
}

pub(crate) fn io_fail(what: &std::path::Path, e: std::io::Error) -> Failure {
    Failure::failed(format!("{}: cannot write: {e}", what.display()))
}

/// Checks the output paths before any work (`wheelset_report::output`): `files` and `dirs` as
/// `(flag, path)`; a path that cannot be written is bad input (exit code 2).
pub(crate) fn check_outputs(
    files: &[(&str, Option<&std::path::Path>)],
    dirs: &[(&str, Option<&std::path::Path>)],
) -> Result<(), Failure> {
    for (flag, p) in files {
        if let Some(p) = p {
            wheelset_report::output::check_file_flag(flag, p).map_err(Failure::bad)?;
        }
    }
    for (flag, d) in dirs {
        if let Some(d) = d {
            wheelset_report::output::check_dir_flag(flag, d).map_err(Failure::bad)?;
        }
    }
    Ok(())
}

pub(crate) fn load_params(path: &Option<PathBuf>) -> Result<Params, ConfigError> {
    match path {
        Some(p) => Params::from_file(p),
        None => Ok(Params::default()),
    }
}

pub(crate) fn warn(msg: &str) {
    eprintln!("sim-host: warning: {msg}");
}

/// Creates the file `path` (its directories too), buffered.
pub(crate) fn create_file(path: &std::path::Path) -> Result<BufWriter<std::fs::File>, Failure> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| io_fail(dir, e))?;
    }
    let f = std::fs::File::create(path).map_err(|e| io_fail(path, e))?;
    Ok(BufWriter::with_capacity(1 << 16, f))
}

/// Writes `value` as JSON to `path` (directories created), `pretty` or compact, and
/// prints `{shown} {path}`.
pub(crate) fn write_json(
    path: &std::path::Path,
    value: &impl serde::Serialize,
    pretty: bool,
    shown: &str,
) -> Result<(), Failure> {
    let mut f = create_file(path)?;
    let written = if pretty {
        serde_json::to_writer_pretty(&mut f, value)
    } else {
        serde_json::to_writer(&mut f, value)
    };
    written
        .map_err(std::io::Error::from)
        .and_then(|()| f.flush())
        .map_err(|e| io_fail(path, e))?;
    outln!("{shown} {}", path.display());
    Ok(())
}
