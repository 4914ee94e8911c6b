//! `hil audit`: the fixed-point accuracy audit of the control core, per controller (yaw
//! lead, yaw pure gain, PI traction), at the configured rates and Q formats.
//!
//! What it computes, and how:
//!
//! - **Coefficients**: the f64 discretisation ([`wheelset_control::LeadParams::discretise`],
//!   [`wheelset_control::PiParams::discretise`]) against the quantised values the
//!   controller really multiplies by (read back from [`wheelset_control::Lead::quantised`]
//!   and [`wheelset_control::Pi::quantised`]); absolute and relative errors.
//! - **Poles, zeros, DC gain**: continuous (docs/model.md), discrete f64 and discrete
//!   quantised (from the direct form of each), the discrete roots also mapped back to
//!   rad/s by the inverse bilinear map; shifts between them. The fixed-point DC gain is
//!   *measured* with a constant input.
//! - **Frequency response**: continuous, discrete f64 (analytic), discrete quantised
//!   (analytic) and fixed point *measured* by driving the running controller with
//!   sinusoids and least-squares fitting; at 1, 10, 16, 50, 100 Hz and a log grid
//!   0.1 Hz .. 0.45 fs; worst errors below [`Tolerances::frac_fs`] of the rate.
//! - **Ranges and noise** ([`ranges`]): every signal and state over the scenarios, with
//!   headroom in bits and overflow counts; fixed minus f64 on the same inputs.
//! - **Limit cycles** ([`limits`]).
//! - **Recommended formats**: integer bits from the observed peaks plus a margin; the
//!   fraction bits from a bisection over the signal format (the smallest that passes
//!   every accuracy check, plus a margin).
//!
//! Every number is judged against [`Tolerances`] (stated in the report): pass, warn or
//! fail; the exit code is 1 on any fail.

pub mod limits;
pub mod plant;
pub mod plots;
pub mod qdyn;
pub mod ranges;
pub mod report;
pub mod response;
pub mod target;

use std::path::PathBuf;

use serde::Serialize;
use wheelset_control::{Config, ConfigError, Fx, Sample};

use limits::LimitCycle;
use qdyn::{Formats, QDyn, QFormat};
use ranges::{Observed, Scenario};
use response::{Coeffs, Kind, C64};

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
    /// Print only the verdict lines.
    #[arg(long)]
    pub quiet: bool,
}

impl Default for AuditArgs {
    fn default() -> Self {
        Self {
            rate: None,
            yaw_divisor: None,
            traction_divisor: None,
            json: None,
            report: None,
            signal_q: None,
            coef_q: None,
            no_sweep: false,
            no_plant: false,
            no_target: false,
            target_ticks: 2000,
            yaw_predict_ticks: None,
            quiet: true,
        }
    }
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

impl From<ConfigError> for AuditError {
    fn from(e: ConfigError) -> Self {
        AuditError::Config(e)
    }
}

/// The tolerances every figure is judged against. `warn` and `fail` are thresholds on
/// the magnitude of the stated quantity.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Tolerances {
    /// Accuracy is judged for `f <= frac_fs * rate` (0.1: 500 Hz at 5 kHz).
    pub frac_fs: f64,
    /// Fixed (measured) vs discrete f64 gain, dB: warn, fail.
    pub fixed_gain_db: (f64, f64),
    /// Fixed vs discrete f64 phase, degrees: warn, fail.
    pub fixed_phase_deg: (f64, f64),
    /// Discrete f64 vs continuous gain, dB (the discretisation itself).
    pub discrete_gain_db: (f64, f64),
    /// Discrete f64 vs continuous phase, degrees.
    pub discrete_phase_deg: (f64, f64),
    /// Coefficient relative quantisation error.
    pub coef_rel: (f64, f64),
    /// Relative shift of a pole or zero (equivalent rad/s), quantised vs f64.
    pub root_rel: (f64, f64),
    /// DC gain relative error, fixed (measured) vs continuous.
    pub dc_rel: (f64, f64),
    /// Headroom below which to warn / fail, bits.
    pub headroom_bits: (f64, f64),
    /// Max output error vs f64 over the scenarios, in wire LSBs of that output.
    pub noise_wire_lsb: (f64, f64),
    /// Limit-cycle amplitude / dead-band offset, wire LSBs of the output.
    pub limit_cycle_wire_lsb: (f64, f64),
    /// Max output error vs f64 during the safe-state ramps, fraction of the output limit.
    pub ramp_of_limit: (f64, f64),
}

impl Default for Tolerances {
    fn default() -> Self {
        Self {
            frac_fs: 0.1,
            fixed_gain_db: (1e-3, 1e-2),
            fixed_phase_deg: (1e-2, 1e-1),
            discrete_gain_db: (0.25, 1.0),
            discrete_phase_deg: (2.5, 10.0),
            coef_rel: (1e-5, 1e-3),
            root_rel: (1e-5, 1e-3),
            dc_rel: (1e-5, 1e-3),
            headroom_bits: (1.0, 0.0),
            noise_wire_lsb: (0.5, 2.0),
            limit_cycle_wire_lsb: (0.5, 2.0),
            ramp_of_limit: (1e-4, 1e-3),
        }
    }
}

/// Pass, warn or fail.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Status {
    /// Within the warn threshold.
    Pass,
    /// Between warn and fail.
    Warn,
    /// Beyond the fail threshold.
    Fail,
}

impl Status {
    /// `"pass"`, `"warn"`, `"fail"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Status::Pass => "pass",
            Status::Warn => "warn",
            Status::Fail => "fail",
        }
    }
}

/// One judged figure.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Check {
    /// Controller (or `all`).
    pub controller: String,
    /// What is judged.
    pub item: String,
    /// The figure.
    pub value: f64,
    /// Warn threshold.
    pub warn: f64,
    /// Fail threshold.
    pub fail: f64,
    /// Unit of the figure.
    pub unit: String,
    /// Verdict.
    pub status: Status,
    /// Why, in words.
    pub reason: String,
}

fn judge(
    controller: &str,
    item: &str,
    value: f64,
    (warn, fail): (f64, f64),
    unit: &str,
    what: &str,
) -> Check {
    let v = value.abs();
    let status = if !v.is_finite() || v > fail {
        Status::Fail
    } else if v > warn {
        Status::Warn
    } else {
        Status::Pass
    };
    let reason = match status {
        Status::Pass => format!("{what} {value:.3e} {unit} within {warn:.1e}"),
        Status::Warn => format!("{what} {value:.3e} {unit} above the warn level {warn:.1e}"),
        Status::Fail => format!("{what} {value:.3e} {unit} exceeds the tolerance {fail:.1e}"),
    };
    Check {
        controller: controller.to_string(),
        item: item.to_string(),
        value,
        warn,
        fail,
        unit: unit.to_string(),
        status,
        reason,
    }
}

/// Gain and phase.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct GainPhase {
    /// `|H|`, in the controller's unit.
    pub gain: f64,
    /// `arg H`, degrees.
    pub phase_deg: f64,
}

impl From<C64> for GainPhase {
    fn from(c: C64) -> Self {
        Self {
            gain: c.abs(),
            phase_deg: c.arg_deg(),
        }
    }
}

/// One frequency of the response table.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FreqPoint {
    /// Frequency, Hz.
    pub f_hz: f64,
    /// One of the named frequencies (1, 10, 16, 50, 100 Hz).
    pub named: bool,
    /// Continuous controller.
    pub continuous: GainPhase,
    /// Discrete, f64 coefficients (analytic).
    pub discrete_f64: GainPhase,
    /// Fixed point, measured on the running controller.
    pub fixed: GainPhase,
    /// Discrete, quantised coefficients (analytic).
    pub discrete_quantised: GainPhase,
    /// The f64 controller measured the same way (checks the measurement itself).
    pub discrete_f64_measured: GainPhase,
    /// `20 log10 |fixed/discrete_f64|`, dB.
    pub fixed_vs_f64_db: f64,
    /// `arg fixed - arg discrete_f64`, degrees.
    pub fixed_vs_f64_deg: f64,
    /// `20 log10 |discrete_f64/continuous|`, dB.
    pub f64_vs_continuous_db: f64,
    /// `arg discrete_f64 - arg continuous`, degrees.
    pub f64_vs_continuous_deg: f64,
}

/// DC gains (`null` = infinite: an integrator).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DcGain {
    /// Continuous.
    pub continuous: Option<f64>,
    /// Discrete f64 (analytic).
    pub discrete_f64: Option<f64>,
    /// Fixed point, measured (constant input until settled).
    pub fixed: Option<f64>,
    /// Discrete quantised (analytic).
    pub discrete_quantised: Option<f64>,
    /// Relative error fixed vs continuous.
    pub fixed_vs_continuous_rel: Option<f64>,
}

/// One coefficient.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct CoefRow {
    /// Name.
    pub name: String,
    /// Unit (SI).
    pub unit: String,
    /// f64 value, SI.
    pub ideal: f64,
    /// f64 value, per unit (what is quantised).
    pub ideal_pu: f64,
    /// Quantised value, SI.
    pub quantised: f64,
    /// `quantised - ideal`.
    pub abs_err: f64,
    /// `(quantised - ideal)/ideal`.
    pub rel_err: f64,
}

/// Poles and zeros of one form: z-plane (discrete) and s-plane (rad/s).
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Roots {
    /// Poles, z-plane (discrete forms only).
    pub poles_z: Vec<f64>,
    /// Zeros, z-plane.
    pub zeros_z: Vec<f64>,
    /// Poles, rad/s (continuous, or discrete mapped by the inverse bilinear map).
    pub poles_s: Vec<f64>,
    /// Zeros, rad/s.
    pub zeros_s: Vec<f64>,
}

/// Poles/zeros of the three forms and their shifts.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PoleZero {
    /// Continuous.
    pub continuous: Roots,
    /// Discrete f64.
    pub discrete_f64: Roots,
    /// Discrete quantised.
    pub discrete_quantised: Roots,
    /// Quantised minus f64, z-plane: poles then zeros.
    pub shift_quantisation_z: Vec<f64>,
    /// Quantised minus f64, rad/s, relative: poles then zeros.
    pub shift_quantisation_rel: Vec<f64>,
    /// Discrete f64 (mapped) minus continuous, rad/s: poles then zeros.
    pub shift_discretisation_s: Vec<f64>,
}

/// Worst errors below `frac_fs * rate`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Worst {
    /// The limit, Hz.
    pub below_hz: f64,
    /// Max |fixed vs f64| gain error, dB, and where.
    pub fixed_gain_db: (f64, f64),
    /// Max |fixed vs f64| phase error, deg, and where.
    pub fixed_phase_deg: (f64, f64),
    /// Max |f64 vs continuous| gain error, dB, and where.
    pub discrete_gain_db: (f64, f64),
    /// Max |f64 vs continuous| phase error, deg, and where.
    pub discrete_phase_deg: (f64, f64),
    /// Max |measured f64 vs analytic f64| gain error, dB (the measurement's own error).
    pub measurement_gain_db: f64,
}

/// The audit of one controller.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ControllerAudit {
    /// `yaw_lead`, `yaw_gain`, `traction_pi`.
    pub name: String,
    /// Sample rate, Hz.
    pub rate_hz: f64,
    /// The law and its discretisation.
    pub law: String,
    /// Gain unit.
    pub unit: String,
    /// Coefficients.
    pub coefficients: Vec<CoefRow>,
    /// Poles and zeros.
    pub poles_zeros: PoleZero,
    /// DC gains.
    pub dc_gain: DcGain,
    /// Frequency response, ascending frequency.
    pub freq_response: Vec<FreqPoint>,
    /// Worst errors.
    pub worst: Worst,
    /// Stimulus amplitude of the measurement, SI input unit.
    pub measure_amplitude: f64,
    /// Limit cycles and dead bands.
    pub limit_cycles: Vec<LimitCycle>,
}

/// A recommended format for one signal or state.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Recommendation {
    /// Signal name.
    pub signal: String,
    /// Controller.
    pub controller: String,
    /// Peak magnitude observed, pu.
    pub peak_pu: f64,
    /// Integer bits (incl. sign) needed for the peak, plus the margin.
    pub int_bits: u32,
    /// Fraction bits.
    pub frac_bits: u32,
    /// Word length.
    pub word: u32,
    /// `Qi.f`.
    pub format: String,
    /// The margin used, in words.
    pub margin: String,
}

/// The whole audit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Audit {
    /// The command that produced it.
    pub command: String,
    /// Base rate, Hz.
    pub base_rate_hz: u32,
    /// Signal and coefficient formats audited.
    pub formats: Formats,
    /// Whether this is the production fixed-point type (`Fx`) or the instrumented one.
    pub sample_type: String,
    /// Tolerances.
    pub tolerances: Tolerances,
    /// One entry per controller.
    pub controllers: Vec<ControllerAudit>,
    /// Ranges, noise, clamps over the scenarios.
    pub observed: Observed,
    /// The scenarios: `(name, source, ticks)`.
    pub scenarios: Vec<(String, String, usize)>,
    /// Scenarios that could not run, and why.
    pub scenario_notes: Vec<String>,
    /// Recommended formats.
    pub recommendations: Vec<Recommendation>,
    /// The signal fraction bits found by the bisection (smallest passing) and the
    /// coefficient fraction bits needed, if the sweep ran.
    pub sweep: Option<Sweep>,
    /// Target comparison.
    pub target: target::TargetReport,
    /// Every judged figure.
    pub checks: Vec<Check>,
    /// Worst status.
    pub verdict: Status,
}

/// Word-length sweep result.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Sweep {
    /// Smallest signal fraction bits (with the audited integer bits) passing every
    /// accuracy check.
    pub min_signal_frac_bits: Option<u32>,
    /// Evaluated `(frac bits, passed, first failing check)`.
    pub tried: Vec<(u32, bool, String)>,
    /// Smallest coefficient fraction bits for every coefficient within the warn
    /// relative error.
    pub min_coef_frac_bits: u32,
}

/// The named frequencies of issue 7, Hz.
pub const NAMED_HZ: [f64; 5] = [1.0, 10.0, 16.0, 50.0, 100.0];

/// The frequency grid: the named points plus 40 log-spaced points 0.1 Hz .. 0.45 fs.
pub fn grid(fs: f64) -> Vec<(f64, bool)> {
    let (a, b) = (0.1f64, 0.45 * fs);
    let n = 40;
    let mut v: Vec<(f64, bool)> = (0..n)
        .map(|i| (a * (b / a).powf(i as f64 / (n - 1) as f64), false))
        .filter(|(f, _)| !NAMED_HZ.iter().any(|g| (g - f).abs() < 1e-9))
        .collect();
    v.extend(
        NAMED_HZ
            .iter()
            .filter(|f| **f < 0.5 * fs)
            .map(|f| (*f, true)),
    );
    v.sort_by(|x, y| x.0.total_cmp(&y.0));
    v
}

/// Audit one controller with sample type `T`.
pub fn audit_controller<T: Sample>(
    kind: Kind,
    cfg: &Config,
    tol: &Tolerances,
    lsb: f64,
    freqs: &[(f64, bool)],
) -> Result<ControllerAudit, ConfigError> {
    let fs = kind.rate_hz(cfg);
    let t_s = 1.0 / fs;
    let (ideal, quant) = response::coefficients::<T>(kind, cfg)?;
    let coefficients = ideal
        .list()
        .iter()
        .zip(quant.list())
        .map(|((n, v, u, scaled), (_, q, _, _))| CoefRow {
            name: n.to_string(),
            unit: u.to_string(),
            ideal_pu: if *scaled { v / kind.pu_to_si(cfg) } else { *v },
            ideal: *v,
            quantised: q,
            abs_err: q - v,
            rel_err: if *v != 0.0 { (q - v) / v } else { 0.0 },
        })
        .collect();
    let (cp, cz, cdc) = response::continuous_pz(kind, cfg);
    let roots = |c: &Coeffs| {
        let (p, z) = c.poles_zeros();
        Roots {
            poles_s: p.iter().map(|&r| response::z_to_s(r, t_s)).collect(),
            zeros_s: z.iter().map(|&r| response::z_to_s(r, t_s)).collect(),
            poles_z: p,
            zeros_z: z,
        }
    };
    let rf = roots(&ideal);
    let rq = roots(&quant);
    let cat = |r: &Roots, s: bool| -> Vec<f64> {
        if s {
            r.poles_s.iter().chain(&r.zeros_s).copied().collect()
        } else {
            r.poles_z.iter().chain(&r.zeros_z).copied().collect()
        }
    };
    let cont = Roots {
        poles_z: vec![],
        zeros_z: vec![],
        poles_s: cp,
        zeros_s: cz,
    };
    let poles_zeros = PoleZero {
        shift_quantisation_z: cat(&rq, false)
            .iter()
            .zip(cat(&rf, false))
            .map(|(a, b)| a - b)
            .collect(),
        shift_quantisation_rel: cat(&rq, true)
            .iter()
            .zip(cat(&rf, true))
            .map(|(a, b)| if b != 0.0 { (a - b) / b } else { a - b })
            .collect(),
        shift_discretisation_s: cat(&rf, true)
            .iter()
            .zip(cat(&cont, true))
            .map(|(a, b)| a - b)
            .collect(),
        continuous: cont,
        discrete_f64: rf,
        discrete_quantised: rq,
    };
    let fixed_dc = response::measured_dc::<T>(kind, cfg)?;
    let dc_gain = DcGain {
        continuous: cdc,
        discrete_f64: ideal.dc_gain(),
        fixed: fixed_dc,
        discrete_quantised: quant.dc_gain(),
        fixed_vs_continuous_rel: match (fixed_dc, cdc) {
            (Some(a), Some(b)) => Some((a - b) / b),
            _ => None,
        },
    };
    let mut freq_response = Vec::with_capacity(freqs.len());
    for &(f, named) in freqs {
        if f >= 0.5 * fs {
            continue;
        }
        let c = response::continuous(kind, cfg, f);
        let d = ideal.response(f, t_s);
        let dq = quant.response(f, t_s);
        let fx = response::measured::<T>(kind, cfg, f)?;
        let fm = response::measured::<f64>(kind, cfg, f)?;
        freq_response.push(FreqPoint {
            f_hz: f,
            named,
            continuous: c.into(),
            discrete_f64: d.into(),
            fixed: fx.into(),
            discrete_quantised: dq.into(),
            discrete_f64_measured: fm.into(),
            fixed_vs_f64_db: response::gain_err_db(fx, d),
            fixed_vs_f64_deg: response::phase_err_deg(fx, d),
            f64_vs_continuous_db: response::gain_err_db(d, c),
            f64_vs_continuous_deg: response::phase_err_deg(d, c),
        });
    }
    let below = tol.frac_fs * fs;
    let worst_of = |g: &dyn Fn(&FreqPoint) -> f64| {
        freq_response
            .iter()
            .filter(|p| p.f_hz <= below)
            .map(|p| (g(p), p.f_hz))
            .fold(
                (0.0f64, 0.0f64),
                |a, b| if b.0.abs() > a.0.abs() { b } else { a },
            )
    };
    let worst = Worst {
        below_hz: below,
        fixed_gain_db: worst_of(&|p| p.fixed_vs_f64_db),
        fixed_phase_deg: worst_of(&|p| p.fixed_vs_f64_deg),
        discrete_gain_db: worst_of(&|p| p.f64_vs_continuous_db),
        discrete_phase_deg: worst_of(&|p| p.f64_vs_continuous_deg),
        measurement_gain_db: freq_response
            .iter()
            .map(|p| (20.0 * (p.discrete_f64_measured.gain / p.discrete_f64.gain).log10()).abs())
            .fold(0.0, f64::max),
    };
    let limit_cycles = limits::limit_cycles::<T>(kind, cfg, lsb)?;
    Ok(ControllerAudit {
        name: kind.name().to_string(),
        rate_hz: fs,
        law: kind.law().to_string(),
        unit: kind.unit().to_string(),
        coefficients,
        poles_zeros,
        dc_gain,
        freq_response,
        worst,
        measure_amplitude: response::measure_amplitude(kind),
        limit_cycles,
    })
}

/// Judge one controller's figures.
pub fn controller_checks(a: &ControllerAudit, tol: &Tolerances, cfg: &Config) -> Vec<Check> {
    let n = &a.name;
    let mut v = Vec::new();
    for c in &a.coefficients {
        v.push(judge(
            n,
            &format!("coefficient {} relative quantisation error", c.name),
            c.rel_err,
            tol.coef_rel,
            "",
            "relative error",
        ));
    }
    for (i, s) in a.poles_zeros.shift_quantisation_rel.iter().enumerate() {
        v.push(judge(
            n,
            &format!("root {i} relative shift (quantised vs f64)"),
            *s,
            tol.root_rel,
            "",
            "relative shift",
        ));
    }
    if let Some(r) = a.dc_gain.fixed_vs_continuous_rel {
        v.push(judge(
            n,
            "DC gain, fixed (measured) vs continuous",
            r,
            tol.dc_rel,
            "",
            "relative error",
        ));
    }
    let w = &a.worst;
    v.push(judge(
        n,
        &format!(
            "gain error fixed vs f64 below {:.0} Hz (worst at {:.3} Hz)",
            w.below_hz, w.fixed_gain_db.1
        ),
        w.fixed_gain_db.0,
        tol.fixed_gain_db,
        "dB",
        "gain error",
    ));
    v.push(judge(
        n,
        &format!(
            "phase error fixed vs f64 below {:.0} Hz (worst at {:.3} Hz)",
            w.below_hz, w.fixed_phase_deg.1
        ),
        w.fixed_phase_deg.0,
        tol.fixed_phase_deg,
        "deg",
        "phase error",
    ));
    if n == "yaw_predictor" {
        // The predictor approximates an ideal advance by design; its deviation from it
        // is the sampled-data analysis' business, not a numerics figure: not judged.
        return v;
    }
    v.push(judge(
        n,
        &format!(
            "gain error discrete f64 vs continuous below {:.0} Hz (worst at {:.3} Hz)",
            w.below_hz, w.discrete_gain_db.1
        ),
        w.discrete_gain_db.0,
        tol.discrete_gain_db,
        "dB",
        "discretisation gain error",
    ));
    v.push(judge(
        n,
        &format!(
            "phase error discrete f64 vs continuous below {:.0} Hz (worst at {:.3} Hz)",
            w.below_hz, w.discrete_phase_deg.1
        ),
        w.discrete_phase_deg.0,
        tol.discrete_phase_deg,
        "deg",
        "discretisation phase error",
    ));
    let wire = match n.as_str() {
        "traction_pi" => cfg.wire.voltage,
        _ => cfg.wire.torque,
    };
    for lc in &a.limit_cycles {
        v.push(judge(
            n,
            &format!("limit cycle amplitude, hold {}", lc.hold),
            lc.amplitude_si / wire,
            tol.limit_cycle_wire_lsb,
            "wire LSB",
            "sustained oscillation amplitude",
        ));
        v.push(judge(
            n,
            &format!("dead-band offset vs f64, hold {}", lc.hold),
            lc.offset_si / wire,
            tol.limit_cycle_wire_lsb,
            "wire LSB",
            "final offset",
        ));
    }
    v
}

/// Judge ranges and noise.
pub fn observed_checks(o: &Observed, tol: &Tolerances) -> Vec<Check> {
    let mut v = Vec::new();
    for s in &o.signals {
        if s.samples == 0 {
            continue;
        }
        let mut c = judge(
            &s.controller,
            &format!("{} overflows (outside the signal format)", s.name),
            s.overflows as f64,
            (0.0, 0.0),
            "samples",
            "overflowed samples",
        );
        if s.overflows > 0 {
            c.reason = format!(
                "{} overflows: {} samples outside the signal format (peak {:.3} pu, headroom \
                 {:.2} bits) in scenario {}",
                s.name,
                s.overflows,
                s.min_pu.abs().max(s.max_pu.abs()),
                s.headroom_bits,
                s.worst_scenario
            );
        }
        v.push(c);
        let h = s.headroom_bits;
        let status = if h < tol.headroom_bits.1 {
            Status::Fail
        } else if h < tol.headroom_bits.0 {
            Status::Warn
        } else {
            Status::Pass
        };
        v.push(Check {
            controller: s.controller.clone(),
            item: format!("{} headroom", s.name),
            value: h,
            warn: tol.headroom_bits.0,
            fail: tol.headroom_bits.1,
            unit: "bits".into(),
            status,
            reason: format!(
                "headroom {h:.2} bits (warn below {} bits, fail below {})",
                tol.headroom_bits.0, tol.headroom_bits.1
            ),
        });
    }
    for nz in &o.noise {
        let ctrl = if nz.output == "u_a" {
            "traction_pi".to_string()
        } else {
            format!("yaw_{}", nz.yaw_mode)
        };
        v.push(match nz.phase {
            ranges::Phase::Normal => judge(
                &ctrl,
                &format!("{} max error vs f64, scenario {}", nz.output, nz.scenario),
                nz.max_wire_lsb,
                tol.noise_wire_lsb,
                "wire LSB",
                "max quantisation error",
            ),
            ranges::Phase::SafeRamp => judge(
                &ctrl,
                &format!(
                    "{} max error vs f64 during the safe-state ramps, scenario {}",
                    nz.output, nz.scenario
                ),
                nz.max_of_limit,
                tol.ramp_of_limit,
                "of the output limit",
                "ramp-profile error (quantised per-step increment, accumulated)",
            ),
        });
    }
    v
}

/// Parse the format options.
fn formats_of(args: &AuditArgs) -> Result<Formats, AuditError> {
    let mut f = Formats::PRODUCTION;
    if let Some(s) = &args.signal_q {
        f.signal = QFormat::parse(s).map_err(|e| AuditError::Usage(format!("--signal-q {e}")))?;
    }
    if let Some(s) = &args.coef_q {
        f.coef = QFormat::parse(s).map_err(|e| AuditError::Usage(format!("--coef-q {e}")))?;
    }
    Ok(f)
}

/// The configuration audited: the control core's default with the rate options.
pub fn config_of(args: &AuditArgs) -> Config {
    let mut c = Config::default();
    if let Some(r) = args.rate {
        c.base_rate_hz = r;
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

/// Every accuracy figure of sample type `T` (no recommendation, no sweep).
pub struct Core {
    /// Per controller.
    pub controllers: Vec<ControllerAudit>,
    /// Ranges and noise.
    pub observed: Observed,
}

/// Run the per-controller audits and the scenario observation with `T`.
pub fn core<T: Sample>(
    cfg: &Config,
    tol: &Tolerances,
    fmt: &Formats,
    scenarios: &[Scenario],
    freqs_of: &dyn Fn(f64) -> Vec<(f64, bool)>,
) -> Result<Core, ConfigError> {
    let lsb = fmt.signal.lsb();
    let controllers = Kind::active(cfg)
        .iter()
        .map(|&k| audit_controller::<T>(k, cfg, tol, lsb, &freqs_of(k.rate_hz(cfg))))
        .collect::<Result<Vec<_>, _>>()?;
    let observed = ranges::observe::<T>(cfg, scenarios, fmt.signal)?;
    Ok(Core {
        controllers,
        observed,
    })
}

fn all_checks(c: &Core, tol: &Tolerances, cfg: &Config) -> Vec<Check> {
    let mut v: Vec<Check> = c
        .controllers
        .iter()
        .flat_map(|a| controller_checks(a, tol, cfg))
        .collect();
    v.extend(observed_checks(&c.observed, tol));
    v
}

/// Run the core with the instrumented type at `fmt` (counting arithmetic saturations).
fn core_dyn(
    cfg: &Config,
    tol: &Tolerances,
    fmt: Formats,
    scenarios: &[Scenario],
    freqs_of: &dyn Fn(f64) -> Vec<(f64, bool)>,
) -> Result<Core, ConfigError> {
    qdyn::with_formats(fmt, || {
        qdyn::take_saturations();
        let mut c = core::<QDyn>(cfg, tol, &fmt, scenarios, freqs_of)?;
        c.observed.arithmetic_saturations = Some(qdyn::take_saturations());
        Ok(c)
    })
}

/// Bisection over the signal fraction bits (integer bits as audited) for the smallest
/// format passing every accuracy check on the synthetic scenarios and the named
/// frequencies.
fn sweep(cfg: &Config, tol: &Tolerances, fmt: &Formats, coefs: &[CoefRow]) -> Sweep {
    let scen = ranges::synthetic(cfg);
    let named = |fs: f64| -> Vec<(f64, bool)> {
        NAMED_HZ
            .iter()
            .filter(|f| **f < tol.frac_fs * fs)
            .map(|f| (*f, true))
            .collect()
    };
    let max_f = 32 - fmt.signal.int_bits;
    let mut tried = Vec::new();
    let mut eval = |f: u32| -> bool {
        let mut fm = *fmt;
        fm.signal = QFormat::new(fmt.signal.int_bits, f);
        let r = core_dyn(cfg, tol, fm, &scen, &named);
        let (ok, why) = match r {
            Ok(c) => {
                let checks = all_checks(&c, tol, cfg);
                match checks.iter().find(|c| c.status == Status::Fail) {
                    Some(c) => (false, format!("{}: {}", c.controller, c.reason)),
                    None => (true, String::new()),
                }
            }
            Err(e) => (false, e.to_string()),
        };
        tried.push((f, ok, why));
        ok
    };
    let (mut lo, mut hi) = (4u32, max_f);
    let min = if !eval(hi) {
        None
    } else {
        while hi - lo > 1 {
            let mid = (lo + hi) / 2;
            if eval(mid) {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        Some(hi)
    };
    tried.sort_by_key(|t| t.0);
    // Coefficients: a relative error <= warn needs 2^-(F+1) <= warn |c_pu|.
    let min_coef = coefs
        .iter()
        .filter(|c| c.ideal_pu != 0.0)
        .map(|c| {
            (-(tol.coef_rel.0 * c.ideal_pu.abs()).log2() - 1.0)
                .ceil()
                .max(0.0) as u32
        })
        .max()
        .unwrap_or(0);
    Sweep {
        min_signal_frac_bits: min,
        tried,
        min_coef_frac_bits: min_coef,
    }
}

/// Run the audit as `hil audit` does; returns the exit code (0 pass/warn, 1 fail).
pub fn run(args: &AuditArgs) -> Result<u8, AuditError> {
    let audit = build(args)?;
    if let Some(p) = &args.json {
        let s = serde_json::to_string_pretty(&audit).map_err(|e| AuditError::Io {
            path: p.clone(),
            source: std::io::Error::other(e),
        })?;
        write(p, &s)?;
    }
    if let Some(dir) = &args.report {
        report::write_report(&audit, dir)?;
    }
    print!("{}", report::summary(&audit, args.quiet));
    Ok(if audit.verdict == Status::Fail { 1 } else { 0 })
}

/// Write `s` to `p`, creating the parent directory.
pub(crate) fn write(p: &std::path::Path, s: &str) -> Result<(), AuditError> {
    if let Some(d) = p.parent() {
        if !d.as_os_str().is_empty() {
            std::fs::create_dir_all(d).map_err(|e| AuditError::Io {
                path: d.to_path_buf(),
                source: e,
            })?;
        }
    }
    std::fs::write(p, s).map_err(|e| AuditError::Io {
        path: p.to_path_buf(),
        source: e,
    })
}

/// Compute the whole audit (no output written).
pub fn build(args: &AuditArgs) -> Result<Audit, AuditError> {
    let fmt = formats_of(args)?;
    let cfg = config_of(args);
    cfg.validate()?;
    let tol = Tolerances::default();
    let mut scenarios = ranges::synthetic(&cfg);
    let mut scenario_notes = Vec::new();
    if args.no_plant {
        scenario_notes.push("closed-loop plant scenarios skipped (--no-plant)".to_string());
    } else {
        let (s, n) = plant::scenarios(&cfg);
        scenarios.extend(s);
        scenario_notes.extend(n);
    }
    let production = fmt == Formats::PRODUCTION;
    let c = if production {
        let mut c = core::<Fx>(&cfg, &tol, &fmt, &scenarios, &|fs| grid(fs))?;
        // The instrumented type is bit-identical at the production formats; run it over
        // the scenarios too to count the arithmetic saturations Fx performs silently.
        let o = qdyn::with_formats(fmt, || {
            qdyn::take_saturations();
            ranges::observe::<QDyn>(&cfg, &scenarios, fmt.signal).map(|_| qdyn::take_saturations())
        })?;
        c.observed.arithmetic_saturations = Some(o);
        c
    } else {
        core_dyn(&cfg, &tol, fmt, &scenarios, &|fs| grid(fs))?
    };
    let mut checks = all_checks(&c, &tol, &cfg);
    if let Some(n) = c.observed.arithmetic_saturations {
        checks.push(judge(
            "all",
            "saturations inside the fixed-point arithmetic (instrumented run)",
            n as f64,
            (0.0, 0.0),
            "operations",
            "saturating operations",
        ));
    }
    let coefs: Vec<CoefRow> = c
        .controllers
        .iter()
        .flat_map(|a| a.coefficients.clone())
        .collect();
    let sweep = (!args.no_sweep).then(|| sweep(&cfg, &tol, &fmt, &coefs));
    let recommendations = recommend(&c.observed, &fmt, sweep.as_ref(), &cfg);
    let target = if args.no_target {
        target::TargetReport {
            available: false,
            note: "target: not run (--no-target)".into(),
            runs: Vec::new(),
        }
    } else if !production {
        target::TargetReport {
            available: false,
            note: "target: not applicable (the firmware runs the production formats)".into(),
            runs: Vec::new(),
        }
    } else {
        let pick = |n: &str| scenarios.iter().find(|s| s.name == n);
        let mut w: Vec<(&Scenario, f64)> = Vec::new();
        for (n, from) in [("full_scale_steps", 0.0), ("chirp", 0.0), ("curve", 4.8)] {
            if let Some(s) = pick(n) {
                w.push((s, from));
            }
        }
        target::compare(&w, args.target_ticks, &cfg)
    };
    for r in &target.runs {
        let mut c = judge(
            "all",
            &format!(
                "target vs host Actuation frames, scenario {} ({} ticks)",
                r.scenario, r.ticks
            ),
            r.mismatches as f64,
            (0.0, 0.0),
            "frames",
            "frames differing",
        );
        c.reason = format!(
            "{} of {} frames differ between QEMU and the host (max code difference T_psi {} \
             dNm, u_a {} cV); target vs f64 max {:.1}/{:.1} wire LSB, host vs f64 {:.1}/{:.1}",
            r.mismatches,
            r.ticks,
            r.max_code_diff.0,
            r.max_code_diff.1,
            r.target_vs_f64_wire_lsb.0,
            r.target_vs_f64_wire_lsb.1,
            r.host_vs_f64_wire_lsb.0,
            r.host_vs_f64_wire_lsb.1
        );
        checks.push(c);
    }
    let verdict = checks
        .iter()
        .map(|c| c.status)
        .max()
        .unwrap_or(Status::Pass);
    Ok(Audit {
        command: command_line(args),
        base_rate_hz: cfg.base_rate_hz,
        formats: fmt,
        sample_type: if production {
            "wheelset_control::Fx (Q4.28) with Coef (Q1.31): the production type".into()
        } else {
            format!(
                "instrumented fixed point, signals {} coefficients {}",
                fmt.signal, fmt.coef
            )
        },
        tolerances: tol,
        controllers: c.controllers,
        observed: c.observed,
        scenarios: scenarios
            .iter()
            .map(|s| (s.name.clone(), s.source.clone(), s.ticks.len()))
            .collect(),
        scenario_notes,
        recommendations,
        sweep,
        target,
        checks,
        verdict,
    })
}

fn command_line(a: &AuditArgs) -> String {
    let mut s = String::from("hil audit");
    if let Some(r) = a.rate {
        s += &format!(" --rate {r}");
    }
    if let Some(d) = a.yaw_divisor {
        s += &format!(" --yaw-divisor {d}");
    }
    if let Some(d) = a.traction_divisor {
        s += &format!(" --traction-divisor {d}");
    }
    if let Some(t) = a.yaw_predict_ticks {
        s += &format!(" --yaw-predict-ticks {t}");
    }
    if let Some(q) = &a.signal_q {
        s += &format!(" --signal-q {q}");
    }
    if let Some(q) = &a.coef_q {
        s += &format!(" --coef-q {q}");
    }
    if a.no_sweep {
        s += " --no-sweep";
    }
    if a.no_plant {
        s += " --no-plant";
    }
    if a.no_target {
        s += " --no-target";
    }
    if let Some(p) = &a.json {
        s += &format!(" --json {}", p.display());
    }
    if let Some(p) = &a.report {
        s += &format!(" --report {}", p.display());
    }
    s
}

/// Recommended word and fraction lengths per signal: integer bits for the observed
/// peak plus one bit of margin (a factor 2); fraction bits from the sweep plus two bits
/// of margin (a factor 4 on the error), or the audited ones without a sweep.
fn recommend(
    o: &Observed,
    fmt: &Formats,
    sw: Option<&Sweep>,
    _cfg: &Config,
) -> Vec<Recommendation> {
    let frac = sw
        .and_then(|s| s.min_signal_frac_bits)
        .map(|f| (f + 2).min(31))
        .unwrap_or(fmt.signal.frac_bits);
    let fmargin = if sw.and_then(|s| s.min_signal_frac_bits).is_some() {
        "+2 fraction bits over the smallest passing format"
    } else {
        "fraction bits as audited (no sweep)"
    };
    o.signals
        .iter()
        .filter(|s| s.samples > 0)
        .map(|s| {
            let peak = s.min_pu.abs().max(s.max_pu.abs());
            // 2^(i-1) > peak  <=>  i = floor(log2 peak) + 2; +1 bit margin.
            let need = if peak > 0.0 {
                (peak.log2().floor() as i64 + 2).max(1) as u32
            } else {
                1
            };
            let int_bits = need + 1;
            let word = int_bits + frac;
            let note = if word > 32 {
                format!(
                    "; {word} bits exceed an i32: in 32 bits keep Q{}.{} (margin {} bits)",
                    need,
                    32 - need,
                    (32 - need) as i64 - frac as i64 + 2
                )
            } else {
                String::new()
            };
            Recommendation {
                signal: s.name.clone(),
                controller: s.controller.clone(),
                peak_pu: peak,
                int_bits,
                frac_bits: frac,
                word,
                format: format!("Q{int_bits}.{frac}"),
                margin: format!("+1 integer bit (x2) over the observed peak; {fmargin}{note}"),
            }
        })
        .collect()
}

/// Identity check used by tests and the report: run `T` and the instrumented type at
/// `fmt` side by side on `xs` (pu, y' and current) and count differing output bits.
pub fn bit_identical_to_fx(xs: &[(f64, f64)]) -> bool {
    let cfg = Config::default();
    let Ok(mut a) = wheelset_control::Controller::<Fx>::try_new(&cfg) else {
        return false;
    };
    qdyn::with_formats(Formats::PRODUCTION, || {
        let Ok(mut b) = wheelset_control::Controller::<QDyn>::try_new(&cfg) else {
            return false;
        };
        xs.iter().all(|&(y, i)| {
            let oa = a.tick(&wheelset_control::Inputs {
                y_dot: Fx::from_f64(y),
                current: Fx::from_f64(i),
                speed: Fx::from_f64(0.9256),
                demand: Fx::from_f64(0.246),
            });
            let ob = b.tick(&wheelset_control::Inputs {
                y_dot: QDyn::from_f64(y),
                current: QDyn::from_f64(i),
                speed: QDyn::from_f64(0.9256),
                demand: QDyn::from_f64(0.246),
            });
            oa.yaw_torque.to_bits() as i64 == ob.yaw_torque.0
                && oa.voltage.to_bits() as i64 == ob.voltage.0
        })
    })
}
