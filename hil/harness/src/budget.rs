//! Budgets: the limits the checks compare against, with a pass/warn/fail verdict each
//! (`docs/harness.md`). Defaults below ([`Budgets::default`]); override them with a TOML
//! file (`--budget FILE`) and/or single keys (`--set timing.cpu_max.fail=0.5`), later
//! ones winning. The units are the sections' ([`TimingBudgets`], [`FrameBudgets`],
//! [`Tolerance`]); `warn = 0` warns on any occurrence ([`Limit`]).

use std::collections::BTreeMap;
use std::fmt;
use std::path::Path;

use serde::{Deserialize, Serialize};
use wheelset_plant::error::ConfigError;
use wheelset_report::Verdict;

/// A two-level limit: `value > warn` warns, `value > fail` fails.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Limit {
    /// Warning limit.
    pub warn: f64,
    /// Failure limit.
    pub fail: f64,
}

impl Limit {
    /// The limit a `verdict` crossed: the failure limit on a fail, else the warning one.
    #[must_use]
    pub fn crossed(&self, verdict: Verdict) -> f64 {
        if verdict == Verdict::Fail {
            self.fail
        } else {
            self.warn
        }
    }

    /// The verdict for `value` (NaN fails).
    #[must_use]
    pub fn judge(&self, value: f64) -> Verdict {
        if value.is_nan() || value > self.fail {
            Verdict::Fail
        } else if value > self.warn {
            Verdict::Warn
        } else {
            Verdict::Pass
        }
    }
}

const fn lim(warn: f64, fail: f64) -> Limit {
    Limit { warn, fail }
}

/// Timing budgets (fractions of the control period unless stated).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TimingBudgets {
    /// Largest input-to-output latency / T.
    pub latency_max: Limit,
    /// Largest deviation of the device's output instants from the ideal schedule / T.
    pub jitter_max: Limit,
    /// Fraction of periods without an actuation echoing their sample by the deadline.
    pub missed_frac: Limit,
    /// Fraction of ticks whose execution time exceeds T.
    pub overrun_frac: Limit,
    /// Largest execution time / T.
    pub cpu_max: Limit,
    /// Mean execution time / T.
    pub cpu_mean: Limit,
    /// Wire time of the mean bytes per period (both directions) / T.
    pub link: Limit,
}

impl Default for TimingBudgets {
    fn default() -> Self {
        Self {
            latency_max: lim(0.80, 1.00),
            jitter_max: lim(0.05, 0.10),
            missed_frac: lim(0.0, 0.01),
            overrun_frac: lim(0.0, 0.0),
            cpu_max: lim(0.50, 0.80),
            cpu_mean: lim(0.30, 0.60),
            link: lim(
                f64::from(wheelset_proto::link::LINK_SHARE_WARN_PERMILLE) / 1000.0,
                f64::from(wheelset_proto::link::LINK_SHARE_MAX_PERMILLE) / 1000.0,
            ),
        }
    }
}

/// Tolerance of one closed-loop signal against the reference.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Tolerance {
    /// Absolute tolerance, in the signal's unit.
    pub abs: f64,
    /// Relative tolerance, of the reference's peak |value| over the run.
    pub rel: f64,
    /// Time tolerance, s: each sample may be compared with the reference up to this much
    /// earlier or later.
    pub time_s: f64,
    /// The warning band: errors up to `warn_factor x (abs + rel x peak)` warn, beyond fail.
    pub warn_factor: f64,
}

impl Default for Tolerance {
    fn default() -> Self {
        Self {
            abs: 0.0,
            rel: 0.05,
            time_s: 0.002,
            warn_factor: 2.0,
        }
    }
}

/// The signals compared with the reference (CSV column names) and their default
/// tolerances: twice the fixed-point device's error or more (5 kHz, one tick of delay, lead
/// law, `curve`; README, "The harness (hil)"): a wrong sign or an unstable loop is far out.
pub fn default_tolerances() -> BTreeMap<String, Tolerance> {
    let t = |abs: f64, rel: f64, time_s: f64| Tolerance {
        abs,
        rel,
        time_s,
        ..Tolerance::default()
    };
    [
        ("y_m", t(2e-6, 0.01, 0.002)),
        ("psi_rad", t(1e-6, 0.05, 0.002)),
        ("T_ctrl_Nm", t(50.0, 0.1, 0.002)),
        // The control core slews the current reference (2e4 A/s: the 115 A step takes
        // 5.75 ms) where the reference steps: 8 ms of time tolerance covers the ramp.
        ("i_a_A", t(1.0, 0.02, 0.008)),
        ("u_a_V", t(1.0, 0.001, 0.008)),
    ]
    .into_iter()
    .map(|(k, v)| (k.to_string(), v))
    .collect()
}

/// Frame budgets (fractions of the frames sent, both directions together). The
/// accounting identity itself (`sent = received + rejected + dropped + in_flight`) is not
/// a budget: if it does not hold, the run fails.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FrameBudgets {
    /// Frames rejected by a receiver (CRC, COBS, length ...).
    pub rejected_frac: Limit,
    /// Frames dropped on the way.
    pub dropped_frac: Limit,
}

impl Default for FrameBudgets {
    fn default() -> Self {
        Self {
            rejected_frac: lim(0.0, 0.001),
            dropped_frac: lim(0.0, 0.001),
        }
    }
}

/// Every budget.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Budgets {
    /// Timing.
    pub timing: TimingBudgets,
    /// Frames.
    pub frames: FrameBudgets,
    /// Numerics, per signal (CSV column name).
    pub numerics: BTreeMap<String, Tolerance>,
}

impl Default for Budgets {
    fn default() -> Self {
        Self {
            timing: TimingBudgets::default(),
            frames: FrameBudgets::default(),
            numerics: default_tolerances(),
        }
    }
}

/// A budget file or `--set` that cannot be used: `SOURCE: REASON` (the reason names the key).
fn bad(source: &str, reason: impl fmt::Display) -> String {
    format!("{source}: {reason}")
}

fn merge(into: &mut toml::Table, from: toml::Table) {
    for (k, v) in from {
        match (into.get_mut(&k), v) {
            (Some(toml::Value::Table(a)), toml::Value::Table(b)) => merge(a, b),
            (_, v) => {
                into.insert(k, v);
            }
        }
    }
}

impl Budgets {
    /// The defaults, then `file`, then each `KEY=VALUE` of `sets` (TOML dotted keys and
    /// values, e.g. `timing.cpu_max.fail=0.5`, `numerics.y_m.rel=0.1`).
    pub fn load(file: Option<&Path>, sets: &[String]) -> Result<Self, String> {
        let mut table =
            toml::Table::try_from(Budgets::default()).map_err(|e| bad("defaults", e))?;
        let mut last = "defaults".to_string();
        if let Some(path) = file {
            let src = path.display().to_string();
            let text = wheelset_plant::input::read_input(path).map_err(|e| {
                let reason = match e {
                    ConfigError::Io { reason, .. } => format!("cannot read: {reason}"),
                    e => e.to_string(),
                };
                bad(&src, reason)
            })?;
            // Typed from the text itself first: an error names the key and line as written.
            if let Err(e) = toml::from_str::<Budgets>(&text) {
                let reason = match wheelset_plant::error::from_toml(&src, &text, &e) {
                    ConfigError::Parse {
                        key, line, reason, ..
                    } => {
                        let line = line.map_or(String::new(), |l| format!("line {l}: "));
                        let key = key.map_or(String::new(), |k| format!("key `{k}`: "));
                        format!("{line}{key}{reason}")
                    }
                    e => e.to_string(),
                };
                return Err(bad(&src, reason));
            }
            Self::layer(&mut table, &text, &src)?;
            last = src;
        }
        // Each `--set` typed alone (an error names it), the limits validated on the result
        // (a `warn`/`fail` pair may come in either order).
        for s in sets {
            let src = format!("--set {s}");
            if !s.contains('=') {
                return Err(bad(&src, "expected KEY=VALUE"));
            }
            Self::layer(&mut table, s, &src)?;
        }
        if !sets.is_empty() {
            last = if file.is_some() {
                format!("{last} with --set")
            } else {
                "--set".to_string()
            };
        }
        let b = Self::typed(table, &last)?;
        b.validate().map_err(|reason| bad(&last, reason))?;
        Ok(b)
    }

    fn layer(table: &mut toml::Table, text: &str, src: &str) -> Result<(), String> {
        let t: toml::Table = text
            .parse()
            .map_err(|e: toml::de::Error| bad(src, e.message()))?;
        merge(table, t);
        Self::typed(table.clone(), src).map(|_| ())
    }

    fn typed(t: toml::Table, src: &str) -> Result<Self, String> {
        t.try_into()
            .map_err(|e: toml::de::Error| bad(src, e.message()))
    }

    /// Refuses unknown signals, negative or NaN limits, and `warn > fail`.
    pub fn validate(&self) -> Result<(), String> {
        let t = &self.timing;
        for (name, l) in [
            ("timing.latency_max", t.latency_max),
            ("timing.jitter_max", t.jitter_max),
            ("timing.missed_frac", t.missed_frac),
            ("timing.overrun_frac", t.overrun_frac),
            ("timing.cpu_max", t.cpu_max),
            ("timing.cpu_mean", t.cpu_mean),
            ("timing.link", t.link),
            ("frames.rejected_frac", self.frames.rejected_frac),
            ("frames.dropped_frac", self.frames.dropped_frac),
        ] {
            if !(l.warn >= 0.0 && l.fail >= 0.0 && l.warn <= l.fail) {
                return Err(format!(
                    "{name}: need 0 <= warn <= fail, got warn = {}, fail = {}",
                    l.warn, l.fail
                ));
            }
        }
        let known = default_tolerances();
        for (name, tol) in &self.numerics {
            if !known.contains_key(name) {
                return Err(format!(
                    "numerics.{name}: unknown signal (known: {})",
                    known.keys().cloned().collect::<Vec<_>>().join(", ")
                ));
            }
            let ok = tol.abs >= 0.0
                && tol.rel >= 0.0
                && tol.time_s >= 0.0
                && tol.warn_factor >= 1.0
                && tol.time_s <= 1.0;
            if !ok {
                return Err(format!(
                    "numerics.{name}: need abs, rel >= 0, 0 <= time_s <= 1, warn_factor >= 1"
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn limits_judge_in_order() {
        let l = lim(0.5, 0.8);
        assert_eq!(l.judge(0.5), Verdict::Pass);
        assert_eq!(l.judge(0.6), Verdict::Warn);
        assert_eq!(l.judge(0.81), Verdict::Fail);
        assert_eq!(l.judge(f64::NAN), Verdict::Fail);
        assert!(Verdict::Pass < Verdict::Warn && Verdict::Warn < Verdict::Fail);
    }

    #[test]
    fn sets_override_and_bad_input_names_the_key() {
        let b = Budgets::load(
            None,
            &[
                "timing.cpu_max.fail=0.9".into(),
                "numerics.y_m.rel=0.1".into(),
            ],
        )
        .expect("valid");
        assert_eq!(b.timing.cpu_max.fail, 0.9);
        assert_eq!(b.timing.cpu_max.warn, 0.5);
        assert_eq!(b.numerics["y_m"].rel, 0.1);
        assert_eq!(b.numerics["y_m"].abs, default_tolerances()["y_m"].abs);
        for (bad, needle) in [
            ("timing.cpu_max.fail=-1", "warn <= fail"),
            ("timing.nope.fail=1", "unknown field"),
            ("numerics.z_m.rel=0.1", "unknown signal"),
            ("timing.cpu_max.fail='x'", "invalid type"),
            ("timing.cpu_max", "KEY=VALUE"),
        ] {
            let e = Budgets::load(None, &[bad.into()]).expect_err(bad);
            assert!(e.to_string().contains(needle), "{bad}: {e}");
        }
    }

    #[test]
    fn sets_are_validated_as_a_whole_in_any_order() {
        // warn 0.9 > the default fail 0.8 alone, but the pair is consistent.
        let pair = ["timing.cpu_max.warn=0.9", "timing.cpu_max.fail=0.95"];
        for order in [[0, 1], [1, 0]] {
            let sets: Vec<String> = order.iter().map(|&i| pair[i].to_string()).collect();
            let b = Budgets::load(None, &sets).expect("consistent pair");
            assert_eq!((b.timing.cpu_max.warn, b.timing.cpu_max.fail), (0.9, 0.95));
        }
        // An inconsistent pair is refused in both orders, naming the key.
        let bad = ["timing.cpu_max.warn=0.9", "timing.cpu_max.fail=0.85"];
        for order in [[0, 1], [1, 0]] {
            let sets: Vec<String> = order.iter().map(|&i| bad[i].to_string()).collect();
            let e = Budgets::load(None, &sets).expect_err("inconsistent pair");
            assert!(e.to_string().contains("timing.cpu_max"), "{e}");
        }
    }
}
