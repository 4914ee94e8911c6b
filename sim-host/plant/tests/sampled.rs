//! The sampled-data path: the controller is called on its grid, the sensor and actuator
//! stages do what they say. (The control core on this path, against the continuous run:
//! `wheelset-loop`'s `tests/core.rs`.)

#![allow(clippy::unwrap_used)]

use wheelset_plant::control::{Actuation, Measurements, SampledController};
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::{run_sampled, ActuatorModel, SensorModel, SimError};

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
