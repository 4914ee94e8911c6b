//! `hil audit`'s command line: the options, the usage/input errors, and what they
//! select (the formats, the configuration, the command line echoed in the report).

use std::path::PathBuf;

use wheelset_control::{Config, ConfigError};

use super::qdyn::{Formats, QFormat};

/// `hil audit` options.
#[derive(Clone, Debug, clap::Args)]
pub struct AuditArgs {
    /// Base tick rate, Hz (default: the control core's default). Both loops run at
    /// `rate / divisor`.
    #[arg(long, value_name = "HZ")]
    pub rate: Option<u32>,
    /// Yaw-loop divisor (default: the control core's).
    #[arg(long, value_name = "N")]
    pub yaw_divisor: Option<u16>,
    /// Traction-loop divisor (default: the control core's).
    #[arg(long, value_name = "N")]
    pub traction_divisor: Option<u16>,
    /// Parameter file (TOML, as `hil run --params`): the audited configuration takes
    /// its gains and motor constants (`wheelset_loop::device_loop::runtime_for`).
    #[arg(long, value_name = "FILE", value_parser = params_file)]
    pub params: Option<ParamsFile>,
    /// Write the JSON here.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write the Markdown report and its SVG plots into this directory.
    #[arg(long, value_name = "DIR")]
    pub report: Option<PathBuf>,
    /// Audit a different signal format `I.F` (integer bits incl. sign . fraction bits,
    /// word <= 32) instead of the production Q4.28, run through an instrumented type.
    #[arg(long, value_name = "I.F")]
    pub signal_q: Option<String>,
    /// Coefficient format `I.F` (production Q1.31).
    #[arg(long, value_name = "I.F")]
    pub coef_q: Option<String>,
    /// Skip the word-length bisection (faster; no fraction-bit recommendation).
    #[arg(long)]
    pub no_sweep: bool,
    /// The control core's y' predictor, base ticks (default: the core's default, 1.5;
    /// 0 = off); when on, the predictor is audited as a filter of its own.
    #[arg(long, value_name = "TICKS")]
    pub yaw_predict_ticks: Option<f64>,
    /// Skip the target (QEMU) comparison.
    #[arg(long)]
    pub no_target: bool,
    /// Ticks per scenario window sent to the target (QEMU exchanges ~300 ticks/s).
    #[arg(long, value_name = "N", default_value_t = 2000)]
    pub target_ticks: usize,
    /// Skip the closed-loop plant scenarios (curve, beating, fault runs).
    #[arg(long)]
    pub no_plant: bool,
    /// Skip the closed-loop audit (device in the loop, limit cycle, margins).
    #[arg(long)]
    pub no_closed_loop: bool,
    /// Print only the book's generated audit block (`wheelset_audit::readme_block`); skips the
    /// word-length sweep (its figure is not in the block).
    #[arg(long)]
    pub readme_block: bool,
    /// Print only the verdict lines.
    #[arg(long)]
    pub quiet: bool,
}

impl Default for AuditArgs {
    /// The command line's defaults: `hil audit` with no option.
    fn default() -> Self {
        #[derive(clap::Parser)]
        struct Cli {
            #[command(flatten)]
            args: AuditArgs,
        }
        <Cli as clap::Parser>::parse_from(["hil audit"]).args
    }
}

/// `--params FILE`: the file as given and the parameters it holds.
#[derive(Clone, Debug, PartialEq)]
pub struct ParamsFile {
    /// The file as given.
    pub path: PathBuf,
    /// Its parameters (validated against the plausible ranges).
    pub params: wheelset_plant::params::Params,
}

fn params_file(s: &str) -> Result<ParamsFile, String> {
    let path = PathBuf::from(s);
    let params = wheelset_plant::params::Params::from_file(&path).map_err(|e| e.to_string())?;
    Ok(ParamsFile { path, params })
}

/// Why the audit could not run (usage or input errors: exit code 2).
#[derive(Debug)]
pub enum AuditError {
    /// The configuration (rate, divisors, format) is refused by the control core.
    Config(ConfigError),
    /// A bad option value.
    Usage(String),
    /// Writing an output failed.
    Io {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
}

impl core::fmt::Display for AuditError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            AuditError::Config(e) => write!(f, "audit: configuration refused: {e}"),
            AuditError::Usage(s) => write!(f, "audit: {s}"),
            AuditError::Io { path, source } => {
                write!(f, "audit: cannot write `{}`: {source}", path.display())
            }
        }
    }
}

impl std::error::Error for AuditError {}

impl AuditError {
    pub(crate) fn io(path: &std::path::Path) -> impl FnOnce(std::io::Error) -> Self + '_ {
        move |source| AuditError::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

impl From<ConfigError> for AuditError {
    fn from(e: ConfigError) -> Self {
        AuditError::Config(e)
    }
}

/// Parse the format options.
pub(crate) fn formats_of(args: &AuditArgs) -> Result<Formats, AuditError> {
    let mut f = Formats::PRODUCTION;
    if let Some(s) = &args.signal_q {
        f.signal = QFormat::parse(s).map_err(|e| AuditError::Usage(format!("--signal-q {e}")))?;
    }
    if let Some(s) = &args.coef_q {
        f.coef = QFormat::parse(s).map_err(|e| AuditError::Usage(format!("--coef-q {e}")))?;
    }
    Ok(f)
}

/// The configuration audited: the control core's default (with the gains and motor
/// constants of `--params`) with the rate options; `--rate` takes the gains designed for
/// that rate with one tick of delay (`wheelset_control::design`) where it has a design.
pub fn config_of(args: &AuditArgs) -> Config {
    let mut c = args.params.as_ref().map_or_else(Config::default, |p| {
        wheelset_loop::device_loop::runtime_for(&p.params).control
    });
    if let Some(r) = args.rate {
        c = c.designed(r, 1).unwrap_or(Config {
            base_rate_hz: r,
            ..c
        });
    }
    if let Some(d) = args.yaw_divisor {
        c.yaw_divisor = d;
    }
    if let Some(d) = args.traction_divisor {
        c.traction_divisor = d;
    }
    if let Some(t) = args.yaw_predict_ticks {
        c.yaw_predict_ticks = t;
    }
    c
}

pub(crate) fn command_line(a: &AuditArgs) -> String {
    fn opt(v: Option<impl ToString>) -> Option<String> {
        v.map(|v| v.to_string())
    }
    let on = |switch: bool| switch.then(String::new);
    let flags = [
        ("--rate", opt(a.rate)),
        ("--yaw-divisor", opt(a.yaw_divisor)),
        ("--traction-divisor", opt(a.traction_divisor)),
        ("--params", opt(a.params.as_ref().map(|p| p.path.display()))),
        ("--yaw-predict-ticks", opt(a.yaw_predict_ticks)),
        ("--signal-q", a.signal_q.clone()),
        ("--coef-q", a.coef_q.clone()),
        ("--no-sweep", on(a.no_sweep)),
        ("--no-plant", on(a.no_plant)),
        ("--no-target", on(a.no_target)),
        ("--no-closed-loop", on(a.no_closed_loop)),
        ("--json", opt(a.json.as_ref().map(|p| p.display()))),
        ("--report", opt(a.report.as_ref().map(|p| p.display()))),
    ];
    let mut s = String::from("hil audit");
    for (flag, value) in flags {
        match value.as_deref() {
            Some("") => s += &format!(" {flag}"),
            Some(v) => s += &format!(" {flag} {v}"),
            None => {}
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::{command_line, AuditArgs};

    #[test]
    fn the_command_line_names_each_flag_given_in_order() {
        let a = AuditArgs {
            rate: Some(2_000),
            traction_divisor: Some(4),
            yaw_predict_ticks: Some(1.5),
            coef_q: Some("1.31".into()),
            no_sweep: true,
            no_closed_loop: true,
            report: Some("out".into()),
            ..AuditArgs::default()
        };
        assert_eq!(
            command_line(&a),
            "hil audit --rate 2000 --traction-divisor 4 --yaw-predict-ticks 1.5 --coef-q 1.31 \
             --no-sweep --no-closed-loop --report out"
        );
        assert_eq!(command_line(&AuditArgs::default()), "hil audit");
    }
}
