//! Linearisation and modal analysis: analytic vs complex-step Jacobians, the kinematic
//! frequency, controller signs, the sweep grid, crossings, the structural zero, JSON.

#![allow(clippy::unwrap_used)]

mod common;
use nalgebra::Complex;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use std::f64::consts::PI;
use wheelset_plant::control::closed_loop_rhs;
use wheelset_plant::control::{ContinuousController, Exogenous, YawLaw};
use wheelset_plant::linear::{
    closed_loop_a, closed_loop_jacobian, closed_loop_jacobian_central, linear_plant,
    plant_jacobian, InJac, Jac,
};
use wheelset_plant::modes::{creep_grid, eigenvalues, sweep_case, Case};
use wheelset_plant::params::Params;
use wheelset_plant::plant::{ix, Inputs, Plant, PlantConfig, State, NX, STATE_NAMES};
use wheelset_plant::scenario::Axle;

/// Step of the complex-step derivative (`df/dx_j = Im f(x + i h e_j) / h`, exact to
/// rounding): the oracle of the analytic Jacobians.
const COMPLEX_STEP: f64 = 1e-20;

/// Complex-step Jacobians of the plant RHS (same layout as `plant_jacobian`).
fn plant_jacobian_complex_step(plant: &Plant, x: &State, u: &Inputs<f64>) -> (Jac, InJac) {
    let lift = |v: f64| Complex::new(v, 0.0);
    let uc = Inputs {
        t_psi: lift(u.t_psi),
        u_a: lift(u.u_a),
        curvature: lift(u.curvature),
        cant: lift(u.cant),
        f_run: lift(u.f_run),
        t_drive: lift(u.t_drive),
    };
    let xc: [Complex<f64>; NX] = x.map(lift);
    let a = complex_step(x, |xp| plant.rhs(plant.cfg, xp, &uc).0);
    let mut b = InJac::zeros();
    for k in 0..2 {
        let mut up = uc;
        if k == 0 {
            up.t_psi.im = COMPLEX_STEP;
        } else {
            up.u_a.im = COMPLEX_STEP;
        }
        let (f, _) = plant.rhs(plant.cfg, &xc, &up);
        for i in 0..NX {
            b[(i, k)] = f[i].im / COMPLEX_STEP;
        }
    }
    (a, b)
}

/// `df/dx` of `f` at `x` by the complex step.
fn complex_step(x: &State, f: impl Fn(&[Complex<f64>; NX]) -> [Complex<f64>; NX]) -> Jac {
    let mut a = Jac::zeros();
    for j in 0..NX {
        let mut xp = x.map(|v| Complex::new(v, 0.0));
        xp[j].im = COMPLEX_STEP;
        let f = f(&xp);
        for i in 0..NX {
            a[(i, j)] = f[i].im / COMPLEX_STEP;
        }
    }
    a
}

/// Complex-step closed-loop Jacobian of `closed_loop_rhs`.
fn closed_loop_jacobian_complex_step(
    plant: &Plant,
    ctrl: &ContinuousController,
    x: &State,
    e: &Exogenous<f64>,
) -> Jac {
    let lift = |v: f64| Complex::new(v, 0.0);
    let ec = Exogenous {
        curvature: lift(e.curvature),
        cant: lift(e.cant),
        f_run: lift(e.f_run),
        i_ref: lift(e.i_ref),
        demand: lift(e.demand),
    };
    complex_step(x, |xp| closed_loop_rhs(plant, plant.cfg, ctrl, xp, &ec))
}

fn configs() -> Vec<PlantConfig> {
    let mut v = Vec::new();
    for axle in [Axle::Rigid, Axle::Flexible] {
        for drive in [false, true] {
            for yaw_spring in [false, true] {
                v.push(PlantConfig {
                    axle,
                    drive,
                    yaw_spring,
                });
            }
        }
    }
    v
}

fn random_state(rng: &mut Pcg64, p: &Params) -> [f64; NX] {
    let mut x = [0.0; NX];
    let mut r = |s: f64| s * (rng.random::<f64>() - 0.5);
    let v = p.v + r(5.0);
    x[ix::Y] = r(1e-2);
    x[ix::YD] = r(0.2);
    x[ix::PSI] = r(1e-2);
    x[ix::PSID] = r(0.2);
    x[ix::WR] = v / p.r0 + r(1.0);
    x[ix::WL] = v / p.r0 + r(1.0);
    x[ix::TWIST] = r(1e-3);
    x[ix::WIND] = r(1e-3);
    x[ix::WM] = p.n_gear * v / p.r0 + r(5.0);
    x[ix::IA] = r(300.0);
    x[ix::V] = v;
    x[ix::LEAD] = r(1e-3);
    x[ix::PI] = 3900.0 + r(200.0);
    x
}

/// The exogenous inputs of the Jacobian checks: a curve with cant, running resistance,
/// a current reference and a demand, so every input column is exercised.
fn exogenous() -> Exogenous<f64> {
    Exogenous {
        curvature: 1e-4,
        cant: 0.05,
        f_run: 3000.0,
        i_ref: 100.0,
        demand: 2000.0,
    }
}

fn assert_close(a: f64, b: f64, scale: f64, what: &str) {
    assert!(
        (a - b).abs() <= 1e-8 * scale.max(a.abs()).max(b.abs()),
        "{what}: analytic {a} vs complex-step {b}"
    );
}

#[test]
fn analytic_jacobians_match_complex_step_at_random_states() {
    let p = Params {
        k_lat: 2e5,
        ..Params::default()
    };
    let mut rng = Pcg64::seed_from_u64(11);
    for cfg in configs() {
        let plant = Plant::new(&p, cfg);
        for _ in 0..20 {
            let mut x = random_state(&mut rng, &p);
            if cfg.axle == Axle::Rigid {
                x[ix::WL] = x[ix::WR];
            }
            let u = Inputs {
                t_psi: 500.0,
                u_a: 3950.0,
                curvature: 4e-4 * rng.random::<f64>(),
                cant: 0.1,
                f_run: 5000.0,
                t_drive: 100.0,
            };
            let (a, b) = plant_jacobian(&plant, &p, &x, &u);
            let (ac, bc) = plant_jacobian_complex_step(&plant, &x, &u);
            let scale = a.amax();
            for i in 0..NX {
                for j in 0..NX {
                    assert_close(
                        a[(i, j)],
                        ac[(i, j)],
                        1e-6 * scale,
                        &format!("{cfg:?} A[{i},{j}]"),
                    );
                }
                for k in 0..2 {
                    assert_close(b[(i, k)], bc[(i, k)], 1e-12, &format!("{cfg:?} B[{i},{k}]"));
                }
            }
            for law in [YawLaw::Passive, YawLaw::Gain, YawLaw::Lead] {
                let ctrl = ContinuousController::new(&p, law);
                let e = exogenous();
                let a = closed_loop_jacobian(&plant, &p, &ctrl, &x, &e);
                let ac = closed_loop_jacobian_complex_step(&plant, &ctrl, &x, &e);
                let scale = a.amax();
                for i in 0..NX {
                    for j in 0..NX {
                        assert_close(
                            a[(i, j)],
                            ac[(i, j)],
                            1e-6 * scale,
                            &format!("{cfg:?} {law:?} Acl[{i},{j}]"),
                        );
                    }
                }
            }
        }
    }
}

/// The central-difference Jacobian (the one `examples/adh_modes.rs` uses with adhesion)
/// equals the analytic one on the linear creep law to 1e-6 relative (plus a rounding
/// floor of 1e-7 of the largest entry), at random states.
#[test]
fn central_difference_jacobian_matches_analytic_on_the_linear_law() {
    let p = Params::default();
    let mut rng = Pcg64::seed_from_u64(11);
    for cfg in configs() {
        let plant = Plant::new(&p, cfg);
        for _ in 0..5 {
            let x = random_state(&mut rng, &p);
            for law in [YawLaw::Passive, YawLaw::Gain, YawLaw::Lead] {
                let ctrl = ContinuousController::new(&p, law);
                let e = exogenous();
                let a = closed_loop_jacobian(&plant, &p, &ctrl, &x, &e);
                let ad = closed_loop_jacobian_central(&plant, &ctrl, &x, &e);
                // Rounding floor: the creepage `-1 + w r0/v` is formed at unit scale, so
                // each force carries ~f11 eps of rounding, divided by the step h_j >= 1e-8:
                // ~1e-3 absolute in the wheel rows, below 1e-7 of the largest entry.
                let floor = 1e-7 * a.amax();
                let mut nonzero = 0;
                for i in 0..NX {
                    for j in 0..NX {
                        let (u, w) = (a[(i, j)], ad[(i, j)]);
                        if u != 0.0 {
                            nonzero += 1;
                        }
                        assert!(
                            (u - w).abs() <= 1e-6 * u.abs() + floor,
                            "{cfg:?} {law:?} A[{i},{j}]: analytic {u} vs central {w} (max entry {})",
                            a.amax()
                        );
                    }
                }
                assert!(nonzero > 10, "{cfg:?} {law:?}: only {nonzero} entries");
            }
        }
    }
}

#[test]
fn linear_plant_has_the_documented_shape() {
    let p = Params::default();
    let cfg = PlantConfig {
        axle: Axle::Flexible,
        drive: true,
        yaw_spring: false,
    };
    let (m, states) = linear_plant(&p, cfg);
    assert_eq!(m.a.shape(), (11, 11));
    assert_eq!(m.b.shape(), (11, 2));
    assert_eq!(m.c.shape(), (3, 11));
    // B: T_psi enters the yaw acceleration as -1/J, u_a the current as 1/L_a.
    let psid = states.iter().position(|&s| s == ix::PSID).unwrap();
    let ia = states.iter().position(|&s| s == ix::IA).unwrap();
    assert!((m.b[(psid, 0)] + 1.0 / p.j).abs() < 1e-15);
    assert!((m.b[(ia, 1)] - 1.0 / p.l_a).abs() < 1e-9);
    assert_eq!(m.c.row(1).iter().filter(|v| **v == 1.0).count(), 1);
    assert_eq!(STATE_NAMES[states[ia]], "i_a_A");
}

/// The lateral eigenvalue nearest the kinematic one.
fn nearest(eig: &[Complex<f64>], w: f64) -> Complex<f64> {
    *eig.iter()
        .min_by(|a, b| {
            (**a - Complex::new(0.0, w))
                .norm()
                .total_cmp(&(**b - Complex::new(0.0, w)).norm())
        })
        .unwrap()
}

#[test]
fn free_rigid_wheelset_approaches_the_kinematic_frequency_at_high_creep() {
    let base = Params {
        k_yaw: 0.0,
        c_lat: 0.0,
        ..Params::default()
    };
    let fk = base.v * (base.lambda / (base.r0 * base.l_g)).sqrt() / (2.0 * PI);
    assert!((fk - base.kinematic_hz()).abs() < 1e-12);
    let mut errs = Vec::new();
    for creep in [1e7, 1e8, 1e9] {
        let p = Params {
            f11: creep,
            f22: creep,
            ..base.clone()
        };
        let (a, _) = closed_loop_a(
            &p,
            Axle::Rigid,
            false,
            &ContinuousController::new(&p, YawLaw::Passive),
        );
        let l = nearest(&eigenvalues(&a).unwrap(), 2.0 * PI * fk);
        errs.push((l.im.abs() / (2.0 * PI) - fk).abs() / fk);
    }
    assert!(errs[2] < 0.005, "{errs:?}");
    assert!(errs[2] < errs[0], "does not approach: {errs:?}");
}

fn max_re(case_law: (Axle, bool, YawLaw), p: &Params) -> f64 {
    let (a, _) = closed_loop_a(
        p,
        case_law.0,
        case_law.1,
        &ContinuousController::new(p, case_law.2),
    );
    eigenvalues(&a)
        .unwrap()
        .iter()
        .filter(|l| l.norm() > 1e-9) // the structural zero
        .map(|l| l.re)
        .fold(f64::NEG_INFINITY, f64::max)
}

#[test]
fn each_controller_sign_stabilises_and_the_reverse_destabilises() {
    let p = Params::default();
    // Correct signs: stable at 10 MN.
    for law in [YawLaw::Passive, YawLaw::Gain, YawLaw::Lead] {
        assert!(max_re((Axle::Rigid, false, law), &p) < 0.0, "{law:?}");
    }
    // Reversed active sign: unstable over the whole sweep.
    for creep in creep_grid(19) {
        let q = Params {
            f11: creep,
            f22: creep,
            k_active: -p.k_active,
            ..p.clone()
        };
        for law in [YawLaw::Gain, YawLaw::Lead] {
            let r = max_re((Axle::Rigid, false, law), &q);
            assert!(r > 0.0, "{law:?} reversed at {creep} N: max re {r}");
        }
    }
    // Reversed passive spring: unstable.
    let q = Params {
        k_yaw: -p.k_yaw,
        ..p.clone()
    };
    assert!(max_re((Axle::Rigid, false, YawLaw::Passive), &q) > 0.0);
}

#[test]
fn grid_contains_the_reference_points_exactly() {
    for n in [2, 10, 37, 1000, 1001] {
        let g = creep_grid(n);
        for c in [1e6, 2e6, 5e6, 1e7] {
            assert!(g.contains(&c), "n = {n} lacks {c}");
        }
        assert!(g.windows(2).all(|w| w[0] < w[1]));
        assert!(g.len() >= n);
    }
}

#[test]
fn pure_gain_loses_the_kinematic_mode_near_5_mn_and_bisection_is_tight() {
    let p = Params::default();
    let sw = sweep_case(&p, Case::B, &creep_grid(100), || {}).unwrap();
    let c = sw
        .crossings
        .iter()
        .find(|c| c.mode == "kinematic")
        .expect("kinematic crossing");
    assert!(c.unstable_below);
    assert!(c.creep_n > 4e6 && c.creep_n < 7e6, "{}", c.creep_n);
    // The bisection result separates stable from unstable within 0.01 %.
    for (f, stable) in [(c.creep_n * 0.9999, false), (c.creep_n * 1.0001, true)] {
        let q = Params {
            f11: f,
            f22: f,
            ..p.clone()
        };
        let r = max_re((Axle::Rigid, false, YawLaw::Gain), &q);
        assert_eq!(r < 0.0, stable, "at {f} N max re {r}");
    }
    // The high-frequency mode is over-damped (real) in the pure-gain case.
    let k = sw.index_of(1e7).unwrap();
    let hf = sw
        .modes_at(k)
        .into_iter()
        .find(|m| m.name == "high-frequency")
        .unwrap();
    assert_eq!(hf.im, 0.0);
}

#[test]
fn structural_zero_is_reported_and_excluded_in_every_case() {
    let p = Params::default();
    for case in Case::ALL {
        let sw = sweep_case(&p, case, &creep_grid(10), || {}).unwrap();
        for k in 0..sw.creep.len() {
            let z = sw.structural_zero(k).expect("structural zero identified");
            assert!(z.norm() < 1e-9, "case {}: {z}", case.id());
            assert!(sw
                .modes_at(k)
                .iter()
                .all(|m| !m.name.contains("structural")));
        }
        let names = sw.mode_names();
        assert!(names.contains(&"kinematic".to_string()), "{names:?}");
        assert!(names.contains(&"high-frequency".to_string()), "{names:?}");
        if case == Case::D {
            for n in ["torsional", "gear", "current loop"] {
                assert!(names.contains(&n.to_string()), "{names:?}");
            }
        }
    }
}

#[test]
fn modes_cli_writes_the_json_interface() {
    let dir = std::env::temp_dir().join(format!("sim-host-modes-{}", std::process::id()));
    let json = dir.join("sub/modes.json");
    let plots = dir.join("plots");
    let args = ["modes", "--points", "20", "--plot", plots.to_str().unwrap()];
    let v = common::run_json(&args, &json);
    let cases = v["cases"].as_array().unwrap();
    assert_eq!(cases.len(), 4);
    for (c, id) in cases.iter().zip(["a", "b", "c", "d"]) {
        assert_eq!(c["id"], id);
        assert!(c["label"].is_string());
        let pts = c["points"].as_array().unwrap();
        for creep in [1e6, 2e6, 5e6, 1e7] {
            let pt = pts
                .iter()
                .find(|p| p["creep_n"].as_f64() == Some(creep))
                .unwrap();
            let eig = pt["eigenvalues"].as_array().unwrap();
            assert_eq!(eig[0].as_array().unwrap().len(), 2);
            let m = &pt["modes"][0];
            for key in ["name", "re", "im", "freq_hz", "zeta"] {
                assert!(!m[key].is_null(), "{key}");
            }
        }
        for x in c["crossings"].as_array().unwrap() {
            for key in ["creep_n", "freq_hz", "mode", "unstable_below"] {
                assert!(!x[key].is_null(), "{key}");
            }
        }
        assert!(dir.join(format!("plots/modes_case_{id}.svg")).exists());
    }
    let _ = std::fs::remove_dir_all(&dir);
}
