//! The sampled-data analysis (`wheelset_plant::sampled`) through its public API: the ZOH, the
//! tick matrices against a simulation of the controllers, the monodromy's modes, the
//! continuous closed loop, the plant variants and the link budget. (Moved from the
//! module's unit tests when `sampled.rs` was split.)
#![allow(clippy::unwrap_used, clippy::expect_used)]

use nalgebra::DMatrix;
use wheelset_control::{Config, YawMode};
use wheelset_control::{F64Controller, Inputs};
use wheelset_plant::params::Params;
use wheelset_plant::sampled::*;

#[test]
fn zoh_of_a_scalar_is_exact() {
    let (a, b, t) = (-100.0, 2500.0, 2e-4);
    let (ad, bd) = zoh(
        &DMatrix::from_element(1, 1, a),
        &DMatrix::from_row_slice(1, 2, &[0.0, b]),
        t,
    );
    assert!((ad[(0, 0)] - (a * t).exp()).abs() < 1e-14);
    assert!((bd[(0, 1)] - ((a * t).exp() - 1.0) / a * b).abs() < 1e-12);
    assert_eq!(bd[(0, 0)], 0.0);
}

/// The armature under the PI with one tick of delay, by hand:
/// `i' = alpha i + beta a`, `a' = -(Kp + Ki) i + I`, `I' = I - Ki i`.
#[test]
fn current_loop_eigenvalues_match_the_hand_built_loop() {
    for base in [2000u32, 5000, 10_000] {
        let cfg = Config {
            base_rate_hz: base,
            yaw_mode: YawMode::Passive,
            ..Config::default()
        };
        let cl = closed_loop(&armature(4e-4, 0.04), &cfg, 1).expect("valid");
        let t = 1.0 / base as f64;
        let alpha = (-100.0 * t).exp();
        let beta = (1.0 - alpha) / 0.04;
        let (kp, ki) = (1.0, t / 0.5);
        let m = DMatrix::from_row_slice(
            3,
            3,
            &[alpha, beta, 0.0, -(kp + ki), 0.0, 1.0, -ki, 0.0, 1.0],
        );
        let mut want: Vec<f64> = m.complex_eigenvalues().iter().map(|e| e.norm()).collect();
        want.sort_by(|a, b| b.partial_cmp(a).expect("finite"));
        let got: Vec<f64> = cl
            .modes
            .iter()
            .map(|m| m.radius)
            .filter(|r| *r > 1e-12)
            .collect();
        assert_eq!(got.len(), 3, "{base}: {got:?}");
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() < 1e-9, "{base}: {got:?} vs {want:?}");
        }
    }
}

/// The matrices model the controller as it runs: simulate the reduced plant (exact
/// ZOH) with `F64Controller` (one tick of delay, limits out of reach) and with the
/// per-tick matrices of `closed_loop`: identical trajectories, for each yaw mode and
/// multi-rate divisors.
#[test]
fn loop_matrices_reproduce_the_real_controller() {
    for (mode, yd, td) in [
        (YawMode::Lead, 1, 1),
        (YawMode::Lead, 2, 3),
        (YawMode::Gain, 4, 1),
        (YawMode::Passive, 1, 2),
    ] {
        let mut cfg = Config {
            base_rate_hz: 10_000,
            yaw_divisor: yd,
            traction_divisor: td,
            yaw_mode: mode,
            ..Config::default()
        };
        cfg.limits.torque = 2.0e6;
        cfg.limits.current_ref_rate = 1e9;
        let p = Reduced {
            creep: 5e6,
            lambda: 0.2,
            yaw_spring: mode == YawMode::Passive,
        }
        .plant_with(&Params::default());
        let t0 = 1.0 / cfg.base_rate_hz as f64;
        let x0 = DMatrix::from_column_slice(5, 1, &[1e-3, 2e-3, -1e-3, 0.01, 5.0]);
        let real = simulate_controller(&p, &cfg, t0, &x0, 60);
        // Matrix model: the same steps, from X = [x0; 0...].
        let model = simulate_matrices(&p, &cfg, 1, &x0, 60);
        for (k, (r, m)) in real.iter().zip(&model).enumerate() {
            let err = (r - m).norm() / r.norm().max(1e-12);
            assert!(err < 1e-9, "{mode:?} {yd}/{td} tick {k}: {err:e}");
        }
    }
}

/// Helper for the test above: run the per-tick matrices of `closed_loop`'s
/// construction from plant state `x0` and return the plant states.
/// The real `F64Controller` ticking on the exactly discretised (ZOH) plant, its
/// output applied one tick later; the plant state after each tick. Deviations: current
/// and speed around the operating point, no demand.
fn simulate_controller(
    p: &LinearPlant,
    cfg: &Config,
    t0: f64,
    x0: &DMatrix<f64>,
    ticks: usize,
) -> Vec<DMatrix<f64>> {
    let (ad, bd) = zoh(&p.a, &p.b, t0);
    let mut c = F64Controller::try_new(cfg).expect("valid");
    let mut x = x0.clone();
    let mut applied = DMatrix::<f64>::zeros(2, 1);
    let mut real = Vec::new();
    for _ in 0..ticks {
        let y = &p.c * &x;
        let o = c.tick(&Inputs::from_si(&cfg.scales, y[0], y[1], 0.0, 0.0));
        let (t, u) = o.to_si(&cfg.scales);
        x = &ad * &x + &bd * &applied;
        applied = DMatrix::from_column_slice(2, 1, &[t, u]);
        real.push(x.clone());
    }
    real
}

fn simulate_matrices(
    p: &LinearPlant,
    cfg: &Config,
    d: usize,
    x0: &DMatrix<f64>,
    ticks: usize,
) -> Vec<DMatrix<f64>> {
    let n = p.a.nrows();
    let mats = tick_matrices(p, cfg, d).expect("valid");
    let nx = mats[0].nrows();
    let mut x = DMatrix::<f64>::zeros(nx, 1);
    x.view_mut((0, 0), (n, 1)).copy_from(x0);
    let mut out = Vec::new();
    for k in 0..ticks {
        x = &mats[k % mats.len()] * &x;
        out.push(x.view((0, 0), (n, 1)).into_owned());
    }
    out
}

/// The sign fact of docs/model.md on the reduced plant: `T_psi = +Ks y'` is stable at the
/// nominal point, the opposite sign unstable across the creep grid.
#[test]
fn opposite_active_sign_is_unstable() {
    let cfg = Config::default();
    let mut neg = cfg;
    neg.lead.k = -neg.lead.k;
    let plant = |c| {
        Reduced {
            creep: c,
            lambda: 0.2,
            yaw_spring: false,
        }
        .plant_with(&Params::default())
    };
    assert!(closed_loop(&plant(10e6), &cfg, 1).expect("valid").stable());
    for c in CREEP_GRID {
        assert!(
            !closed_loop(&plant(c), &neg, 1).expect("valid").stable(),
            "{c}"
        );
    }
}

/// The full linearisation (case d) too: the matrices reproduce the real controller.
#[test]
fn loop_matrices_reproduce_the_real_controller_on_the_full_plant() {
    let mut cfg = Config {
        yaw_predict_ticks: 1.5,
        ..Config::default()
    };
    cfg.limits.torque = 2.0e6;
    cfg.limits.current_ref_rate = 1e9;
    let p = Model::Full.plant(&Params::default(), 5e6, 0.2, false);
    let n = p.a.nrows();
    let mut x0 = DMatrix::<f64>::zeros(n, 1);
    x0[(1, 0)] = 2e-3; // y'
    x0[(3, 0)] = 0.01; // psi'
    let real = simulate_controller(&p, &cfg, 1.0 / cfg.base_rate_hz as f64, &x0, 200);
    let model = simulate_matrices(&p, &cfg, 1, &x0, 200);
    for (k, (r, m)) in real.iter().zip(&model).enumerate() {
        let err = (r - m).norm() / r.norm().max(1e-12);
        assert!(err < 1e-8, "tick {k}: {err:e}");
    }
}

/// `Config::default()`'s rates are what the analysis chooses (with the recommended
/// compensation); without it no candidate up to 10 kHz keeps every grid point the
/// continuous loop holds.
#[test]
fn default_rates_are_the_analysis_choice() {
    let p = Params::default();
    let base = Config::default();
    let r = rates(
        &p,
        Model::Full,
        &base,
        1,
        &LinkBudget::default(),
        &Criteria::default(),
    )
    .expect("valid");
    let on = r.variants.iter().find(|v| v.predict).expect("variant");
    let chosen = on.chosen.expect("a candidate qualifies");
    assert_eq!(
        (chosen.base_hz, chosen.yaw_divisor, chosen.traction_divisor),
        (base.base_rate_hz, base.yaw_divisor, base.traction_divisor)
    );
    assert!(chosen.max_damping_loss < 0.005, "{chosen:?}");
    let off = r.variants.iter().find(|v| !v.predict).expect("variant");
    assert!(off.chosen.is_none());
    // The continuous law itself fails below ~1.55 MN: the 1 MN row is lost.
    assert_eq!(chosen.unstable_continuous, CONICITY_GRID.len());
    let json = r.to_json();
    assert_eq!(json["variants"][1]["chosen"]["base_hz"], 5000);
    assert!(r.render().contains("chosen: base 5000 Hz, yaw divisor 1"));
}

#[test]
fn absurd_timings_are_refused() {
    let p = armature(4e-4, 0.04);
    let cfg = Config {
        yaw_divisor: 37,
        traction_divisor: 41,
        base_rate_hz: 100_000,
        ..Config::default()
    };
    cfg.validate().expect("a valid controller configuration");
    assert!(closed_loop(&p, &cfg, 1)
        .expect_err("hyper-period 1517")
        .contains("hyper-period"));
    assert!(closed_loop(&p, &Config::default(), 5000).is_err());
    let bad = LinearPlant {
        a: DMatrix::zeros(2, 2),
        b: DMatrix::zeros(2, 1),
        c: DMatrix::zeros(3, 2),
    };
    assert!(closed_loop(&bad, &Config::default(), 1)
        .expect_err("shape")
        .contains("plant shapes"));
}

#[test]
fn link_budget_arithmetic() {
    let l = LinkBudget::default();
    // The wire crate's worst-case one-lateral Sensor and Actuation frames.
    let (up, down) = (
        wheelset_proto::SENSOR_ONE_LATERAL_MAX_FRAME,
        wheelset_proto::ACTUATION_MAX_FRAME,
    );
    assert_eq!((l.bytes_in as usize, l.bytes_out as usize), (up, down));
    // 68 bytes = 680 bits at 2 Mbaud = 340 us, + 2 x 5 us, at 2 kHz (500 us) = 0.70.
    let bits = ((up + down) * 10) as f64;
    let u = (bits / 2e6 + 10e-6) * 2000.0;
    assert!((l.utilisation(2000.0, 2e6) - u).abs() < 1e-12);
    assert!((u - 0.70).abs() < 1e-12);
    // The smallest baud: 680 bits / (0.7 x 200 us - 10 us) = 5.231 Mbaud, rounded up.
    let b = l.min_baud(5000.0);
    assert_eq!(b, (bits / (0.7 * 200e-6 - 10e-6)).ceil());
    assert!(l.utilisation(5000.0, b) <= 0.7);
    assert!(l.utilisation(5000.0, b - 1.0) > 0.7);
}
