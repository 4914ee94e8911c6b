//! Plant tests: equilibrium, every corrected equation term against its derivation from
//! the creep forces, controller signs, the pure rolling line, the step timing.

#![allow(clippy::unwrap_used)]

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use wheelset_plant::control::{ContinuousController, YawLaw};
use wheelset_plant::params::Params;
use wheelset_plant::plant::{ix, Inputs, Plant, PlantConfig, NX};
use wheelset_plant::scenario::{Axle, Scenario};
use wheelset_plant::sim::{run_continuous, run_continuous_each};

fn full(spring: bool) -> PlantConfig {
    PlantConfig {
        axle: Axle::Flexible,
        drive: true,
        yaw_spring: spring,
    }
}

#[test]
fn pure_rolling_on_straight_track_is_an_equilibrium_with_zero_creep() {
    let p = Params::default();
    for cfg in [
        full(true),
        full(false),
        PlantConfig {
            axle: Axle::Rigid,
            drive: false,
            yaw_spring: true,
        },
    ] {
        let plant = Plant::new(&p, cfg);
        let x = plant.rolling_state(p.v);
        let u = Inputs {
            u_a: plant.back_emf(&x),
            ..Inputs::default()
        };
        let (dx, cr) = plant.rhs(plant.cfg, &x, &u);
        assert!(cr.fx_r.abs() < 1e-6 && cr.fx_l.abs() < 1e-6 && cr.fy.abs() < 1e-6);
        for (i, d) in dx.iter().enumerate() {
            assert!(d.abs() < 1e-9, "{cfg:?}: state {i} derivative {d}");
        }
    }
}

#[test]
fn pi_integrator_preset_at_back_emf_keeps_the_current_at_zero() {
    let src = "duration_s = 3.0\n[[track]]\nt_s = 0.0\n";
    let sc = Scenario::from_toml_str(src, "straight.toml", &Params::default()).unwrap();
    let tr = run_continuous(&sc, YawLaw::Lead);
    let max_i = tr.records.iter().map(|r| r.i_a_a.abs()).fold(0.0, f64::max);
    let max_y = tr.records.iter().map(|r| r.y_m.abs()).fold(0.0, f64::max);
    assert!(max_i < 1e-9, "current drifted to {max_i} A");
    assert!(max_y < 1e-12, "y drifted to {max_y} m");
    let u0 = tr.records[0].u_a_v;
    assert!(
        (u0 - 3961.4).abs() < 1.0,
        "u_a(0) = {u0} V, expected the back-EMF"
    );
}

/// Random states around pure rolling with everything non-zero.
fn random_state(rng: &mut Pcg64, p: &Params) -> [f64; NX] {
    let mut x = [0.0; NX];
    let v = p.v * (1.0 + 0.05 * (rng.random::<f64>() - 0.5));
    x[ix::Y] = 5e-3 * (rng.random::<f64>() - 0.5);
    x[ix::YD] = 0.1 * (rng.random::<f64>() - 0.5);
    x[ix::PSI] = 5e-3 * (rng.random::<f64>() - 0.5);
    x[ix::PSID] = 0.1 * (rng.random::<f64>() - 0.5);
    x[ix::WR] = v / p.r0 * (1.0 + 1e-3 * (rng.random::<f64>() - 0.5));
    x[ix::WL] = v / p.r0 * (1.0 + 1e-3 * (rng.random::<f64>() - 0.5));
    x[ix::TWIST] = 1e-3 * (rng.random::<f64>() - 0.5);
    x[ix::WIND] = 1e-3 * (rng.random::<f64>() - 0.5);
    x[ix::WM] = p.n_gear * v / p.r0 * (1.0 + 1e-3 * (rng.random::<f64>() - 0.5));
    x[ix::IA] = 200.0 * (rng.random::<f64>() - 0.5);
    x[ix::V] = v;
    x
}

fn close(a: f64, b: f64, what: &str) {
    let tol = 1e-9 * (a.abs().max(b.abs())).max(1e-6);
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b}");
}

#[test]
fn every_corrected_term_matches_its_derivation_from_the_creep_forces() {
    // k_lat non-zero to exercise the lateral stiffness term too.
    let p = Params {
        k_lat: 3e5,
        ..Params::default()
    };
    let mut rng = Pcg64::seed_from_u64(7);
    for _ in 0..200 {
        let x = random_state(&mut rng, &p);
        let u = Inputs {
            t_psi: 2e3 * (rng.random::<f64>() - 0.5),
            u_a: 4000.0 + 100.0 * (rng.random::<f64>() - 0.5),
            curvature: 1e-3 * (rng.random::<f64>() - 0.5),
            cant: 0.1 * (rng.random::<f64>() - 0.5),
            f_run: 6e3 * rng.random::<f64>(),
            t_drive: 0.0,
        };
        let plant = Plant::new(&p, full(true));
        let (dx, cr) = plant.rhs(plant.cfg, &x, &u);
        let (f11, f22, lg, r0, lam) = (p.f11, p.f22, p.l_g, p.r0, p.lambda);
        let (y, yd, psi, psid) = (x[ix::Y], x[ix::YD], x[ix::PSI], x[ix::PSID]);
        let (wr, wl, tw, wind, wm, ia, v) = (
            x[ix::WR],
            x[ix::WL],
            x[ix::TWIST],
            x[ix::WIND],
            x[ix::WM],
            x[ix::IA],
            x[ix::V],
        );
        let k = u.curvature;
        let t_total = p.k_yaw * psi + u.t_psi;

        // Creep laws (1)-(3) as printed.
        let fxr = f11 * (-1.0 + lg * psid / v + wr * (r0 + lam * y) / v - lg * k);
        let fxl = -f11 * (1.0 + lg * psid / v - wl * (r0 - lam * y) / v - lg * k);
        let fy = -f22 * (yd - v * psi) / v;
        close(cr.fx_r, fxr, "F_xR (1)");
        close(cr.fx_l, fxl, "F_xL (2)");
        close(cr.fy, fy, "F_y (3)");

        // Newton from the creep forces.
        close(
            p.j * dx[ix::PSID],
            -lg * (fxr - fxl) - t_total,
            "yaw moment",
        );
        close(
            p.i_w * dx[ix::WR],
            -r0 * fxr - p.k_t() * tw,
            "right wheel torque",
        );
        close(
            p.i_w * dx[ix::WL],
            -r0 * fxl + p.k_t() * tw - p.k_gear() * wind,
            "left wheel torque",
        );
        close(
            (p.m + p.m_v / 2.0) * dx[ix::V],
            fxr + fxl - u.f_run,
            "longitudinal force",
        );

        // The corrected equations (4)-(10) of docs/model.md, expanded as printed there.
        let lhs4 = p.m * dx[ix::YD] + (2.0 * f22 / v + p.c_lat) * yd + p.k_lat * y
            - 2.0 * f22 * psi
            - p.m * v * v * k;
        close(lhs4, -p.m * p.g * u.cant, "(4)");
        let lhs5 = p.j * dx[ix::PSID]
            + 2.0 * f11 * lg * lg * psid / v
            + lg * f11 * lam * y * (wr + wl) / v
            + lg * f11 * r0 * (wr - wl) / v
            - 2.0 * f11 * lg * lg * k;
        close(lhs5, -t_total, "(5)");
        let lhs6 = p.i_w * dx[ix::WR]
            + f11 * r0 * r0 * wr / v
            + p.k_t() * tw
            + r0 * f11 * lg * psid / v
            + r0 * f11 * lam * y * wr / v;
        close(lhs6, r0 * f11 * (1.0 + lg * k), "(6)");
        let lhs7 = p.i_w * dx[ix::WL] + f11 * r0 * r0 * wl / v - p.k_t() * tw + p.k_gear() * wind
            - r0 * f11 * lg * psid / v
            - r0 * f11 * lam * y * wl / v;
        close(lhs7, r0 * f11 * (1.0 - lg * k), "(7)");
        let lhs8 =
            (p.m + p.m_v / 2.0) * dx[ix::V] - f11 / v * (lam * y * (wr - wl) + r0 * (wr + wl));
        close(lhs8, -2.0 * f11 - u.f_run, "(8)");
        close(p.l_a * dx[ix::IA] + p.r_a * ia + p.k_m * wm, u.u_a, "(9)");
        // (10): n I_m theta_m'' + k_gear theta_m/n = n K_m i_a + k_gear phi_L, i.e.
        // n I_m theta_m'' = n K_m i_a + k_gear (phi_L - theta_m/n).
        close(
            p.n_gear * p.i_m * dx[ix::WM],
            p.n_gear * p.k_m * ia + p.k_gear() * wind,
            "(10)",
        );
        close(dx[ix::TWIST], wr - wl, "twist rate");
        close(dx[ix::WIND], wl - wm / p.n_gear, "wind-up rate");
    }
}

#[test]
fn rigid_axle_sums_the_wheel_equations() {
    let p = Params::default();
    let mut rng = Pcg64::seed_from_u64(3);
    let plant = Plant::new(
        &p,
        PlantConfig {
            axle: Axle::Rigid,
            drive: false,
            yaw_spring: false,
        },
    );
    for _ in 0..50 {
        let mut x = random_state(&mut rng, &p);
        x[ix::WL] = x[ix::WR];
        let u = Inputs {
            t_drive: 1000.0,
            ..Inputs::default()
        };
        let (dx, cr) = plant.rhs(plant.cfg, &x, &u);
        close(
            2.0 * p.i_w * dx[ix::WR],
            -p.r0 * (cr.fx_r + cr.fx_l) + 1000.0,
            "rigid axle",
        );
        assert_eq!(dx[ix::WR], dx[ix::WL]);
    }
}

fn no_traction_curve() -> Scenario {
    let mut src = wheelset_plant::scenario::BUILTIN[0].1.to_string();
    // drop the traction and resistance tables
    if let Some(i) = src.find("[traction]") {
        src.truncate(i);
    }
    Scenario::from_toml_str(&src, "curve-no-traction", &Params::default()).unwrap()
}

#[test]
fn active_run_sits_on_the_pure_rolling_line_and_passive_does_not() {
    let sc = no_traction_curve();
    let y0 = sc.params.pure_rolling_y(1.0 / 2300.0);
    for law in [YawLaw::Lead, YawLaw::Gain, YawLaw::Passive] {
        let tr = run_continuous(&sc, law);
        let r = tr.at(11.9).unwrap();
        assert!((r.curvature_1pm - 1.0 / 2300.0).abs() < 1e-12);
        let rel = (r.y_m - y0).abs() / y0;
        if law == YawLaw::Passive {
            assert!(rel > 0.05, "passive unexpectedly on the line: {rel}");
            // The spring carries a real torque on the curve.
            assert!(r.t_psi_nm.abs() > 100.0, "{}", r.t_psi_nm);
        } else {
            assert!(rel < 1e-3, "{law:?}: y = {} vs y0 = {y0} ({rel})", r.y_m);
            assert!(r.t_psi_nm.abs() < 5.0, "{law:?}: T = {}", r.t_psi_nm);
        }
    }
}

#[test]
fn reversed_active_sign_diverges_and_correct_sign_does_not() {
    let sc = no_traction_curve();
    let p = &sc.params;
    for law in [YawLaw::Gain, YawLaw::Lead] {
        let good = ContinuousController::new(p, law);
        let mut bad = good;
        bad.k = -good.k;
        let max_y = |c| {
            let mut max = 0.0f64;
            run_continuous_each(&sc, c, |r| {
                max = max.max(if r.y_m.is_finite() {
                    r.y_m.abs()
                } else {
                    f64::INFINITY
                })
            });
            max
        };
        let (g, b) = (max_y(good), max_y(bad));
        assert!(g < 2e-3, "{law:?} stable run max |y| = {g}");
        assert!(
            b > 10.0 * g,
            "{law:?} reversed sign did not diverge: {b} vs {g}"
        );
    }
}

#[test]
fn traction_step_lands_exactly_at_5_s() {
    let sc = Scenario::load("curve", &Params::default()).unwrap();
    let tr = run_continuous(&sc, YawLaw::Lead);
    let before = tr
        .records
        .iter()
        .find(|r| (r.t_s - 4.999).abs() < 1e-9)
        .unwrap();
    let at = tr
        .records
        .iter()
        .find(|r| (r.t_s - 5.0).abs() < 1e-12)
        .unwrap();
    assert_eq!(before.demand_nm, 0.0);
    assert!(before.i_a_a.abs() < 0.05, "{}", before.i_a_a);
    assert!((at.demand_nm - 2460.0).abs() < 1e-9);
    assert!((at.f_run_n - 5470.0).abs() < 1e-9);
    // The current has not moved yet at exactly 5 s, but it has 1 ms later.
    assert!((at.i_a_a - before.i_a_a).abs() < 0.05, "{}", at.i_a_a);
    let after = tr
        .records
        .iter()
        .find(|r| (r.t_s - 5.001).abs() < 1e-9)
        .unwrap();
    assert!(after.i_a_a > 10.0, "{}", after.i_a_a);
    // And the current settles on i_ref = 2460 / (5 * 4.28) = 114.95 A.
    let end = tr.records.last().unwrap();
    assert!(
        (end.i_a_a - 2460.0 / (5.0 * 4.28)).abs() < 0.1,
        "{}",
        end.i_a_a
    );
    // Speed stays nearly constant (traction balances F_run).
    assert!((end.v_mps - 83.3).abs() < 0.05, "{}", end.v_mps);
}
