//! The verdict: the tolerances every figure is judged against, the pass/warn/fail
//! status (one type with the run budgets, [`wheelset_report::Verdict`]) and the judged
//! figure ([`Check`]).

use serde::Serialize;

/// Pass, warn or fail, ordered best to worst (the overall verdict is the maximum).
pub use wheelset_report::Verdict as Status;

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
    /// What to do when it does not pass (every check states one; [`Self::reason_and_remedy`]).
    pub remedy: String,
    /// The check could not run (e.g. the target comparison without QEMU): its status is
    /// `warn`, so the verdict does not claim it ([`counts_words`] counts it as not run).
    pub not_run: bool,
}

impl Check {
    /// A judged figure: `value` in `unit` against `(warn, fail)`, with its status and
    /// reason; no remedy yet ([`Self::with_remedy`]).
    #[must_use]
    pub fn new(
        controller: &str,
        item: &str,
        value: f64,
        (warn, fail): (f64, f64),
        unit: &str,
        status: Status,
        reason: String,
    ) -> Self {
        Self {
            controller: controller.to_string(),
            item: item.to_string(),
            value,
            warn,
            fail,
            unit: unit.to_string(),
            status,
            reason,
            remedy: String::new(),
            not_run: false,
        }
    }

    /// The check with its remedy.
    #[must_use]
    pub fn with_remedy(mut self, remedy: impl Into<String>) -> Self {
        self.remedy = remedy.into();
        self
    }

    /// A check that could not run: `item` and why, with the way to run it.
    #[must_use]
    pub fn not_run(controller: &str, item: &str, why: &str, remedy: &str) -> Self {
        let nan = f64::NAN;
        let reason = format!("not run: {why}");
        Self {
            remedy: remedy.to_string(),
            not_run: true,
            ..Self::new(controller, item, nan, (nan, nan), "", Status::Warn, reason)
        }
    }

    /// `reason`, then `; remedy: ...` for a check that did not pass.
    #[must_use]
    pub fn reason_and_remedy(&self) -> String {
        if self.status == Status::Pass || self.remedy.is_empty() {
            self.reason.clone()
        } else {
            format!("{}; remedy: {}", self.reason, self.remedy)
        }
    }
}

/// The counts of a verdict line in words: `136 pass, 1 warn, 0 fail` and `, 1 not run`
/// when any did not run (a check not run counts only as not run).
#[must_use]
pub fn counts_words(checks: &[Check]) -> String {
    let n = |st| {
        checks
            .iter()
            .filter(|c| c.status == st && !c.not_run)
            .count()
    };
    let (p, w, f) = (n(Status::Pass), n(Status::Warn), n(Status::Fail));
    let s = format!("{p} pass, {w} warn, {f} fail");
    match checks.iter().filter(|c| c.not_run).count() {
        0 => s,
        n => s + &format!(", {n} not run"),
    }
}

pub(crate) fn judge(
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
    Check::new(controller, item, value, (warn, fail), unit, status, reason)
}
