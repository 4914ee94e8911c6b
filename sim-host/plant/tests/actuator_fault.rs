//! The plant's yaw-actuator faults (scenario data): the run is the healthy one before the
//! fault, and after it the wheelset hunts at the growth rate of the passive-less plant's
//! unstable mode (`wheelset_plant::fault::failed_actuator_mode`).
#![allow(clippy::unwrap_used, clippy::expect_used)]

use wheelset_plant::control::YawLaw;
use wheelset_plant::fault::{failed_actuator_mode, ActuatorFault, FaultMode};
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::{run_continuous, Trajectory};

fn load(name: &str) -> Scenario {
    Scenario::load(name, &Params::default()).expect("built-in scenario")
}

/// Peak |y'| over `[t0, t1)`.
fn peak(tr: &Trajectory, t0: f64, t1: f64) -> f64 {
    tr.records
        .iter()
        .filter(|r| r.t_s >= t0 && r.t_s < t1)
        .map(|r| r.yd_mps.abs())
        .fold(0.0, f64::max)
}

#[test]
fn the_failed_actuator_lets_the_wheelset_hunt_at_the_modal_rate() {
    let sc = load("actuator-fault");
    let fault = sc.actuator_fault.expect("the scenario has a fault");
    assert_eq!(fault.mode, FaultMode::Off);
    assert_eq!(fault.t_on_ns, 6_000_000_000);
    assert_eq!(sc.params.lambda, 0.3);
    let healthy = Scenario {
        actuator_fault: None,
        ..sc.clone()
    };
    let a = run_continuous(&sc, YawLaw::Lead);
    let b = run_continuous(&healthy, YawLaw::Lead);
    // Identical up to the fault.
    for (ra, rb) in a
        .records
        .iter()
        .zip(&b.records)
        .take_while(|(r, _)| r.t_s < 6.0)
    {
        assert_eq!(ra.y_m.to_bits(), rb.y_m.to_bits(), "t = {}", ra.t_s);
    }
    // After it: no torque delivered, the healthy run stays put, the faulty one diverges.
    assert!(a
        .records
        .iter()
        .filter(|r| r.t_s >= 6.0)
        .all(|r| r.t_ctrl_nm == 0.0));
    assert!(b.info.diverged_at_s.is_none());
    let t_div = a.info.diverged_at_s.expect("hunting");
    assert!(t_div > 6.0 && t_div < 7.0, "{t_div}");
    // Growth of the peak |y'| over 50 ms windows, 6.10 -> 6.25 s, against the modal rate.
    let m = failed_actuator_mode(&sc.params, sc.axle, sc.drive).expect("a mode");
    let (p0, p1) = (peak(&a, 6.10, 6.15), peak(&a, 6.25, 6.30));
    let sigma = (p1 / p0).ln() / 0.15;
    println!(
        "modal sigma {:.2} 1/s ({:.2} Hz), measured {sigma:.2} 1/s",
        m.sigma_per_s, m.f_hz
    );
    assert!(
        (sigma / m.sigma_per_s - 1.0).abs() < 0.15,
        "{sigma} vs {m:?}"
    );
}

#[test]
fn fraction_and_reversed_scale_the_delivered_torque() {
    let base = load("actuator-fault");
    let with = |mode| Scenario {
        actuator_fault: Some(ActuatorFault {
            t_on_ns: 6_000_000_000,
            mode,
        }),
        ..base.clone()
    };
    let half = run_continuous(&with(FaultMode::Fraction(0.5)), YawLaw::Lead);
    let rev = run_continuous(&with(FaultMode::Reversed), YawLaw::Lead);
    let off = run_continuous(&base, YawLaw::Lead);
    // Half the law hunts later than none (or not at all); a reversed one sooner.
    let (t_rev, t_off) = (
        rev.info.diverged_at_s.unwrap(),
        off.info.diverged_at_s.unwrap(),
    );
    let t_half = half.info.diverged_at_s.unwrap_or(f64::INFINITY);
    println!("diverged: reversed {t_rev} s, off {t_off} s, half {t_half} s");
    assert!(
        t_rev < t_off && t_off < t_half,
        "reversed {t_rev} s, off {t_off} s, half {t_half} s"
    );
    // The recorded torque is the delivered one: reversed = -(commanded).
    let r = rev.records.iter().find(|r| r.t_s >= 6.0).unwrap();
    assert!(r.t_ctrl_nm != 0.0);
}

#[test]
fn a_fault_does_not_touch_the_passive_spring() {
    let sc = load("actuator-fault");
    let healthy = Scenario {
        actuator_fault: None,
        ..sc.clone()
    };
    let a = run_continuous(&sc, YawLaw::Passive);
    let b = run_continuous(&healthy, YawLaw::Passive);
    assert_eq!(a.records.len(), b.records.len());
    for (ra, rb) in a.records.iter().zip(&b.records) {
        assert_eq!(ra.y_m.to_bits(), rb.y_m.to_bits());
    }
}

#[test]
fn scenario_files_refuse_bad_faults() {
    let src = |t: &str| format!("duration_s = 10.0\n[actuator_fault]\n{t}\n");
    let p = Params::default();
    for (body, key) in [
        ("t_s = 11.0\nmode = \"off\"", "actuator_fault.t_s"),
        ("t_s = 1.0\nmode = \"stuck\"", "actuator_fault.mode"),
        ("t_s = 1.0\nmode = \"fraction\"", "actuator_fault.fraction"),
        (
            "t_s = 1.0\nmode = \"fraction\"\nfraction = 1.5",
            "actuator_fault.fraction",
        ),
    ] {
        let e = Scenario::from_toml_str(&src(body), "f.toml", &p).unwrap_err();
        assert_eq!(e.key(), Some(key), "{body}: {e}");
        assert!(e.to_string().contains("f.toml"), "{e}");
    }
    let e = Scenario::from_toml_str(&src("t_s = 1.0\nmode = \"off\"\ngain = 2"), "f.toml", &p)
        .unwrap_err();
    assert!(e.to_string().contains("gain"), "{e}");
}

/// A reversed actuator pushes the mode with the law's own gain: on `actuator-fault`
/// (conicity 0.3, the lead) `y'` grows several times faster than with the actuator
/// stopped (the free wheelset's rate), about 100 1/s, and the run diverges within
/// 0.2 s of the fault (`wheelset_control::monitor`'s docs cite this).
#[test]
fn a_reversed_actuator_grows_faster_than_the_free_wheelset() {
    let base = load("actuator-fault");
    let run = |mode| {
        let sc = Scenario {
            actuator_fault: Some(ActuatorFault {
                mode,
                ..base.actuator_fault.expect("the scenario has a fault")
            }),
            ..base.clone()
        };
        run_continuous(&sc, YawLaw::Lead)
    };
    let growth = |tr: &Trajectory| (peak(tr, 6.07, 6.09) / peak(tr, 6.02, 6.04)).ln() / 0.05;
    let (off, rev) = (run(FaultMode::Off), run(FaultMode::Reversed));
    let (g_off, g_rev) = (growth(&off), growth(&rev));
    println!("growth after the fault: stopped {g_off:.1} 1/s, reversed {g_rev:.1} 1/s");
    assert!(
        g_rev > 3.0 * g_off && g_rev > 70.0 && g_rev < 150.0,
        "{g_rev} vs {g_off}"
    );
    let t_div = rev.info.diverged_at_s.expect("the reversed loop diverges");
    assert!(t_div > 6.0 && t_div < 6.2, "{t_div}");
}
