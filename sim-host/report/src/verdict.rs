//! The pass/warn/fail outcome of a check, shared by every report: the harness's run
//! checks against their budgets, the audit's judged figures, the sweep's points.

use std::fmt;

use serde::{Deserialize, Serialize};

/// A check's outcome, ordered from best to worst.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Verdict {
    /// Within budget.
    #[default]
    Pass,
    /// Above the warning limit.
    Warn,
    /// Above the failure limit.
    Fail,
}

impl Verdict {
    /// `"pass"`, `"warn"`, `"fail"` (as serialised).
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Pass => "pass",
            Self::Warn => "warn",
            Self::Fail => "fail",
        }
    }
}

impl fmt::Display for Verdict {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}
