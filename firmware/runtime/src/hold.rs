//! The hold-safe policy as a pure state machine (`m`: ticks without a new frame):
//!
//! ```text
//! holding[n] = !fresh[n] && sampled[n]          (the tick runs on the held sample)
//! m[n]       = 0 if fresh[n], m[n-1] + 1 if holding[n] (saturating), else m[n-1]
//! safe[n]    = (sampled[n] && m[n] > hold_ticks) || alarm_safe[n]
//! ```

/// The policy's state: ticks without a new frame and whether the safe state is in force
/// (`Default`: idle, no tick missed, not safe).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HoldPolicy {
    missing: u32,
    safe: bool,
}

/// A change of the safe state decided by one tick.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SafeChange {
    /// The safe state is entered this tick.
    Enter,
    /// The safe state is left this tick.
    Exit,
}

/// What one tick of the policy decided.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HoldStep {
    /// The tick runs on the held sample ([`crate::Flags::HOLDING`]), safe or not.
    pub holding: bool,
    /// In the safe state this tick ([`crate::Flags::SAFE`], `safe_ticks`).
    pub safe: bool,
    /// Entered or left this tick (`safe_entries`, `safe_exits`), `None` if unchanged.
    pub change: Option<SafeChange>,
}

impl HoldPolicy {
    /// One tick: `fresh` a new Sensor frame, `sampled` any ever, `alarm_safe` an alarm's hold.
    #[inline]
    pub fn step(
        &mut self,
        fresh: bool,
        sampled: bool,
        hold_ticks: u16,
        alarm_safe: bool,
    ) -> HoldStep {
        let holding = !fresh && sampled;
        if fresh {
            self.missing = 0;
        } else if sampled {
            self.missing = self.missing.saturating_add(1);
        }
        let want = (sampled && self.missing > u32::from(hold_ticks)) || alarm_safe;
        let change = match (self.safe, want) {
            (false, true) => Some(SafeChange::Enter),
            (true, false) => Some(SafeChange::Exit),
            _ => None,
        };
        self.safe = want;
        HoldStep {
            holding,
            safe: want,
            change,
        }
    }

    /// In the safe state (as decided by the latest tick)?
    #[must_use]
    pub const fn is_safe(&self) -> bool {
        self.safe
    }

    /// Consecutive ticks without a new frame since a sample exists (saturating).
    #[must_use]
    pub const fn missing(&self) -> u32 {
        self.missing
    }
}
