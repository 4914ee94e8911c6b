//! The stability monitor and the actuator check (`wheelset_control::monitor`): alarm
//! levels with hysteresis, the band, the growth test, the three sample types from one
//! implementation, and the exact-bit round trip.
#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::f64::consts::PI;
use wheelset_control::{Fx, Monitor, MonitorEvents, MonitorParams, MonitorState, Sample};

const BASE: u32 = 5000;

/// The levels in (m/s)^2 from the exact bits: alarm on, alarm off, the actuator check's floor.
fn levels(m: &Monitor<f64>) -> (f64, f64, f64) {
    let [on, off, floor] = m.to_bits().levels.map(f64::from_bits);
    (on, off, floor)
}

/// Runs `f(t)` (y' in m/s = pu) through a monitor at the base rate for `dur` seconds;
/// returns the times of the rising edges (hunting, actuator) and the final events.
fn drive<T: Sample>(
    p: &MonitorParams,
    dur: f64,
    commanding: bool,
    f: impl Fn(f64) -> f64,
) -> (Vec<f64>, Vec<f64>, MonitorEvents) {
    let m = Monitor::<T>::try_new(p, BASE).unwrap();
    let mut s = MonitorState::default();
    let (mut h, mut a) = (Vec::new(), Vec::new());
    let mut ev = MonitorEvents::default();
    let n = (dur * f64::from(BASE)) as usize;
    for k in 0..n {
        let t = k as f64 / f64::from(BASE);
        ev = m.tick(&mut s, T::from_f64(f(t)), commanding, T::ZERO);
        if ev.hunting_rose {
            h.push(t);
        }
        if ev.actuator_rose {
            a.push(t);
        }
    }
    (h, a, ev)
}

fn sine(f_hz: f64, rms: f64) -> impl Fn(f64) -> f64 {
    move |t| rms * 2f64.sqrt() * (2.0 * PI * f_hz * t).sin()
}

#[test]
fn a_sustained_oscillation_in_band_alarms_and_its_end_releases() {
    let p = MonitorParams::default();
    // RMS 1.5 x the threshold at 10 Hz for 3 s, then 0.85 x (between release and
    // threshold: held), then 0.5 x (released).
    let amp = |t: f64| {
        if t < 3.0 {
            1.5
        } else if t < 6.0 {
            0.85
        } else {
            0.5
        }
    };
    let f = move |t: f64| sine(10.0, p.threshold_m_s * amp(t))(t);
    for (name, (h, a, ev)) in [
        ("Q4.28", drive::<Fx>(&p, 9.0, true, f)),
        ("f32", drive::<f32>(&p, 9.0, true, f)),
        ("f64", drive::<f64>(&p, 9.0, true, f)),
    ] {
        assert_eq!(h.len(), 1, "{name}: one hunting alarm, {h:?}");
        // The exponential mean square of a constant power P: P (1 - e^{-t/tau}) (the band
        // gain at 10 Hz is ~0.95): 1.5^2 x 0.9 > 1 after about tau ln(1/(1 - 1/2.0)).
        assert!(h[0] > 0.3 && h[0] < 1.5, "{name}: alarm at {}", h[0]);
        assert!(
            a.is_empty(),
            "{name}: constant amplitude is no growth: {a:?}"
        );
        assert!(!ev.hunting, "{name}: released at the end");
    }
    // Held between the levels: still on at 5.9 s.
    let (_, _, ev) = drive::<Fx>(&p, 5.9, true, f);
    assert!(ev.hunting);
}

#[test]
fn out_of_band_motion_does_not_alarm() {
    let p = MonitorParams::default();
    // 5 x the threshold's RMS, at 0.2 Hz (curve transitions) and at 120 Hz.
    for f_hz in [0.2, 120.0] {
        let (h, _, _) = drive::<Fx>(&p, 8.0, true, sine(f_hz, 5.0 * p.threshold_m_s));
        assert!(h.is_empty(), "{f_hz} Hz: {h:?}");
    }
    // In band it would: 1.5 x at 5 Hz and at 15 Hz (the band's gain is 0.83 at 5 Hz,
    // 0.80 at 15 Hz: first-order edges at 3 and 20 Hz).
    for f_hz in [5.0, 15.0] {
        let (h, _, _) = drive::<Fx>(&p, 8.0, true, sine(f_hz, 1.5 * p.threshold_m_s));
        assert_eq!(h.len(), 1, "{f_hz} Hz: {h:?}");
    }
}

/// A mode growing at `sigma` from `a0` (m/s) at 8 Hz, from t = 1 s.
fn growing(sigma: f64, a0: f64) -> impl Fn(f64) -> f64 {
    move |t| {
        if t < 1.0 {
            0.0
        } else {
            a0 * (sigma * (t - 1.0)).exp() * (2.0 * PI * 8.0 * (t - 1.0)).sin()
        }
    }
}

#[test]
fn growth_while_commanding_is_an_actuator_fault_and_precedes_hunting() {
    let p = MonitorParams::default();
    // sigma = 5 1/s (the failed wheelset at conicity 0.05) from 0.1 mm/s.
    let f = growing(5.0, 1e-4);
    let (h, a, _) = drive::<Fx>(&p, 3.0, true, &f);
    assert_eq!(a.len(), 1, "{a:?}");
    assert_eq!(h.len(), 1, "{h:?}");
    assert!(a[0] < h[0], "actuator {a:?} before hunting {h:?}");
    // The floor (RMS 1 mm/s, peak 1.4 mm/s) is reached at 1 + ln(14)/5 = 1.53 s; the
    // alarm within two blocks (plus one for the phase) after it.
    assert!(a[0] > 1.4 && a[0] < 1.53 + 0.3, "{a:?}");
    // Not commanding (passive mode, safe state): growth is no actuator fault.
    let (h2, a2, _) = drive::<Fx>(&p, 3.0, false, &f);
    assert!(a2.is_empty());
    assert_eq!(h2, h);
    // Slower than the check's rate (1 1/s < 3 1/s): not an actuator fault.
    let (_, a3, _) = drive::<Fx>(&p, 3.0, true, growing(1.0, 2e-3));
    assert!(a3.is_empty(), "{a3:?}");
}

#[test]
fn a_damped_disturbance_is_no_actuator_fault() {
    let p = MonitorParams::default();
    // Bursts of 40 mm/s decaying at zeta omega = 6 1/s (the passive beating's, the
    // lightest damping of the healthy runs), every 2 s.
    let f = |t: f64| {
        let tt = t % 2.0;
        0.04 * (-6.0 * tt).exp() * (2.0 * PI * 9.0 * tt).sin()
    };
    let (_, a, _) = drive::<Fx>(&p, 8.0, true, f);
    assert!(a.is_empty(), "{a:?}");
}

/// As [`drive`] in Q4.28, commanding, with the traction current reference `iref(t)` (pu
/// of the current scale); returns the actuator alarms' times.
fn drive_with_iref(
    p: &MonitorParams,
    dur: f64,
    iref: impl Fn(f64) -> f64,
    f: impl Fn(f64) -> f64,
) -> Vec<f64> {
    let m = Monitor::<Fx>::try_new(p, BASE).unwrap();
    let mut s = MonitorState::default();
    let mut a = Vec::new();
    let n = (dur * f64::from(BASE)) as usize;
    for k in 0..n {
        let t = k as f64 / f64::from(BASE);
        if m.tick(&mut s, Fx::from_f64(f(t)), true, Fx::from_f64(iref(t)))
            .actuator_rose
        {
            a.push(t);
        }
    }
    a
}

/// The traction step of the default rule plus `extra` (pu): the reference moves up by it
/// at each of `steps` (s), on the first tick at or after it.
fn stepped(p: &MonitorParams, extra: f64, steps: &[f64]) -> impl Fn(f64) -> f64 {
    let jump = p.act_traction_change_a / p.current_scale_a + extra;
    let steps = steps.to_vec();
    move |t| jump * steps.iter().filter(|&&ts| t >= ts).count() as f64
}

/// As [`drive_with_iref`], the reference stepping by 100 A at each of `steps` (s).
fn drive_with_steps(
    p: &MonitorParams,
    dur: f64,
    steps: &[f64],
    f: impl Fn(f64) -> f64,
) -> Vec<f64> {
    drive_with_iref(p, dur, stepped(p, 0.05, steps), f)
}

/// The response to a traction step as `low-adhesion` shows it (the protection's cut):
/// 9 Hz, the envelope rising as `(tau/0.15 s)^2` to 20 mm/s over 0.15 s from the step at
/// `t0`, then decaying at 8 1/s (the healthy loop's damping).
fn step_response(t0: f64) -> impl Fn(f64) -> f64 {
    move |t| {
        let tau = t - t0;
        if tau < 0.0 {
            return 0.0;
        }
        let env = if tau < 0.15 {
            (tau / 0.15).powi(2)
        } else {
            (-8.0 * (tau - 0.15)).exp()
        };
        0.02 * env * (2.0 * PI * 9.0 * tau).sin()
    }
}

#[test]
fn a_traction_step_is_no_actuator_fault_whatever_its_phase() {
    let p = MonitorParams::default();
    let mut alarmed_without = 0;
    // Steps at 2.0 s + every phase of a 0.1 s block (blocks end at multiples of 0.1 s).
    for k in 0..10 {
        let t0 = 2.0 + 0.01 * f64::from(k);
        let f = step_response(t0);
        // Unannounced, the onset's two growing blocks raise the alarm for some phases:
        // the false alarm of `low-adhesion` before the rule.
        alarmed_without += usize::from(!drive_with_steps(&p, 4.0, &[], &f).is_empty());
        // With the traction reference stepping on that tick (a demand step, the
        // protection's cut, either sign): silent.
        let a = drive_with_steps(&p, 4.0, &[t0], &f);
        assert!(a.is_empty(), "step at {t0}: {a:?}");
        let down = stepped(&p, 0.05, &[t0]);
        let a = drive_with_iref(&p, 4.0, |t| 0.5 - down(t), &f);
        assert!(a.is_empty(), "step down at {t0}: {a:?}");
    }
    assert!(
        alarmed_without > 0,
        "the test response must challenge the check"
    );
}

/// The rule's level: a reference change within a block of at most the traction step is
/// no step (the check judges the block), one just above it is.
#[test]
fn the_traction_step_is_a_change_above_its_level_within_a_block() {
    let p = MonitorParams::default();
    let lsb = 1.0 / f64::from(1u32 << 28);
    for k in 0..10 {
        let t0 = 2.0 + 0.01 * f64::from(k);
        let f = step_response(t0);
        if drive_with_steps(&p, 4.0, &[], &f).is_empty() {
            continue;
        }
        // Two LSB under the level: the onset's growth is judged, as without a step.
        let under = drive_with_iref(&p, 4.0, stepped(&p, -2.0 * lsb, &[t0]), &f);
        assert!(!under.is_empty(), "step at {t0}");
        let over = drive_with_iref(&p, 4.0, stepped(&p, 2.0 * lsb, &[t0]), &f);
        assert!(over.is_empty(), "step at {t0}: {over:?}");
    }
}

/// A driver's notch ramped under the traction controller's jerk limit (2 kN m/s at the
/// wheel: about 9 A per 0.1 s block through `n K_m` = 21.4 N m/A) moves the reference by
/// less than the step in every block, so the check keeps judging: a failed actuator
/// during the ramp alarms when it would without one.
#[test]
fn a_ramped_demand_does_not_quiet_the_check() {
    let p = MonitorParams::default();
    let f = growing(5.0, 1e-4);
    let a0 = drive_with_steps(&p, 3.0, &[], &f);
    let ramp = |t: f64| 0.093 * t;
    let a = drive_with_iref(&p, 3.0, ramp, &f);
    assert_eq!(a, a0);
}

#[test]
fn a_failed_actuator_is_caught_through_traction_steps() {
    let p = MonitorParams::default();
    // sigma = 5 1/s (conicity 0.05) from t = 1 s: the alarm without any step, then with
    // the protection cutting just before it, and every 0.5 s (twice its cycle on
    // `low-adhesion`; cuts closer than (QUIET_BLOCKS + act_blocks) blocks = 0.4 s apart
    // would hide the growth from the check, not from the hunting alarm).
    let f = growing(5.0, 1e-4);
    let a0 = drive_with_steps(&p, 3.0, &[], &f);
    assert_eq!(a0.len(), 1, "{a0:?}");
    for steps in [
        vec![a0[0] - 0.01],
        vec![a0[0] - 0.15],
        (0..6).map(|k| 0.9 + 0.5 * f64::from(k)).collect(),
    ] {
        let a = drive_with_steps(&p, 3.0, &steps, &f);
        assert_eq!(a.len(), 1, "steps {steps:?}: {a:?}");
        // At most QUIET_BLOCKS blocks later (plus one block's phase).
        let late = a[0] - a0[0];
        let bound = f64::from(wheelset_control::QUIET_BLOCKS + 1) * p.act_block_s;
        assert!(
            late >= 0.0 && late <= bound + 1e-9,
            "steps {steps:?}: {late} s later"
        );
    }
}

#[test]
fn fixed_point_and_floats_alarm_together() {
    let p = MonitorParams::default();
    let f = growing(12.0, 1e-5);
    let (hf, af, _) = drive::<Fx>(&p, 3.0, true, &f);
    let (h32, a32, _) = drive::<f32>(&p, 3.0, true, &f);
    let (h64, a64, _) = drive::<f64>(&p, 3.0, true, &f);
    let step = 1.0 / f64::from(p.rate_hz);
    for (x, y) in [(&hf, &h64), (&h32, &h64), (&af, &a64), (&a32, &a64)] {
        assert_eq!(x.len(), 1, "{x:?}");
        assert!((x[0] - y[0]).abs() <= step + 1e-9, "{x:?} vs {y:?}");
    }
}

#[test]
fn bits_round_trip_and_invalid_bits_are_refused() {
    let p = MonitorParams::default();
    let m = Monitor::<Fx>::try_new(&p, BASE).unwrap();
    assert_eq!(m.divisor(), 10);
    let b = m.to_bits();
    assert_eq!(Monitor::<Fx>::from_bits(&b, BASE), Ok(m));
    assert_eq!(Monitor::<Fx>::from_valid_bits(&b, BASE), m);
    let m32 = Monitor::<f32>::try_new(&p, BASE).unwrap();
    assert_eq!(Monitor::<f32>::from_valid_bits(&m32.to_bits(), BASE), m32);
    assert_eq!(Monitor::<f32>::from_bits(&m32.to_bits(), BASE), Ok(m32));
    // Another base rate: the sub-rate follows.
    assert_eq!(Monitor::<Fx>::from_bits(&b, 4000).unwrap().divisor(), 8);
    let bad = |f: &dyn Fn(&mut wheelset_control::MonitorBits)| {
        let mut x = b;
        f(&mut x);
        Monitor::<Fx>::from_bits(&x, BASE).unwrap_err().field
    };
    assert_eq!(bad(&|x| x.k_lo = 0), "monitor.k_lo");
    assert_eq!(bad(&|x| x.k_ms = 0x8000_0000), "monitor.k_ms");
    assert_eq!(bad(&|x| x.levels.swap(0, 1)), "monitor.levels");
    assert_eq!(bad(&|x| x.levels[2] = 0), "monitor.levels");
    assert_eq!(bad(&|x| x.levels[1] = x.levels[0]), "monitor.levels");
    assert_eq!(bad(&|x| x.levels[1] = 0), "monitor.levels");
    assert_eq!(bad(&|x| x.block = 0), "monitor.block");
    assert_eq!(bad(&|x| x.drift = 0), "monitor.drift");
    assert_eq!(bad(&|x| x.levels[0] = 1 << 40), "monitor.levels");
    assert_eq!(bad(&|x| x.drive_k = 0), "monitor.drive_k");
    assert_eq!(bad(&|x| x.drive_levels.swap(0, 1)), "monitor.drive_levels");
    assert_eq!(bad(&|x| x.drive_levels[1] = 0), "monitor.drive_levels");
    assert_eq!(
        bad(&|x| x.drive_levels[1] = x.drive_levels[0]),
        "monitor.drive_levels"
    );
    assert_eq!(bad(&|x| x.drive_persist = 0), "monitor.drive_persist");
    assert_eq!(bad(&|x| x.traction_change = 0), "monitor.traction_change");
}

#[test]
fn bad_parameters_name_the_field() {
    let d = MonitorParams::default();
    let field = |p: MonitorParams| match Monitor::<Fx>::try_new(&p, BASE).unwrap_err() {
        wheelset_control::ConfigError::Range { field, .. } => field,
        e => panic!("{e:?}"),
    };
    assert_eq!(field(MonitorParams { rate_hz: 10, ..d }), "monitor.rate_hz");
    // The band's top edge must be strictly below a quarter of the monitor rate.
    let quarter = 0.25 * f64::from(d.rate_hz);
    assert_eq!(
        field(MonitorParams {
            band_hi_hz: quarter,
            ..d
        }),
        "monitor.band_hi_hz"
    );
    for (p, name) in [
        (
            MonitorParams {
                drive_window_steps: 2,
                ..d
            },
            "monitor.drive_window_steps",
        ),
        (
            MonitorParams {
                drive_ripple_a: 0.0,
                ..d
            },
            "monitor.drive_ripple_a",
        ),
        (
            MonitorParams {
                drive_ripple_a: 2500.0,
                ..d
            },
            "monitor.drive_ripple_a",
        ),
        (
            MonitorParams {
                drive_persist_steps: 0,
                ..d
            },
            "monitor.drive_persist_steps",
        ),
        (
            MonitorParams {
                act_traction_change_a: 0.0,
                ..d
            },
            "monitor.act_traction_change_a",
        ),
        (
            MonitorParams {
                act_traction_change_a: 2001.0,
                ..d
            },
            "monitor.act_traction_change_a",
        ),
        (
            MonitorParams {
                current_scale_a: f64::NAN,
                ..d
            },
            "monitor.current_scale_a",
        ),
    ] {
        assert_eq!(field(p), name);
    }
    assert_eq!(
        field(MonitorParams { rate_hz: 6000, ..d }),
        "monitor.rate_hz"
    );
    assert_eq!(
        field(MonitorParams {
            band_lo_hz: 25.0,
            ..d
        }),
        "monitor.band_lo_hz"
    );
    assert_eq!(
        field(MonitorParams {
            band_hi_hz: f64::NAN,
            ..d
        }),
        "monitor.band_hi_hz"
    );
    assert_eq!(
        field(MonitorParams {
            band_hi_hz: 200.0,
            ..d
        }),
        "monitor.band_hi_hz"
    );
    assert_eq!(
        field(MonitorParams {
            window_s: 0.001,
            ..d
        }),
        "monitor.window_s"
    );
    assert_eq!(
        field(MonitorParams {
            threshold_m_s: 0.0,
            ..d
        }),
        "monitor.threshold_m_s"
    );
    assert_eq!(
        field(MonitorParams { release: 1.0, ..d }),
        "monitor.release"
    );
    assert_eq!(
        field(MonitorParams {
            act_floor_m_s: 0.05,
            ..d
        }),
        "monitor.act_floor_m_s"
    );
    assert_eq!(
        field(MonitorParams {
            act_drift_m_s: 0.0005,
            ..d
        }),
        "monitor.act_drift_m_s"
    );
    assert_eq!(
        field(MonitorParams {
            act_growth_per_s: -1.0,
            ..d
        }),
        "monitor.act_growth_per_s"
    );
    assert_eq!(
        field(MonitorParams {
            act_block_s: 0.0,
            ..d
        }),
        "monitor.act_block_s"
    );
    assert_eq!(
        field(MonitorParams { act_blocks: 0, ..d }),
        "monitor.act_blocks"
    );
}

#[test]
fn an_off_monitor_never_alarms() {
    let m = Monitor::<Fx>::default();
    let mut s = MonitorState::default();
    for k in 0..10_000 {
        let ev = m.tick(
            &mut s,
            Fx::from_num(if k % 2 == 0 { 1.0 } else { -1.0 }),
            true,
            Fx::from_num(k % 2),
        );
        assert!(!ev.hunting && !ev.actuator);
    }
}

/// The drift (module docs, "Drift"): a failed wheelset pushed to the flange at a nearly
/// constant `y'` has no band-passed energy, so only the low-passed `y'` shows it. A ramp
/// to 45 mm/s (the reversed actuator on `low-adhesion` at conicity 0.05) while the law
/// commands raises the actuator alarm within the low-pass's settling and two blocks;
/// 10 mm/s (the healthy runs' peak) and the same drift without the law commanding do not.
#[test]
fn a_drift_to_the_flange_raises_the_actuator_alarm() {
    let p = MonitorParams::default();
    let ramp = |v: f64| {
        move |t: f64| {
            if t < 1.0 {
                0.0
            } else {
                v * ((t - 1.0) / 0.1).min(1.0)
            }
        }
    };
    for (name, (h, a, ev)) in [
        ("Q4.28", drive::<Fx>(&p, 2.0, true, ramp(0.045))),
        ("f32", drive::<f32>(&p, 2.0, true, ramp(0.045))),
        ("f64", drive::<f64>(&p, 2.0, true, ramp(0.045))),
    ] {
        assert!(h.is_empty(), "{name}: a drift is no hunting: {h:?}");
        assert_eq!(a.len(), 1, "{name}: {a:?}");
        // |l| passes 25 mm/s about 0.1 + ln(45/20)/(2 pi 3) = 0.14 s after the ramp's
        // start; two block ends after that (blocks of 0.1 s): by 1.4 s.
        assert!(a[0] > 1.1 && a[0] <= 1.4, "{name}: alarm at {}", a[0]);
        assert!(ev.actuator, "{name}: the alarm holds while the drift lasts");
    }
    let (_, a, _) = drive::<Fx>(&p, 2.0, true, ramp(0.010));
    assert!(a.is_empty(), "10 mm/s: {a:?}");
    let (_, a, _) = drive::<Fx>(&p, 2.0, false, ramp(0.045));
    assert!(a.is_empty(), "not commanding: {a:?}");
}

/// The parameter ranges' edges: each open edge refused at exactly its value (a band edge
/// of 0 or equal to the other, a threshold, a release and a growth of 0, a floor equal to
/// the threshold), each closed edge accepted (a threshold of 1 m/s, a floor of 1e-4 m/s).
#[test]
fn the_parameter_ranges_refuse_their_open_edges() {
    let d = MonitorParams::default();
    let refused = |p: MonitorParams, name: &str| match Monitor::<f64>::try_new(&p, BASE) {
        Err(wheelset_control::ConfigError::Range { field, .. }) => assert_eq!(field, name),
        other => panic!("{name}: {other:?}"),
    };
    refused(
        MonitorParams {
            band_lo_hz: 0.0,
            ..d
        },
        "monitor.band_lo_hz",
    );
    refused(
        MonitorParams {
            band_lo_hz: d.band_hi_hz,
            ..d
        },
        "monitor.band_lo_hz",
    );
    refused(
        MonitorParams {
            threshold_m_s: 0.0,
            ..d
        },
        "monitor.threshold_m_s",
    );
    refused(MonitorParams { release: 0.0, ..d }, "monitor.release");
    refused(MonitorParams { release: 1.0, ..d }, "monitor.release");
    refused(
        MonitorParams {
            act_floor_m_s: d.threshold_m_s,
            ..d
        },
        "monitor.act_floor_m_s",
    );
    refused(
        MonitorParams {
            act_growth_per_s: 0.0,
            ..d
        },
        "monitor.act_growth_per_s",
    );
    for ok in [
        MonitorParams {
            threshold_m_s: 1.0,
            ..d
        },
        MonitorParams {
            act_floor_m_s: 1e-4,
            ..d
        },
    ] {
        assert!(Monitor::<f64>::try_new(&ok, BASE).is_ok(), "{ok:?}");
    }
}

/// The traction-change step's range is 1e-3 to 2 current full scales (1 A refused, 2.5 kA
/// accepted at a 2 kA scale), and the mean square's coefficient is `1 - exp(-T/(W/2))`.
#[test]
fn the_traction_change_range_and_the_window_coefficient() {
    let d = MonitorParams::default();
    let with = |a: f64| MonitorParams {
        act_traction_change_a: a,
        current_scale_a: 2000.0,
        ..d
    };
    assert!(Monitor::<f64>::try_new(&with(1.0), BASE).is_err());
    assert!(Monitor::<f64>::try_new(&with(2500.0), BASE).is_ok());
    assert!(Monitor::<f64>::try_new(&with(4001.0), BASE).is_err());
    let m = Monitor::<f64>::try_new(&d, BASE).unwrap();
    let t = 1.0 / f64::from(d.rate_hz);
    let want = 1.0 - (-t / (d.window_s / 2.0)).exp();
    let got = f64::from_bits(m.to_bits().k_ms);
    assert!((got - want).abs() < 1e-12 * want, "{got} vs {want}");
}

/// The alarm levels in (m/s)^2: on at the threshold squared, off at (release x threshold)
/// squared, the block's energy floor at the floor squared times the samples in a block
/// (0.1 s at 500 Hz: 50).
#[test]
fn the_levels_are_the_squares_of_the_parameters() {
    let d = MonitorParams::default();
    let m = Monitor::<f64>::try_new(&d, BASE).unwrap();
    let (on, off, floor) = levels(&m);
    let thr2 = d.threshold_m_s * d.threshold_m_s;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b;
    assert!(close(on, thr2), "{on}");
    assert!(close(off, thr2 * d.release * d.release), "{off}");
    let per_block = (d.act_block_s * f64::from(d.rate_hz)).round();
    assert_eq!(per_block, 50.0);
    assert!(
        close(floor, d.act_floor_m_s * d.act_floor_m_s * per_block),
        "{floor}"
    );
}

/// The monitor steps once every `divisor()` base ticks: 20 steps in 200 ticks at 500 Hz
/// of a 5 kHz base.
#[test]
fn the_monitor_steps_once_per_divisor() {
    let m = Monitor::<f64>::try_new(&MonitorParams::default(), BASE).unwrap();
    assert_eq!(m.divisor(), 10);
    let mut s = MonitorState::default();
    let steps = (0..200)
        .filter(|_| {
            m.tick(&mut s, 0.0, true, 0.0);
            s.phase == m.divisor()
        })
        .count();
    assert_eq!(steps, 20);
}

/// The divisor is `base / rate` rounded half up: 2.5 ticks a step is 3, 2.4 is 2; and
/// [`Monitor::retime`] follows a new base rate.
#[test]
fn the_divisor_rounds_half_up() {
    let p = |hz| MonitorParams {
        rate_hz: hz,
        ..MonitorParams::default()
    };
    assert_eq!(
        Monitor::<f64>::try_new(&p(2000), 5000).unwrap().divisor(),
        3
    );
    assert_eq!(
        Monitor::<f64>::try_new(&p(2000), 4800).unwrap().divisor(),
        2
    );
    let mut m = Monitor::<f64>::try_new(&p(500), 5000).unwrap();
    m.retime(1250);
    assert_eq!(m.divisor(), 3);
}

/// One monitor step at a block end (phase and block count at 1) on `y' = 0` with the
/// state's filters at rest, the block's energy `energy` and the last block's 0.
fn block_end(m: &Monitor<f64>, energy: f64, s: &mut MonitorState<f64>) {
    s.phase = 1;
    s.block_left = 1;
    s.energy = energy;
    s.energy_prev = 0.0;
    m.tick(s, 0.0, true, 0.0);
}

/// A block grows only with its energy strictly above the floor: at the floor the run of
/// growing blocks does not start, one step above it does.
#[test]
fn a_block_at_the_energy_floor_is_not_growth() {
    let m = Monitor::<f64>::try_new(&MonitorParams::default(), BASE).unwrap();
    let (_, _, floor) = levels(&m);
    let mut s = MonitorState::default();
    block_end(&m, floor, &mut s);
    assert_eq!(s.run, 0);
    block_end(&m, floor.next_up(), &mut s);
    assert_eq!(s.run, 1);
}

/// The actuator alarm, once raised, holds while the mean square is at or above the off
/// level or the run of growing blocks goes on, and releases at the first block end with
/// neither.
#[test]
fn the_actuator_alarm_releases_when_growth_and_motion_stop() {
    let m = Monitor::<f64>::try_new(&MonitorParams::default(), BASE).unwrap();
    let (_, off, floor) = levels(&m);
    let mut s = MonitorState::default();
    s.ev.actuator = true;
    // Still growing: held.
    block_end(&m, 2.0 * floor, &mut s);
    assert!(s.ev.actuator && s.run == 1);
    // The mean square at twice the off level with no growth: held.
    s.ms = 2.0 * off;
    block_end(&m, 0.0, &mut s);
    assert!(s.ev.actuator && s.run == 0 && s.ms >= off, "{}", s.ms);
    // Neither: released.
    s.ms = 0.0;
    block_end(&m, 0.0, &mut s);
    assert!(!s.ev.actuator);
}

/// A block grows only by more than the growth factor over the last: a block whose energy
/// shrunk by the factor equals the last block's is not growth.
#[test]
fn a_block_grown_by_exactly_the_factor_is_not_growth() {
    let m = Monitor::<f64>::try_new(&MonitorParams::default(), BASE).unwrap();
    let (_, _, floor) = levels(&m);
    let shrink = f64::from_bits(m.to_bits().shrink);
    let e = 4.0 * floor;
    let mut s = MonitorState::default();
    let mut end = |prev: f64| {
        s.phase = 1;
        s.block_left = 1;
        s.energy = e;
        s.energy_prev = prev;
        m.tick(&mut s, 0.0, true, 0.0);
        s.run
    };
    assert_eq!(end(e * shrink), 0);
    assert_eq!(end((e * shrink).next_down()), 1);
}

/// The hunting alarm rises only with the mean square strictly above the on level: a step
/// that lands it exactly on the level does not raise it, one LSB above does.
#[test]
fn the_hunting_alarm_rises_strictly_above_its_level() {
    let m = Monitor::<f64>::try_new(&MonitorParams::default(), BASE).unwrap();
    let (on, _, _) = levels(&m);
    let k = f64::from_bits(m.to_bits().k_ms);
    // A step on y' = 0 at rest decays the mean square by (1 - k): find the start that
    // lands on `on` exactly.
    let after = |ms: f64| {
        let mut s = MonitorState {
            ms,
            block_left: 1000,
            ..MonitorState::default()
        };
        m.tick(&mut s, 0.0, false, 0.0);
        s
    };
    let mut ms = on / (1.0 - k);
    for _ in 0..64 {
        let got = after(ms).ms;
        if got == on {
            break;
        }
        ms = if got > on {
            ms.next_down()
        } else {
            ms.next_up()
        };
    }
    let s = after(ms);
    assert_eq!(s.ms, on, "no start lands on the level");
    assert!(!s.ev.hunting && !s.ev.hunting_rose);
    let mut up = ms.next_up();
    while after(up).ms == on {
        up = up.next_up();
    }
    assert!(after(up).ev.hunting_rose);
}
