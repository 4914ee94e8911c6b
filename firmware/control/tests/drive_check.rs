//! The drive check (`wheelset_control::monitor`, the drive check): a current-loop limit
//! cycle raises `drive` within the window and the persistence and its end releases it;
//! what the healthy loop does (a steady error, a slow swing, one step of the reference
//! and the loop's damped answer) does not; the three sample types from one
//! implementation; its level in the core's current scale (its fields' validation: the
//! `monitor` tests).
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::f64::consts::PI;
use wheelset_control::{ConfigError, Fx, Monitor, MonitorParams, MonitorState, Sample};

const BASE: u32 = 5000;

/// The ripple's mean-square levels, pu^2, from the exact bits: alarm on, alarm off.
fn drive_levels(m: &Monitor<f64>) -> (f64, f64) {
    let [on, off] = m.to_bits().drive_levels.map(f64::from_bits);
    (on, off)
}

/// Runs the current errors `e` (pu) through the drive check, one traction step each;
/// returns the steps at which the alarm rose and fell, and the largest mean square (pu^2).
fn run<T: Sample>(p: &MonitorParams, e: &[f64]) -> (Vec<usize>, Vec<usize>, f64) {
    let m = Monitor::<T>::try_new(p, BASE).unwrap();
    let mut s = MonitorState::<T>::default();
    let (mut rose, mut fell, mut peak) = (Vec::new(), Vec::new(), 0.0f64);
    for (n, &x) in e.iter().enumerate() {
        let was = s.ev.drive;
        if m.drive_step(&mut s, T::from_f64(x)) {
            rose.push(n);
        }
        assert_eq!(s.ev.drive && !was, rose.last() == Some(&n), "step {n}");
        if was && !s.ev.drive {
            fell.push(n);
        }
        peak = peak.max(s.drive_ms.to_f64());
    }
    (rose, fell, peak)
}

/// A limit cycle of `amp` pu at `cycles_per_step` of the traction rate for `on` steps,
/// then silence for `off` steps.
fn limit_cycle(amp: f64, cycles_per_step: f64, on: usize, off: usize) -> Vec<f64> {
    (0..on + off)
        .map(|n| {
            if n < on {
                amp * (2.0 * PI * cycles_per_step * n as f64).sin()
            } else {
                0.0
            }
        })
        .collect()
}

/// The step of the mean square `q` crossing `thr^2` for a signal whose squared ripple is
/// `r2[n]`, in f64 (`k_d = 1 - exp(-1/N)`).
fn f64_crossing(p: &MonitorParams, e: &[f64]) -> Option<usize> {
    let k = 1.0 - (-1.0 / f64::from(p.drive_window_steps)).exp();
    let thr = p.drive_ripple_a / p.current_scale_a;
    let (mut q, mut prev) = (0.0, 0.0);
    for (n, &x) in e.iter().enumerate() {
        let r: f64 = x - prev;
        prev = x;
        q += k * (r * r - q);
        if q > thr * thr {
            return Some(n);
        }
    }
    None
}

#[test]
fn a_limit_cycle_alarms_after_the_persistence_and_its_end_releases() {
    let p = MonitorParams::default();
    // 1.5 kA at 0.186 of the rate (930 Hz at 5 kHz: the inductance faults' pair), 2 000
    // steps, then 2 000 steps of silence.
    let e = limit_cycle(1.5, 0.186, 2000, 2000);
    let cross = f64_crossing(&p, &e).expect("the ripple's RMS is far above 300 A");
    let due = cross + usize::from(p.drive_persist_steps) - 1;
    for (name, (rose, fell, _)) in [
        ("f64", run::<f64>(&p, &e)),
        ("f32", run::<f32>(&p, &e)),
        ("Q4.28", run::<Fx>(&p, &e)),
    ] {
        assert_eq!(rose.len(), 1, "{name}: {rose:?}");
        // Persistence: P steps above the level, counted from the crossing (the fixed
        // point may cross one step apart from f64).
        assert!(
            rose[0].abs_diff(due) <= 1,
            "{name}: rose at {} vs {due}",
            rose[0]
        );
        assert!(rose[0] >= usize::from(p.drive_persist_steps), "{name}");
        // It falls after the cycle stops, once the mean square has decayed below the
        // release level: `N ln(q / (release thr)^2)` steps, q at most 8 pu^2.
        assert_eq!(fell.len(), 1, "{name}: {fell:?}");
        let thr = p.drive_ripple_a / p.current_scale_a;
        let bound =
            f64::from(p.drive_window_steps) * (8.0 / (p.release * p.release * thr * thr)).ln();
        assert!(
            fell[0] > 2000 && ((fell[0] - 2000) as f64) < bound,
            "{name}: fell at {}",
            fell[0]
        );
    }
}

#[test]
fn a_slower_limit_cycle_at_a_lower_rate_is_caught_too() {
    // 200 Hz at 1 kHz (the 5 kHz gains run at 1 kHz): 0.2 cycles per step, clamped at
    // the measurement's 2 kA.
    let p = MonitorParams::default();
    let e: Vec<f64> = limit_cycle(3.0, 0.2, 1000, 0)
        .into_iter()
        .map(|x| x.clamp(-2.0, 2.0))
        .collect();
    let (rose, _, _) = run::<Fx>(&p, &e);
    assert_eq!(rose.len(), 1);
    assert!(rose[0] < 2 * usize::from(p.drive_persist_steps), "{rose:?}");
}

#[test]
fn what_the_healthy_loop_does_raises_nothing() {
    let p = MonitorParams::default();
    let thr2 = (p.drive_ripple_a / p.current_scale_a).powi(2);
    // A steady error of 1.5 kA (the voltage at its limit): no ripple.
    let (rose, _, peak) = run::<Fx>(&p, &vec![1.5; 5000]);
    assert!(rose.is_empty());
    // (its first step is one ripple sample of 1.5 pu: r^2/64.5)
    assert!(peak < 0.04, "{peak}");
    // A swing of 1 kA at 20 Hz (the gear mode) at 5 kHz: its ripple is 2.5 % of it.
    let (rose, _, peak) = run::<Fx>(&p, &limit_cycle(1.0, 20.0 / 5000.0, 20_000, 0));
    assert!(rose.is_empty() && peak < 0.01 * thr2, "{peak}");
    // A step of the reference by 2 kA and the loop's damped answer (radius 0.707 per
    // step, 45 deg: the 5 kHz loop's pair): its burst rises above the level, and the
    // persistence keeps it from alarming...
    let step: Vec<f64> = (0..2000)
        .map(|n| {
            let n = n as f64;
            2.0 * 0.5f64.powf(n / 2.0) * (PI * n / 4.0).cos()
        })
        .collect();
    for (name, (rose, _, peak)) in [
        ("f64", run::<f64>(&p, &step)),
        ("f32", run::<f32>(&p, &step)),
        ("Q4.28", run::<Fx>(&p, &step)),
    ] {
        assert!(peak > thr2, "{name}: the burst crosses the level ({peak})");
        assert!(rose.is_empty(), "{name}: {rose:?}");
    }
    // ... which a check without persistence would not.
    let eager = MonitorParams {
        drive_persist_steps: 1,
        ..p
    };
    assert_eq!(run::<Fx>(&eager, &step).0.len(), 1);
}

#[test]
fn the_level_follows_the_current_scale() {
    // 300 A is 0.15 pu of 2 kA.
    let m = Monitor::<f64>::try_new(
        &MonitorParams {
            current_scale_a: 2000.0,
            ..MonitorParams::default()
        },
        BASE,
    )
    .unwrap();
    assert!((drive_levels(&m).0 - 0.15f64.powi(2)).abs() < 1e-12);
    assert!((drive_levels(&m).1 - (0.7f64 * 0.15).powi(2)).abs() < 1e-12);
}

/// The current scale the drive check divides by must be a positive number of amperes:
/// zero and negative scales are refused by name.
#[test]
fn a_zero_or_negative_current_scale_is_refused() {
    for bad in [0.0, -2000.0] {
        let p = MonitorParams {
            current_scale_a: bad,
            ..MonitorParams::default()
        };
        match Monitor::<f64>::try_new(&p, 5000) {
            Err(ConfigError::Range { field, .. }) => {
                assert_eq!(field, "monitor.current_scale_a", "{bad}");
            }
            other => panic!("{bad}: {other:?}"),
        }
    }
}

/// The drive check's boundaries: its threshold must lie strictly between 1e-3 and 2 of
/// the current scale, and a mean square exactly at the alarm level does not count (only
/// above it), here with a one-step persistence and levels exact in f64.
#[test]
fn the_drive_checks_boundaries_are_strict() {
    let d = MonitorParams::default();
    for ripple in [1e-3 * d.current_scale_a, 2.0 * d.current_scale_a] {
        let p = MonitorParams {
            drive_ripple_a: ripple,
            ..d
        };
        match Monitor::<f64>::try_new(&p, 5000) {
            Err(ConfigError::Range { field, .. }) => assert_eq!(field, "monitor.drive_ripple_a"),
            other => panic!("{ripple}: {other:?}"),
        }
    }
    let p = MonitorParams {
        drive_ripple_a: 0.25 * d.current_scale_a,
        drive_persist_steps: 1,
        ..d
    };
    let m = Monitor::<f64>::try_new(&p, 5000).unwrap();
    assert_eq!(drive_levels(&m).0, 0.0625);
    let at = |e: f64| {
        let mut s = MonitorState::<f64> {
            drive_ms: 0.0625,
            ..MonitorState::default()
        };
        m.drive_step(&mut s, e)
    };
    assert!(!at(0.25), "exactly at the level");
    assert!(at(0.2501), "above it");
}
