//! The sampled-data path: a trivial f64 discrete controller at a fast rate approaches
//! the continuous run; the sensor and actuator stages do what they say.

#![allow(clippy::unwrap_used)]

use wheelset_plant::control::{
    Actuation, ContinuousController, F64Sampled, Measurements, SampledController, YawLaw,
};
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::{run_continuous, run_sampled, ActuatorModel, SensorModel, SimError};

fn max_diff(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max)
}

#[test]
fn fast_sampled_controllers_approach_the_continuous_run() {
    let sc = Scenario::load("curve", &Params::default()).unwrap();
    for law in [YawLaw::Gain, YawLaw::Lead] {
        let cont = run_continuous(&sc, law);
        let ctrl = ContinuousController::new(&sc.params, law);
        let mut dctrl = F64Sampled::new(ctrl, sc.dt_ns, sc.params.k_m);
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
        let y = |t: &wheelset_plant::sim::Trajectory| {
            t.records.iter().map(|r| r.y_m).collect::<Vec<_>>()
        };
        let i = |t: &wheelset_plant::sim::Trajectory| {
            t.records.iter().map(|r| r.i_a_a).collect::<Vec<_>>()
        };
        let dy = max_diff(&y(&cont), &y(&samp));
        let di = max_diff(&i(&cont), &i(&samp));
        // Within 2 % of the peak displacement and 2 % of the current reference.
        eprintln!("{law:?}: dy {dy} di {di}");
        assert!(dy < 0.05 * 0.9e-3, "{law:?}: max |dy| = {dy}");
        assert!(di < 0.05 * 115.0, "{law:?}: max |di| = {di}");
        // A slow rate is visibly different (the test can tell rates apart).
        let mut slow = F64Sampled::new(ctrl, 10 * sc.dt_ns, sc.params.k_m);
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
        eprintln!("{law:?}: slow dy {dy2} di {}", max_diff(&i(&cont), &i(&s2)));
        let di2 = max_diff(&i(&cont), &i(&s2));
        assert!(dy2 > dy || !dy2.is_finite() || di2 > di, "{dy2} {dy}");
    }
}

struct Probe {
    period: u64,
    seen: Vec<(u64, Measurements)>,
}

impl SampledController for Probe {
    fn period_ns(&self) -> u64 {
        self.period
    }
    fn step(&mut self, t_ns: u64, meas: &Measurements) -> Actuation {
        self.seen.push((t_ns, *meas));
        Actuation {
            t_psi: 1e9,
            u_a: meas.w_m * 4.28,
        }
    }
}

#[test]
fn controller_is_called_on_its_grid_and_actuator_limits_are_counted() {
    let src = "duration_s = 0.01\n[sim]\ndt_s = 1e-4\noutput_dt_s = 1e-4\n";
    let sc = Scenario::from_toml_str(src, "short.toml", &Params::default()).unwrap();
    let mut probe = Probe {
        period: 500_000,
        seen: vec![],
    };
    let mut act = ActuatorModel::ideal();
    act.t_psi_max = 100.0;
    act.delay_ns = 200_000;
    let tr = run_sampled(
        &sc,
        &mut probe,
        &mut SensorModel::ideal(),
        &mut act,
        false,
        "p",
    )
    .unwrap();
    let times: Vec<u64> = probe.seen.iter().map(|s| s.0).collect();
    assert_eq!(times, (0..20).map(|k| k * 500_000).collect::<Vec<_>>());
    assert_eq!(tr.info.actuator_clamps, 20);
    // Delay: the clamped torque acts from 0.2 ms on, not before.
    assert_eq!(tr.records[1].t_ctrl_nm, 0.0); // t = 0.1 ms
    assert_eq!(tr.records[2].t_ctrl_nm, 100.0); // t = 0.2 ms
                                                // Bad period / delay are refused.
    let mut p2 = Probe {
        period: 150_000,
        seen: vec![],
    };
    let e = run_sampled(
        &sc,
        &mut p2,
        &mut SensorModel::ideal(),
        &mut ActuatorModel::ideal(),
        false,
        "p",
    );
    assert!(matches!(e, Err(SimError::Period { .. })));
}

#[test]
fn sensor_model_quantises_and_adds_seeded_noise() {
    let m = Measurements {
        yd_mps: 0.01234,
        i_a: 57.3,
        ..Default::default()
    };
    let mut q = SensorModel::new([0.0; 5], [0.001, 0.0, 0.5, 0.0, 0.0], 1);
    let out = q.apply(&m);
    assert!((out.yd_mps - 0.012).abs() < 1e-12);
    assert!((out.i_a - 57.5).abs() < 1e-12);
    let mut a = SensorModel::new([1e-3, 0.0, 0.0, 0.0, 0.0], [0.0; 5], 42);
    let mut b = SensorModel::new([1e-3, 0.0, 0.0, 0.0, 0.0], [0.0; 5], 42);
    let xs: Vec<f64> = (0..2000).map(|_| a.apply(&m).yd_mps - m.yd_mps).collect();
    let ys: Vec<f64> = (0..2000).map(|_| b.apply(&m).yd_mps - m.yd_mps).collect();
    assert_eq!(xs, ys, "same seed, same noise");
    let mean = xs.iter().sum::<f64>() / xs.len() as f64;
    let sd = (xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / xs.len() as f64).sqrt();
    assert!(
        mean.abs() < 1e-4 && (sd - 1e-3).abs() < 1e-4,
        "mean {mean} sd {sd}"
    );
}

#[test]
fn noisy_quantised_delayed_loop_still_follows_the_pure_rolling_line() {
    let sc = Scenario::load("curve", &Params::default()).unwrap();
    let ctrl = ContinuousController::new(&sc.params, YawLaw::Lead);
    let mut d = F64Sampled::new(ctrl, 2 * sc.dt_ns, sc.params.k_m); // 5 kHz
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
