//! The missed-tick policy, `lateness = now - deadline` (1 us ticks): on time up to
//! `late_after`, late below a period, else `missed = floor(lateness / period)` deadlines
//! skipped and the next at `deadline + (missed + 1) * period` (no burst of catch-up ticks).

/// What the control task must do after a wake-up.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TickWake {
    /// Run the tick; the ticker's own next deadline is right.
    OnTime,
    /// Run the tick; it started `lateness` ticks after its deadline (less than a period).
    Late {
        /// Timer ticks after the deadline.
        lateness: u64,
    },
    /// Run the tick once; `missed` deadlines were skipped; re-arm the ticker at `next_deadline`.
    Skipped {
        /// Deadlines that passed without a tick.
        missed: u32,
        /// The next deadline on the phase grid, in timer ticks.
        next_deadline: u64,
    },
}

/// A configuration the monitor refuses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TickConfigError {
    /// The period is zero.
    ZeroPeriod,
    /// `late_after` is not below the period.
    LateAfterNotBelowPeriod,
}

/// Tracks the deadlines of a fixed-period tick and applies the skip policy.
#[derive(Clone, Debug)]
pub struct TickMonitor {
    period: u64,
    late_after: u64,
    next_deadline: u64,
}

impl TickMonitor {
    /// A monitor for ticks every `period`, the first at `first_deadline`, late after `late_after`.
    pub fn try_new(
        period: u64,
        first_deadline: u64,
        late_after: u64,
    ) -> Result<Self, TickConfigError> {
        if period == 0 {
            return Err(TickConfigError::ZeroPeriod);
        }
        if late_after >= period {
            return Err(TickConfigError::LateAfterNotBelowPeriod);
        }
        Ok(Self {
            period,
            late_after,
            next_deadline: first_deadline,
        })
    }

    /// A new period and first deadline, late after a quarter period.
    pub fn rearm(&mut self, period: u64, first_deadline: u64) {
        self.period = period.max(1);
        self.late_after = self.period / 4;
        self.next_deadline = first_deadline;
    }

    /// Classifies a wake-up at `now` and advances the schedule (early counts as on time).
    pub fn on_wake(&mut self, now: u64) -> TickWake {
        let deadline = self.next_deadline;
        let lateness = now.saturating_sub(deadline);
        if lateness < self.period {
            self.next_deadline = deadline.saturating_add(self.period);
            if lateness > self.late_after {
                TickWake::Late { lateness }
            } else {
                TickWake::OnTime
            }
        } else {
            // 32-bit division (a u64 one pulls in a library routine).
            let period32 = u32::try_from(self.period).unwrap_or(u32::MAX);
            let missed = u32::try_from(lateness).unwrap_or(u32::MAX) / period32;
            let next_deadline =
                deadline.saturating_add((u64::from(missed) + 1).saturating_mul(self.period));
            self.next_deadline = next_deadline;
            TickWake::Skipped {
                missed,
                next_deadline,
            }
        }
    }
}

/// The tick period in 1 us ticks of a base rate, `1e6 / hz`, if whole.
pub fn period_ticks(hz: u32) -> Option<u64> {
    let timer = crate::settings::TIMER_HZ;
    if hz == 0 || hz > timer || !timer.is_multiple_of(hz) {
        None
    } else {
        Some(u64::from(timer / hz))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const T: u64 = 250; // 4 kHz at 1 us per timer tick

    #[test]
    fn periods_must_be_whole_microseconds() {
        assert_eq!(period_ticks(5_000), Some(200));
        assert_eq!(period_ticks(1_000_000), Some(1));
        assert_eq!(period_ticks(3_000), None);
        assert_eq!(period_ticks(0), None);
        assert_eq!(period_ticks(2_000_000), None);
    }

    #[test]
    fn rearming_moves_the_grid() {
        let mut m = TickMonitor::try_new(T, T, T / 4).unwrap();
        m.on_wake(3 * T);
        m.rearm(2 * T, 10 * T);
        assert_eq!(m.next_deadline, 10 * T);
        assert_eq!(m.on_wake(10 * T), TickWake::OnTime);
        assert_eq!(m.next_deadline, 12 * T);
    }

    #[test]
    fn refuses_bad_configuration() {
        assert_eq!(
            TickMonitor::try_new(0, 0, 0).err(),
            Some(TickConfigError::ZeroPeriod)
        );
        assert_eq!(
            TickMonitor::try_new(T, T, T).err(),
            Some(TickConfigError::LateAfterNotBelowPeriod)
        );
    }

    #[test]
    fn punctual_ticks_advance_one_period_each() {
        let mut m = TickMonitor::try_new(T, T, T / 4).unwrap();
        for k in 1..=100u64 {
            // A few ticks of wake-up latency, within tolerance.
            assert_eq!(m.on_wake(k * T + k % 5), TickWake::OnTime);
            assert_eq!(m.next_deadline, (k + 1) * T);
        }
    }

    #[test]
    fn a_late_tick_is_counted_but_keeps_the_grid() {
        let mut m = TickMonitor::try_new(T, T, T / 4).unwrap();
        assert_eq!(m.on_wake(T + T / 2), TickWake::Late { lateness: T / 2 });
        assert_eq!(m.next_deadline, 2 * T);
        assert_eq!(m.on_wake(2 * T), TickWake::OnTime);
    }

    #[test]
    fn a_stall_skips_missed_deadlines_instead_of_catching_up() {
        let mut m = TickMonitor::try_new(T, T, T / 4).unwrap();
        assert_eq!(m.on_wake(T), TickWake::OnTime);
        // Stalled: the tick due at 2T runs at 5T + 10, so 2T, 3T, 4T and 5T passed; the
        // tick runs once for them, 3 deadlines are skipped, and the next is 6T.
        let wake = m.on_wake(5 * T + 10);
        assert_eq!(
            wake,
            TickWake::Skipped {
                missed: 3,
                next_deadline: 6 * T
            }
        );
        // The next wake-up on the re-armed grid is on time: no burst of catch-up ticks.
        assert_eq!(m.on_wake(6 * T), TickWake::OnTime);
    }

    #[test]
    fn exactly_one_period_late_skips_one() {
        let mut m = TickMonitor::try_new(T, T, 0).unwrap();
        assert_eq!(
            m.on_wake(2 * T),
            TickWake::Skipped {
                missed: 1,
                next_deadline: 3 * T
            }
        );
    }

    #[test]
    fn an_early_wake_is_on_time_and_saturates_nothing() {
        let mut m = TickMonitor::try_new(T, 10 * T, 0).unwrap();
        assert_eq!(m.on_wake(0), TickWake::OnTime);
        assert_eq!(m.next_deadline, 11 * T);
        // Far in the future: no overflow, a huge skip count saturates.
        let mut m = TickMonitor::try_new(1, 0, 0).unwrap();
        assert!(matches!(
            m.on_wake(u64::MAX),
            TickWake::Skipped {
                missed: u32::MAX,
                ..
            }
        ));
    }
}
