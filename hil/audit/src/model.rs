//! The audit's result model: what `hil audit --json` writes (field names are an
//! interface, extend freely).

use serde::Serialize;

use super::bounds;
use super::limits::LimitCycle;
use super::on_target;
use super::qdyn::Formats;
use super::ranges::Observed;
use super::response::C64;
use super::tolerances::{Check, Status, Tolerances};

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
            gain: c.norm(),
            phase_deg: c.arg().to_degrees(),
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
    /// Peak magnitude observed, pu (0 when not observed).
    pub peak_pu: f64,
    /// Whether the scenarios observe this signal.
    pub observed: bool,
    /// Proven largest magnitude for any input within the clamps, pu.
    pub proven_max_pu: f64,
    /// Integer bits (incl. sign): the smallest holding the proven bound.
    pub int_bits: u32,
    /// Fraction bits.
    pub frac_bits: u32,
    /// Word length.
    pub word: u32,
    /// `Qi.f`.
    pub format: String,
    /// Where the integer bits come from, in words.
    pub margin: String,
    /// What the format guarantees (proven overflow freedom and output error).
    pub guarantee: String,
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
    /// Proven range per internal signal, next to the observed one.
    pub bounds: Vec<bounds::Bound>,
    /// Proven rounding error per output, next to the observed one.
    pub error_bounds: Vec<bounds::ErrorBound>,
    /// The WCPG of each linear part.
    pub linear_parts: Vec<bounds::LinearPart>,
    /// The stated result of the proofs.
    pub proof_statement: String,
    /// Every proven bound inside the audited format.
    pub overflow_free: bool,
    /// Recommended formats, from the proven bounds.
    pub recommendations: Vec<Recommendation>,
    /// The closed-loop audit (`null` with `--no-plant` / `--no-closed-loop`).
    pub closed_loop: Option<super::closed::ClosedLoopAudit>,
    /// Findings attributed by experiment (production formats only).
    pub diagnosis: Option<super::diagnose::Diagnosis>,
    /// The word-length sweep, if it ran.
    pub sweep: Option<Sweep>,
    /// Target comparison.
    pub target: on_target::TargetReport,
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
