//! The arithmetic of the Nucleo's TIM2 time driver (`board::nucleo_tim2`): pure
//! functions, tested on the host.
//!
//! TIM2 is a 32-bit up-counter (RM0390 section 18, "General-purpose timers (TIM2 to
//! TIM5)") counting embassy-time ticks of 1 us (prescaled from the 84 MHz APB1 timer
//! clock: [`prescaler`]). It wraps every 2^32 us (71.6 min). Device time is 64-bit:
//!
//! `now = period * 2^31 + (counter XOR (period & 1) * 2^31)` (us),
//!
//! where `period` counts half-wraps of the counter: it is incremented at the counter's
//! overflow to 0 (the update event) and at its midpoint 0x8000_0000 (a compare on CC2).
//! An even `period` expects the counter in `0..2^31`, an odd one in `2^31..2^32`, so a
//! `now()` that reads `period` just before the interrupt that increments it (the
//! counter already past the boundary) still gets the right time ([`now`]). It is the
//! scheme of embassy-stm32's own 16-bit driver, widened to 32 bits.
//!
//! The alarm is the compare on CC1: it matches when the counter equals the alarm's low
//! 32 bits. It is enabled only when the alarm is less than [`ARM_WINDOW`] = 3 * 2^30 us
//! ahead ([`arm_now`]; re-checked at each period start, [`arm_at_period`]), so the first
//! match after enabling is the alarm itself and not an earlier wrap of the counter.

/// Half of the counter's range, us: the length of one `period`.
pub const HALF: u32 = 1 << 31;

/// How far ahead (us) an alarm may be for its compare to be enabled: less than one wrap
/// (2^32 us), with a quarter wrap of margin for a period interrupt served late.
pub const ARM_WINDOW: u64 = 3 << 30;

/// Device time in us from the half-wrap count and the counter (see the module docs).
pub const fn now(period: u32, counter: u32) -> u64 {
    ((period as u64) << 31) + ((counter ^ ((period & 1) << 31)) as u64)
}

/// The device time at which `period` starts, us.
pub const fn period_start(period: u32) -> u64 {
    (period as u64) << 31
}

/// Whether an alarm at `at` (us, after `now`) may have its compare enabled now.
pub const fn arm_now(at: u64, now: u64) -> bool {
    at.saturating_sub(now) < ARM_WINDOW
}

/// Whether an alarm at `at` must have its compare enabled when `period` starts.
pub const fn arm_at_period(at: u64, period: u32) -> bool {
    at < period_start(period).saturating_add(ARM_WINDOW)
}

/// TIM2's prescaler register value (PSC, counter clock = timer clock / (PSC + 1)) for
/// `tick_hz` counts per second from a `timer_hz` timer clock; `None` unless the ratio is
/// a whole number from 1 to 65 536 (PSC is 16-bit).
pub const fn prescaler(timer_hz: u32, tick_hz: u32) -> Option<u16> {
    if tick_hz == 0 || !timer_hz.is_multiple_of(tick_hz) || timer_hz < tick_hz {
        return None;
    }
    let div = timer_hz / tick_hz;
    if div - 1 > u16::MAX as u32 {
        None
    } else {
        Some((div - 1) as u16)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The counter as it runs from `t` (us since start; what the hardware holds).
    fn counter_at(t: u64) -> u32 {
        t as u32
    }

    /// The half-wrap count the interrupts have reached at `t`.
    fn period_at(t: u64) -> u32 {
        (t >> 31) as u32
    }

    #[test]
    fn now_is_continuous_across_half_wraps_and_wraps() {
        for base in [
            0u64,
            1 << 31,
            1 << 32,
            3 << 31,
            5 << 32,
            (1 << 40) + (1 << 31),
        ] {
            for d in [0u64, 1, 1000, (1 << 31) - 1] {
                let t = base + d;
                assert_eq!(now(period_at(t), counter_at(t)), t, "t = {t:#x}");
            }
        }
    }

    #[test]
    fn now_is_right_when_the_period_interrupt_is_still_pending() {
        // The counter just passed a boundary, the interrupt that counts it has not run:
        // `period` is one behind.
        for boundary in [1u64 << 31, 1 << 32, 3 << 31, 7 << 32] {
            for late in [0u64, 1, 5, 100_000] {
                let t = boundary + late;
                let stale = period_at(t) - 1;
                assert_eq!(now(stale, counter_at(t)), t, "t = {t:#x}");
            }
        }
    }

    #[test]
    fn an_armed_compare_first_matches_at_the_alarm() {
        // Enabled at `now`, the compare matches at the first t > now with t as u32 equal
        // to the alarm's low bits: that must be the alarm.
        for now_t in [0u64, 12_345, (1 << 32) - 10, 9 << 31] {
            for ahead in [
                1u64,
                200,
                1 << 31,
                ARM_WINDOW - 1,
                ARM_WINDOW,
                1 << 32,
                1 << 33,
            ] {
                let at = now_t + ahead;
                let low = at as u32;
                let first = now_t + u64::from(low.wrapping_sub(now_t as u32));
                let first = if first == now_t {
                    first + (1 << 32)
                } else {
                    first
                };
                if arm_now(at, now_t) {
                    assert_eq!(first, at, "now {now_t:#x} at {at:#x}");
                } else {
                    assert!(ahead >= ARM_WINDOW);
                }
            }
        }
    }

    #[test]
    fn a_far_alarm_is_armed_by_the_period_that_brings_it_in_range() {
        let at: u64 = (5 << 31) + 77;
        // Not at periods too early ...
        assert!(!arm_at_period(at, 2));
        assert!(!arm_now(at, period_start(2)));
        // ... but by the start of the last period before it at the latest, and then
        // the compare's first match is the alarm (it is less than one wrap ahead).
        assert!(arm_at_period(at, 4));
        assert!(arm_at_period(at, 5));
        let p = (0..=5).find(|&p| arm_at_period(at, p)).unwrap();
        assert!(at - period_start(p) < 1 << 32);
    }

    #[test]
    fn the_half_wrap_compare_is_where_the_period_changes() {
        // CC2 at HALF: the counter at HALF in period 0 is the start of period 1, and
        // the counter back at 0 in period 1 (not yet counted) is the start of period 2.
        assert_eq!(period_start(1), u64::from(HALF));
        assert_eq!(now(1, HALF), period_start(1));
        assert_eq!(now(0, HALF), period_start(1));
        assert_eq!(now(1, 0), period_start(2));
        assert_eq!(now(2, 0), period_start(2));
    }

    #[test]
    fn an_alarm_in_the_past_is_armed() {
        assert!(arm_now(10, 20));
        assert!(arm_at_period(0, 3));
    }

    #[test]
    fn prescaler_of_the_nucleo_clock_and_bad_ratios() {
        // APB1 42 MHz, timer clock doubled: 84 MHz to 1 MHz is /84, PSC 83.
        assert_eq!(prescaler(84_000_000, 1_000_000), Some(83));
        assert_eq!(prescaler(1_000_000, 1_000_000), Some(0));
        assert_eq!(prescaler(84_000_000, 0), None);
        assert_eq!(prescaler(84_000_000, 999_999), None);
        assert_eq!(prescaler(1_000, 1_000_000), None);
        assert_eq!(prescaler(65_536 * 1000, 1000), Some(u16::MAX));
        assert_eq!(prescaler(65_537 * 1000, 1000), None);
    }
}
