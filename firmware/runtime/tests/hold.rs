//! The hold-safe policy alone (`wheelset_runtime::HoldPolicy`), without a runtime: the
//! held ticks, the entry on the `hold_ticks + 1`-th tick without a frame, the exit on
//! the next frame, the alarm's hold, and a property against a reference that recounts
//! the ticks without a frame from the whole history.

use proptest::prelude::*;
use wheelset_runtime::{HoldPolicy, SafeChange};

/// Runs `ticks` (fresh, alarm_safe) with a sample present; returns the steps.
fn run(hold_ticks: u16, ticks: &[(bool, bool)]) -> Vec<wheelset_runtime::HoldStep> {
    let mut p = HoldPolicy::default();
    ticks
        .iter()
        .map(|&(fresh, alarm)| p.step(fresh, true, hold_ticks, alarm))
        .collect()
}

#[test]
fn enters_on_the_tick_after_hold_ticks_missing_and_exits_on_the_next_frame() {
    for hold in [0u16, 1, 3, 10] {
        let h = usize::from(hold);
        // One fresh tick, then h + 3 missing, then a fresh one.
        let mut ticks = vec![(true, false)];
        ticks.extend(std::iter::repeat_n((false, false), h + 3));
        ticks.push((true, false));
        let steps = run(hold, &ticks);
        assert!(!steps[0].holding && !steps[0].safe && steps[0].change.is_none());
        for (k, s) in steps[1..=h + 3].iter().enumerate() {
            let missing = k + 1;
            assert!(
                s.holding,
                "hold {hold}: tick {missing} without a frame holds"
            );
            assert_eq!(s.safe, missing > h, "hold {hold}: missing {missing}");
            let entered = (missing == h + 1).then_some(SafeChange::Enter);
            assert_eq!(s.change, entered, "hold {hold}: missing {missing}");
        }
        let last = steps[h + 4];
        assert!(!last.holding && !last.safe);
        assert_eq!(last.change, Some(SafeChange::Exit), "hold {hold}");
    }
}

#[test]
fn before_the_first_sample_nothing_is_held_and_nothing_is_safe() {
    let mut p = HoldPolicy::default();
    for _ in 0..100 {
        let s = p.step(false, false, 0, false);
        assert!(!s.holding && !s.safe && s.change.is_none());
    }
    assert_eq!(p.missing(), 0);
    // The first sample's tick is fresh; the one after it holds.
    assert!(!p.step(true, true, 0, false).holding);
    let s = p.step(false, true, 0, false);
    assert!(s.holding && s.safe && s.change == Some(SafeChange::Enter));
}

#[test]
fn the_alarm_holds_the_safe_state_with_frames_arriving() {
    let steps = run(
        10,
        &[(true, false), (true, true), (true, true), (true, false)],
    );
    assert!(!steps[0].safe);
    assert_eq!(steps[1].change, Some(SafeChange::Enter));
    assert!(steps[2].safe && steps[2].change.is_none() && !steps[2].holding);
    assert_eq!(steps[3].change, Some(SafeChange::Exit));
}

#[test]
fn the_missing_count_saturates_instead_of_wrapping() {
    let mut p = HoldPolicy::default();
    p.step(true, true, u16::MAX, false);
    // Far more than u16::MAX ticks: safe from tick 65 536 on, and it stays.
    for n in 1..=70_000u32 {
        let s = p.step(false, true, u16::MAX, false);
        assert_eq!(s.safe, n > u32::from(u16::MAX), "tick {n}");
    }
    assert_eq!(p.missing(), 70_000);
}

proptest! {
    /// Against a reference that recounts, at every tick, the ticks since the latest
    /// fresh one (only those with a sample) from the whole history.
    #[test]
    fn matches_the_history_reference(
        hold in 0u16..6,
        ticks in proptest::collection::vec((any::<bool>(), any::<bool>(), 0u8..10), 1..200),
    ) {
        let mut p = HoldPolicy::default();
        let mut sampled = false;
        let mut hist: Vec<(bool, bool)> = Vec::new();
        let mut was_safe = false;
        for &(fresh_bit, alarm, r) in &ticks {
            // Frames arrive more often than not; the first one makes a sample.
            let fresh = fresh_bit || r < 3;
            sampled |= fresh;
            hist.push((fresh, sampled));
            let missing = hist
                .iter()
                .rev()
                .take_while(|(f, _)| !f)
                .filter(|(_, s)| *s)
                .count();
            let want = (sampled && missing > usize::from(hold)) || alarm;
            let s = p.step(fresh, sampled, hold, alarm);
            prop_assert_eq!(s.holding, !fresh && sampled);
            prop_assert_eq!(s.safe, want);
            prop_assert_eq!(p.is_safe(), want);
            let change = match (was_safe, want) {
                (false, true) => Some(SafeChange::Enter),
                (true, false) => Some(SafeChange::Exit),
                _ => None,
            };
            prop_assert_eq!(s.change, change);
            was_safe = want;
        }
    }
}
