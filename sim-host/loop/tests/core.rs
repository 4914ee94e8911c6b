//! The control core on the plant (`wheelset_loop::core`) as a sampled-data controller:
//! at a fast rate it approaches the continuous run, a slow rate is visibly different,
//! and with sensor noise, quantisation, delay and actuator limits it still follows the
//! pure-rolling line.
#![allow(clippy::unwrap_used)]

use wheelset_loop::core::CoreController;
use wheelset_loop::device_loop::control_config;
use wheelset_plant::control::YawLaw;
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::{run_continuous, run_sampled, ActuatorModel, SensorModel, Trajectory};

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

/// The f64 core of `law` at `rate_hz` with the predictor `predict` ticks, the protection
/// off and the current reference's slew limit lifted (the continuous controllers have
/// neither): what remains is the sampling, the wire quantisation and the core's clamps.
fn core_at(sc: &Scenario, law: YawLaw, rate_hz: u32, predict: f64) -> CoreController<f64> {
    let mut cfg = control_config(&sc.params, law, sc.drive);
    cfg.base_rate_hz = rate_hz;
    cfg.yaw_predict_ticks = predict;
    cfg.limits.current_ref_rate = 1e9;
    CoreController::<f64>::try_new(&cfg, false).unwrap()
}

#[test]
fn fast_sampled_core_approaches_the_continuous_run() {
    let sc = Scenario::load("curve", &Params::default()).unwrap();
    let fast_hz = (1_000_000_000 / sc.dt_ns) as u32;
    for law in [YawLaw::Gain, YawLaw::Lead] {
        let cont = run_continuous(&sc, law);
        let mut dctrl = core_at(&sc, law, fast_hz, 0.0);
        let samp = run_sampled(
            &sc,
            &mut dctrl,
            &mut SensorModel::ideal(),
            &mut ActuatorModel::ideal(),
            false,
            "f64",
        )
        .unwrap();
        assert_eq!(cont.records.len(), samp.records.len());
        assert_eq!(samp.info.controller_calls, 200_000);
        let y = |t: &Trajectory| t.records.iter().map(|r| r.y_m).collect::<Vec<_>>();
        let i = |t: &Trajectory| t.records.iter().map(|r| r.i_a_a).collect::<Vec<_>>();
        let dy = max_diff(&y(&cont), &y(&samp));
        let di = max_diff(&i(&cont), &i(&samp));
        // Within 5 % of the peak displacement and 5 % of the current reference.
        eprintln!("{law:?}: dy {dy} di {di}");
        assert!(dy < 0.05 * 0.9e-3, "{law:?}: max |dy| = {dy}");
        assert!(di < 0.05 * 115.0, "{law:?}: max |di| = {di}");
        // A slow rate is visibly different (the test can tell rates apart).
        let mut slow = core_at(&sc, law, fast_hz / 10, 0.0);
        let s2 = run_sampled(
            &sc,
            &mut slow,
            &mut SensorModel::ideal(),
            &mut ActuatorModel::ideal(),
            false,
            "slow",
        )
        .unwrap();
        let dy2 = max_diff(&y(&cont), &y(&s2));
        let di2 = max_diff(&i(&cont), &i(&s2));
        eprintln!("{law:?}: slow dy {dy2} di {di2}");
        assert!(dy2 > dy || !dy2.is_finite() || di2 > di, "{dy2} {dy}");
    }
}

#[test]
fn noisy_quantised_delayed_loop_still_follows_the_pure_rolling_line() {
    let sc = Scenario::load("curve", &Params::default()).unwrap();
    let base_hz = (1_000_000_000 / (2 * sc.dt_ns)) as u32; // 5 kHz
    let mut d = core_at(&sc, YawLaw::Lead, base_hz, 0.0);
    // 1 mm/s noise on y', 0.1 mm/s LSB, 0.5 A noise, 0.1 A LSB; 0.2 ms delay; limits.
    let mut sensor = SensorModel::new([1e-3, 0.0, 0.5, 0.0, 0.0], [1e-4, 0.0, 0.1, 0.0, 0.0], 9);
    let mut act = ActuatorModel::ideal();
    act.delay_ns = 2 * sc.dt_ns;
    act.t_psi_max = 2e4;
    act.u_a_range = (0.0, 5000.0);
    let tr = run_sampled(&sc, &mut d, &mut sensor, &mut act, false, "noisy").unwrap();
    assert_eq!(tr.info.diverged_at_s, None);
    let r = tr.at(11.9).unwrap();
    let rel = (r.y_m - r.y0_m).abs() / r.y0_m;
    assert!(rel < 0.01, "y = {} vs y0 = {} ({rel})", r.y_m, r.y0_m);
    assert!((r.i_a_a - 114.95).abs() < 2.0, "{}", r.i_a_a);
    // Noise reaches the torque: it is not exactly zero on the constant curve.
    let spread = tr
        .records
        .iter()
        .filter(|r| r.t_s > 8.0 && r.t_s < 11.0)
        .map(|r| r.t_ctrl_nm.abs())
        .fold(0.0, f64::max);
    assert!(spread > 1.0 && spread < 5e3, "{spread}");
}
