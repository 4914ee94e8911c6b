//! The closed loop over the simulated serial link: the firmware runtime (fixed point)
//! against the plant, compared with the continuous reference, and under faults.

use wheelset_loop::device_loop::{
    run_device, Deviation, DeviationAcc, DeviceError, DeviceOptions, DeviceRun, CURVE_WINDOWS,
};
use wheelset_loop::sim_link::LinkConfig;
use wheelset_plant::control::YawLaw;
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::run_continuous;
use wheelset_plant::sim::Trajectory;
use wheelset_proto::Flags;

/// `run` against `reference` record by record (`DeviationAcc`).
fn deviation(run: &Trajectory, reference: &Trajectory, windows: [(f64, f64); 2]) -> Deviation {
    let mut acc = DeviationAcc::new(windows);
    for (a, b) in run.records.iter().zip(&reference.records) {
        acc.push(a, b);
    }
    acc.finish()
}

fn curve() -> Scenario {
    Scenario::load("curve", &Params::default()).expect("built-in scenario")
}

fn with_faults(spec: &str, seed: u64) -> DeviceOptions {
    DeviceOptions {
        link: LinkConfig {
            faults: spec.parse().expect("valid fault spec"),
            seed,
            ..LinkConfig::default()
        },
        ..DeviceOptions::default()
    }
}

fn max_abs_y(run: &DeviceRun) -> f64 {
    run.trajectory
        .records
        .iter()
        .map(|r| r.y_m.abs())
        .fold(0.0, f64::max)
}

#[test]
fn curve_with_lead_reproduces_the_continuous_reference() {
    let sc = curve();
    let run = run_device(&sc, YawLaw::Lead, &DeviceOptions::default()).expect("runs");
    let reference = run_continuous(&sc, YawLaw::Lead);
    let d = deviation(&run.trajectory, &reference, CURVE_WINDOWS);
    println!("device vs continuous: {d}");
    assert!(!d.diverged);
    for w in &d.windows {
        assert!(w.y_rel < 0.01, "y off by {} % in {w:?}", w.y_rel * 100.0);
        assert!(
            w.f_rel < 0.02,
            "creep forces off by {} % in {w:?}",
            w.f_rel * 100.0
        );
    }
    // The pure rolling line r0 Lg / (lambda R) on the constant curve.
    let y0 = sc.params.pure_rolling_y(1.0 / 2300.0);
    let at = |t: f64| {
        run.trajectory
            .records
            .iter()
            .find(|r| (r.t_s - t).abs() < 1e-6)
            .map(|r| r.y_m)
            .expect("record")
    };
    assert!((at(4.9) - y0).abs() < 0.001 * y0, "{} vs {y0}", at(4.9));
    // A clean link: every frame arrives, every actuation is this period's.
    let r = &run.report;
    assert_eq!((r.up.sent, r.up.received), (r.up.sent, r.up.sent), "{r}");
    assert_eq!(r.down.received, r.down.sent, "{r}");
    assert!(run.link.iter().all(|l| l.fresh && l.age == 0));
    assert!(run
        .link
        .iter()
        .all(|l| Flags(l.flags) == Flags(Flags::ENABLED)));
}

#[test]
fn faults_keep_the_wheelset_near_the_track_and_every_frame_is_accounted() {
    let sc = curve();
    // BER 1e-3, 10 % frame drops, a 50 ms outage of both directions on the constant curve.
    let run = run_device(
        &sc,
        YawLaw::Lead,
        &with_faults("ber=1e-3,drop=0.1,outage=8.0:0.05", 1),
    )
    .expect("runs");
    let r = &run.report;
    println!("{r}");
    let y = max_abs_y(&run);
    assert!(y < 8e-3, "max |y| {} mm", y * 1e3);
    assert!(r.up.adds_up() && r.down.adds_up(), "{r}");
    assert!(
        r.up.rejected > 0 && r.up.dropped > 0 && r.down.rejected > 0,
        "{r}"
    );
    let st = r.device.expect("status read back");
    // The device's own counters agree with the link-side accounting.
    assert_eq!(u64::from(st.rx_ok), r.up.received, "{r}");
    assert_eq!(
        u64::from(st.rx_crc + st.rx_cobs + st.rx_version + st.rx_length + st.rx_postcard),
        r.up.errors.iter().sum::<u64>(),
        "{r}"
    );
    // The outage (250 periods) is longer than the hold: the device entered the safe
    // state and left it when frames returned.
    assert!(
        st.safe_entries >= 1 && st.safe_exits == st.safe_entries,
        "{r}"
    );
    assert!(st.safe_ticks >= 200, "{r}");
    // Frame age: held actuations during the outage, back to fresh after it.
    let age_in_outage = run.link_at(8_040_000_000).map(|l| l.age).expect("record");
    assert!(age_in_outage > 100, "age {age_in_outage}");
    assert!(run.link_at(9_000_000_000).is_some_and(|l| l.age < 5));
}

#[test]
fn a_sensor_outage_drives_the_safe_state_onto_the_plant() {
    let sc = curve();
    let run = run_device(&sc, YawLaw::Lead, &with_faults("outage=8.0:0.05:up", 2)).expect("runs");
    let r = &run.report;
    assert_eq!((r.safe_entries_seen, r.safe_exits_seen), (1, 1), "{r}");
    assert!(r.safe_periods >= 200, "{r}");
    assert!(max_abs_y(&run) < 8e-3);
    // While safe, the device drives the back-EMF (current decays) and ramps the torque down.
    let safe: Vec<_> = run
        .trajectory
        .records
        .iter()
        .filter(|rec| {
            run.link_at((rec.t_s * 1e9).round() as u64)
                .is_some_and(|l| Flags(l.flags).has(Flags::SAFE))
        })
        .collect();
    let last = safe.last().expect("safe records");
    assert!(
        last.i_a_a.abs() < 60.0,
        "current {} A at the end of the safe state",
        last.i_a_a
    );
    assert!(r.up.adds_up() && r.down.adds_up(), "{r}");
}

#[test]
fn a_link_budget_that_does_not_fit_is_refused() {
    let sc = curve();
    let opt = DeviceOptions {
        link: LinkConfig {
            baud: 1_000_000,
            ..LinkConfig::default()
        },
        ..DeviceOptions::default()
    };
    match run_device(&sc, YawLaw::Lead, &opt) {
        Err(DeviceError::Budget(e)) => {
            let m = e.to_string();
            assert!(m.contains("1000000 baud") && m.contains("200.0 us"), "{m}");
        }
        other => panic!(
            "expected a budget error, got {:?}",
            other.map(|r| r.report.to_string())
        ),
    }
}

#[test]
fn a_faulted_run_is_deterministic_for_its_seed() {
    let sc = curve();
    let spec = "ber=1e-3,drop=0.1,burst=5:8,outage=3.0:0.02";
    let a = run_device(&sc, YawLaw::Lead, &with_faults(spec, 9)).expect("runs");
    let b = run_device(&sc, YawLaw::Lead, &with_faults(spec, 9)).expect("runs");
    let c = run_device(&sc, YawLaw::Lead, &with_faults(spec, 10)).expect("runs");
    assert_eq!(a.trajectory.records, b.trajectory.records);
    assert_eq!(a.link, b.link);
    assert_eq!(a.report.up, b.report.up);
    assert_ne!(a.link, c.link);
}

#[test]
fn acceleration_sensing_integrated_on_the_device_also_reproduces_the_reference() {
    let sc = curve();
    let opt = DeviceOptions {
        lateral: wheelset_loop::device_loop::LateralSensing::Acceleration,
        ..DeviceOptions::default()
    };
    let run = run_device(&sc, YawLaw::Lead, &opt).expect("runs");
    let d = deviation(
        &run.trajectory,
        &run_continuous(&sc, YawLaw::Lead),
        CURVE_WINDOWS,
    );
    println!("device (y'' sensing) vs continuous: {d}");
    assert!(!d.diverged);
    for w in &d.windows {
        assert!(w.y_rel < 0.01 && w.f_rel < 0.02, "{d}");
    }
    assert_eq!(run.report.device.map(|s| s.rx_unexpected), Some(0));
}

/// `--wsp on|off` on the device loop: the host sets `Config.wsp`; with it the
/// device's protection acts (its Status counts it, the `WHEEL_SLIP` flag reaches the
/// host) and no wheel runs away; without it the runaway shows. The device's section
/// table follows the f64 control core's (`--loop core`, the same laws) to 0.02 in
/// utilisation.
#[test]
fn low_adhesion_protection_is_switched_by_the_config() {
    let sc = Scenario::load("low-adhesion", &Params::default()).expect("built-in scenario");
    let on = run_device(&sc, YawLaw::Lead, &DeviceOptions::default()).expect("runs");
    let off = run_device(
        &sc,
        YawLaw::Lead,
        &DeviceOptions {
            wsp: false,
            ..DeviceOptions::default()
        },
    )
    .expect("runs");
    let s_on = on.report.device.expect("status");
    let s_off = off.report.device.expect("status");
    assert!(s_on.wsp_events >= 1 && s_on.wsp_ticks > 0, "{s_on:?}");
    assert_eq!((s_off.wsp_events, s_off.wsp_ticks), (0, 0));
    let slip_flags = on
        .link
        .iter()
        .filter(|l| Flags(l.flags).has(Flags::WHEEL_SLIP))
        .count();
    assert!(slip_flags > 0);
    let a_on = wheelset_plant::traction::summary(&sc, &on.trajectory).expect("sections");
    let a_off = wheelset_plant::traction::summary(&sc, &off.trajectory).expect("sections");
    assert!(!a_on.runaway, "{a_on:?}");
    assert!(a_off.runaway, "{a_off:?}");
    let (core, _) =
        wheelset_loop::core::run_core::<f64>(&sc, YawLaw::Lead, true).expect("core runs");
    let a_core = wheelset_plant::traction::summary(&sc, &core).expect("sections");
    for (d, c) in a_on.sections.iter().zip(&a_core.sections) {
        assert!(
            (d.utilisation - c.utilisation).abs() < 0.02,
            "{} {}-{} s: device {} core {}",
            d.condition,
            d.t0,
            d.t1,
            d.utilisation,
            c.utilisation
        );
    }
}

/// A configuration the device cannot run is refused before the run, with its reason.
#[test]
fn a_refused_config_is_an_error_naming_it() {
    let e = DeviceError::Refused(
        wheelset_proto::RefuseReason::HoldTicks,
        wheelset_proto::Config {
            mode: wheelset_proto::YawMode::Lead,
            traction: true,
            enable: true,
            hold_ticks: 1,
            wsp: true,
            monitor_safe: false,
            rates: None,
        },
    )
    .to_string();
    assert!(
        e.contains("wsp on") && e.contains(wheelset_proto::RefuseReason::HoldTicks.field()),
        "{e}"
    );
}

/// `Config.monitor_safe` and `Command::ClearFaults` from the host: on
/// `actuator-fault` the alarm latches `FAULT_LATCHED` and holds the safe state; the
/// ClearFaults the host sends 30 ms after the first alarm clears both (the alarm state
/// stays high, so no new rising edge re-latches it).
#[test]
fn clear_faults_from_the_host_releases_the_monitor_latch() {
    let sc = Scenario::load("actuator-fault", &Params::default()).expect("built-in scenario");
    let probe = run_device(
        &sc,
        YawLaw::Lead,
        &DeviceOptions {
            monitor_safe: true,
            ..DeviceOptions::default()
        },
    )
    .expect("runs");
    let alarm = Flags::HUNTING | Flags::ACTUATOR_FAULT;
    let first = probe
        .link
        .iter()
        .find(|l| l.flags & alarm != 0)
        .expect("an alarm")
        .t_ns;
    let latched =
        |l: &&wheelset_loop::device_loop::LinkSample| Flags(l.flags).has(Flags::FAULT_LATCHED);
    let safe = |l: &&wheelset_loop::device_loop::LinkSample| Flags(l.flags).has(Flags::SAFE);
    assert!(probe
        .link
        .iter()
        .filter(|l| l.t_ns > first)
        .all(|l| latched(&l)));
    assert!(probe.link.iter().any(|l| safe(&l)));
    let clear = first + 30_000_000;
    let run = run_device(
        &sc,
        YawLaw::Lead,
        &DeviceOptions {
            monitor_safe: true,
            clear_faults_at_ns: Some(clear),
            ..DeviceOptions::default()
        },
    )
    .expect("runs");
    let before: Vec<_> = run
        .link
        .iter()
        .filter(|l| l.t_ns > first && l.t_ns < clear)
        .collect();
    assert!(!before.is_empty() && before.iter().all(latched) && before.iter().any(safe));
    // Applied at the device's next tick, seen in the actuation after it.
    let after: Vec<_> = run
        .link
        .iter()
        .filter(|l| l.t_ns >= clear + 3 * run.period_ns)
        .collect();
    assert!(!after.is_empty());
    assert!(
        after.iter().all(|l| !latched(l) && !safe(l)),
        "{:?}",
        after.first()
    );
}
