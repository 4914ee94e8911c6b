//! Adhesion-limited traction, plant side: Polach's law reduces to the linear law (no `[[adhesion]]`:
//! bit-identical; huge `mu0`: within a tight tolerance), the scenario sections, the
//! `low-adhesion` scenario (an unprotected wheel runs away), and `sim-host adhesion`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

mod common;
use std::process::Command;
use wheelset_plant::adhesion::{Adhesion, Condition, Polach};
use wheelset_plant::control::{closed_loop_rhs, ContinuousController, Exogenous, YawLaw};
use wheelset_plant::params::Params;
use wheelset_plant::plant::{ix, Plant, PlantConfig};
use wheelset_plant::scenario::{track_at, Axle, Scenario};
use wheelset_plant::sim::{rk4_step, run_continuous};

fn curve() -> Scenario {
    Scenario::load("curve", &Params::default()).unwrap()
}

/// The curve run with the continuous lead controller, and the same run integrated here
/// with the plant's law set to `law` (same RK4, same inputs sampled at step starts).
fn run_with(sc: &Scenario, law: Option<Adhesion>, t_end_s: f64) -> Vec<[f64; 13]> {
    let cfg = PlantConfig {
        axle: sc.axle,
        drive: sc.drive,
        yaw_spring: false,
    };
    let mut plant = Plant::new(&sc.params, cfg);
    plant.adhesion = law;
    let ctrl = ContinuousController::new(&sc.params, YawLaw::Lead);
    let mut x = plant.rolling_state(sc.params.v);
    x[ix::PI] = plant.back_emf(&x);
    let h = sc.dt_ns as f64 * 1e-9;
    let n = (t_end_s / h).round() as u64;
    let mut out = Vec::new();
    for k in 0..n {
        let t = k * sc.dt_ns;
        if k % 10 == 0 {
            out.push(x); // the state at t, as the run's 1 ms records
        }
        let demand = sc.traction.at(t);
        let f_run = sc.resistance.at(t);
        let i_ref = demand / (sc.params.n_gear * sc.params.k_m);
        let tr = [t, t + sc.dt_ns / 2, t + sc.dt_ns].map(|tt| track_at(&sc.track, tt, &mut 0));
        x = rk4_step(&x, h, |stage, xs| {
            let j = match stage {
                0 => 0,
                3 => 2,
                _ => 1,
            };
            let e = Exogenous {
                curvature: tr[j].0,
                cant: tr[j].1,
                f_run,
                i_ref,
                demand,
            };
            closed_loop_rhs(&plant, plant.cfg, &ctrl, xs, &e)
        });
    }
    out
}

#[test]
fn without_adhesion_sections_the_run_is_the_linear_law_bit_for_bit() {
    let sc = curve();
    assert!(sc.adhesion.is_empty());
    assert_eq!(sc.condition_at(5_000_000_000), None);
    // The library run (per-step adhesion hook) against this file's integration with the
    // plant's law explicitly off: every state bit-identical.
    let tr = run_continuous(&sc, YawLaw::Lead);
    let here = run_with(&sc, None, 8.0);
    for (i, x) in here.iter().enumerate() {
        let r = &tr.records[i];
        assert_eq!(r.y_m.to_bits(), x[ix::Y].to_bits(), "y at record {i}");
        assert_eq!(r.v_mps.to_bits(), x[ix::V].to_bits(), "v at record {i}");
        assert_eq!(r.i_a_a.to_bits(), x[ix::IA].to_bits(), "i_a at record {i}");
        assert_eq!(r.mu_avail, f64::INFINITY);
    }
}

#[test]
fn a_huge_mu0_is_the_linear_law_within_a_tight_tolerance() {
    let sc = curve();
    let huge = Adhesion {
        q: sc.params.q(),
        condition: Condition::Dry,
        law: Polach {
            mu0: 1e6,
            ..Condition::Dry.polach()
        },
    };
    let lin = run_with(&sc, None, 8.0);
    let big = run_with(&sc, Some(huge), 8.0);
    let mut worst = [0.0f64; 3];
    for (a, b) in lin.iter().zip(&big) {
        for (w, i) in worst.iter_mut().zip([ix::Y, ix::PSI, ix::IA]) {
            *w = w.max((a[i] - b[i]).abs());
        }
    }
    // y ~ 0.7 mm, psi ~ 0.1 mrad, i_a ~ 115 A on this run: errors 1e-9 relative or less.
    assert!(worst[0] < 1e-12, "y differs by {} m", worst[0]);
    assert!(worst[1] < 1e-12, "psi differs by {} rad", worst[1]);
    assert!(worst[2] < 1e-6, "i_a differs by {} A", worst[2]);
    // And a realistic law does change the run (the test can fail).
    let dry = run_with(&sc, Some(Adhesion::new(Condition::Dry, sc.params.q())), 8.0);
    let d = lin
        .iter()
        .zip(&dry)
        .map(|(a, b)| (a[ix::Y] - b[ix::Y]).abs())
        .fold(0.0, f64::max);
    assert!(d > 1e-7, "dry rail left y unchanged ({d} m)");
}

#[test]
fn sections_are_validated_with_the_key_named() {
    let base = "duration_s = 10.0\n";
    let cases = [
        (
            "[[adhesion]]\nstart_s = 1.0\nend_s = 1.0\ncondition = \"wet\"\n",
            "adhesion[0].end_s",
        ),
        (
            "[[adhesion]]\nstart_s = 1.0\nend_s = 3.0\ncondition = \"ice\"\n",
            "adhesion[0].condition",
        ),
        (
            "[[adhesion]]\nstart_s = 1.0\nend_s = 3.0\ncondition = \"wet\"\n[[adhesion]]\nstart_s = 2.0\nend_s = 4.0\ncondition = \"low\"\n",
            "adhesion[1].start_s",
        ),
        (
            "[[adhesion]]\nstart_s = -1.0\nend_s = 3.0\ncondition = \"wet\"\n",
            "adhesion[0].start_s",
        ),
        (
            "[[adhesion]]\nstart_s = 1.0\nend_s = 3.0\ncondition = \"wet\"\nmu = 0.1\n",
            "mu",
        ),
    ];
    for (extra, key) in cases {
        let src = format!("{base}{extra}");
        let err = Scenario::from_toml_str(&src, "x.toml", &Params::default()).unwrap_err();
        assert!(err.to_string().contains(key), "{extra}: {err}");
    }
    let ok = "[[adhesion]]\nstart_s = 1.0\nend_s = 3.0\ncondition = \"wet\"\n";
    let sc = Scenario::from_toml_str(&format!("{base}{ok}"), "x.toml", &Params::default()).unwrap();
    assert_eq!(sc.condition_at(0), Some(Condition::Dry));
    assert_eq!(sc.condition_at(1_000_000_000), Some(Condition::Wet));
    assert_eq!(sc.condition_at(3_000_000_000), Some(Condition::Dry));
}

#[test]
fn low_adhesion_scenario_needs_a_quarter_of_adhesion_and_runs_away_unprotected() {
    let sc = Scenario::load("low-adhesion", &Params::default()).unwrap();
    assert_eq!(sc.axle, Axle::Flexible);
    // The curve track.
    assert_eq!(sc.track, curve().track);
    // Demand ramped (not a step) to about 0.25 of the axle's adhesion 2 Q.
    assert!(sc.traction.ramp_ns > 0);
    let need = sc.traction.value / sc.params.r0 / (2.0 * sc.params.q());
    assert!((need - 0.25).abs() < 0.01, "needs {need}");
    let conds: Vec<Condition> = sc.adhesion.iter().map(|s| s.condition).collect();
    assert!(conds.contains(&Condition::Low) && conds.contains(&Condition::Wet));
    for s in &sc.adhesion {
        if s.condition != Condition::Dry {
            assert!(
                s.t1_ns - s.t0_ns >= 3_000_000_000,
                "section {s:?} too short"
            );
        }
    }
    // The continuous controllers have no wheel-slip protection: the wheel runs away in
    // the low section.
    let tr = run_continuous(&sc, YawLaw::Lead);
    let sum = wheelset_plant::traction::summary(&sc, &tr).unwrap();
    assert!(sum.runaway, "{sum:?}");
    let low = sum
        .sections
        .iter()
        .find(|s| s.condition == Condition::Low)
        .unwrap();
    assert!(low.slip_peak_mps > wheelset_plant::traction::RUNAWAY_SLIP_MPS);
    // Before the low section the dry rail carries the demand at a small slip.
    let dry = &sum.sections[0];
    assert!(dry.slip_peak_mps < 0.5, "{dry:?}");
    let at6 = tr.at(5.9).unwrap();
    assert!((at6.mu_used - 0.25).abs() < 0.02, "mu_used {}", at6.mu_used);
    assert!(at6.mu_avail > 0.3);
}

#[test]
fn adhesion_command_writes_the_characteristic_fields() {
    let dir = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("adhesion");
    let json = dir.join("wet.json");
    let plots = dir.to_str().unwrap();
    let args = [
        "adhesion",
        "--condition",
        "wet",
        "--v-mps",
        "50",
        "--plot",
        plots,
    ];
    let v = common::run_json(&args, &json);
    for key in [
        "condition",
        "v_mps",
        "q_n",
        "f11_n",
        "mu0",
        "a",
        "b",
        "ka",
        "ks",
        "creepage",
        "force_over_q",
    ] {
        assert!(v.get(key).is_some(), "missing {key}");
    }
    assert_eq!(v["condition"], "wet");
    assert_eq!(v["v_mps"], 50.0);
    let s = v["creepage"].as_array().unwrap();
    let f = v["force_over_q"].as_array().unwrap();
    assert!(s.len() >= 200 && s.len() == f.len());
    assert_eq!(s[0], 0.0);
    assert!((s[s.len() - 1].as_f64().unwrap() - 0.2).abs() < 1e-12);
    // Rises with the paper's slope, peaks, falls: the peak is interior.
    let fs: Vec<f64> = f.iter().map(|x| x.as_f64().unwrap()).collect();
    let imax = (0..fs.len())
        .max_by(|&a, &b| fs[a].total_cmp(&fs[b]))
        .unwrap();
    assert!(imax > 0 && imax < fs.len() - 1);
    assert!(fs[fs.len() - 1] < fs[imax]);
    assert!(dir.join("adhesion-wet.svg").exists());
    // Bad input: exit 2 with the flag named.
    let bad = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(["adhesion", "--condition", "wet", "--v-mps=-3", "--json"])
        .arg(&json)
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--v-mps"));
    let bad = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(["adhesion", "--condition", "ice", "--json"])
        .arg(&json)
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
}

#[test]
fn the_core_with_protection_holds_the_wheel_and_without_it_runs_away() {
    use wheelset_loop::core::run_core;
    let sc = Scenario::load("low-adhesion", &Params::default()).unwrap();
    let (on, c_on) = run_core::<f64>(&sc, YawLaw::Lead, true).unwrap();
    let (off, c_off) = run_core::<f64>(&sc, YawLaw::Lead, false).unwrap();
    let s_on = wheelset_plant::traction::summary(&sc, &on).unwrap();
    let s_off = wheelset_plant::traction::summary(&sc, &off).unwrap();
    // Protected: no runaway, the slip bounded, every low or wet section used at 0.8 of
    // its peak or more, the yaw loop stable (the run ends, |y| stays at the curve's
    // millimetres, the yaw torque below its limit), the protection acted and released
    // (the last dry section carries the full demand again).
    assert!(!s_on.runaway, "{s_on:?}");
    assert!(on.info.diverged_at_s.is_none());
    let bound = slip_bound(&sc);
    assert!(
        s_on.slip_peak_mps < bound.total,
        "slip peak {} m/s against the bound {bound:?}",
        s_on.slip_peak_mps
    );
    // The regulated slip means something: its set point at the full reference is below
    // the low rail's peak slip (0.60 m/s), so a regulated wheel works on the rising side;
    // the transient's terms are each a worst case (measured peak 0.454 m/s, in the wet
    // section's regulation, 0.423 m/s in the first transient).
    assert!(bound.set_point_max < bound.low_peak_slip, "{bound:?}");
    assert!(s_on.slip_peak_mps > 0.6 * bound.total, "{bound:?}");
    for s in &s_on.sections {
        if matches!(s.condition, Condition::Low | Condition::Wet) {
            assert!(s.utilisation >= 0.8, "{s:?}");
        }
    }
    let max_y = on.records.iter().map(|r| r.y_m.abs()).fold(0.0, f64::max);
    assert!(max_y < 2.5e-3, "max |y| {max_y} m");
    let max_t = on
        .records
        .iter()
        .map(|r| r.t_psi_nm.abs())
        .fold(0.0, f64::max);
    assert!(
        max_t < 15e3,
        "max |T_psi| {max_t} N m: below the 20 kN m limit"
    );
    assert!(c_on.wsp_events >= 2 && c_on.wsp_ticks > 0, "{c_on:?}");
    let last = s_on.sections.last().unwrap();
    assert_eq!(last.condition, Condition::Dry);
    let end = on.records.last().unwrap();
    assert!(
        (end.mu_used - 0.25).abs() < 0.01,
        "released: mu_used {}",
        end.mu_used
    );
    for s in &s_on.sections {
        assert!(s.mu_used_mean.is_finite() && s.mu_used_mean > 0.0, "{s:?}");
    }
    // Unprotected: the runaway, and the same track no longer carries the yaw loop.
    assert!(s_off.runaway, "{s_off:?}");
    assert_eq!(c_off.wsp_events, 0);
    assert!(s_off.slip_peak_mps > 10.0 * s_on.slip_peak_mps);
    // The regulator's set point is recorded while the protection acts, and the regulated
    // slip holds it (the low section's regulation, 7-10 s, within 5 %).
    assert!(c_off.set_point.is_empty());
    let held: Vec<(f64, f64)> = c_on
        .set_point
        .iter()
        .filter(|p| (7.0..10.0).contains(&p.0))
        .map(|&(t, sp)| {
            let r = on
                .records
                .iter()
                .min_by(|a, b| (a.t_s - t).abs().total_cmp(&(b.t_s - t).abs()))
                .unwrap();
            (sp, r.slip_mps)
        })
        .collect();
    assert!(held.len() > 1000, "{}", held.len());
    for (sp, slip) in &held {
        assert!((slip / sp - 1.0).abs() < 0.05, "slip {slip} set point {sp}");
    }
    // The figure gives each run's slip its own panel and scale: the protected one with
    // its set point and the detection threshold, the runaway with its threshold.
    // (Drawn by the command, which runs both cores again and writes `adhesion.svg`.)
    let dir = std::env::temp_dir().join(format!("sim-host-adh-fig-{}", std::process::id()));
    let st = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(["run", "--scenario", "low-adhesion", "--control", "lead"])
        .args(["--loop", "core", "--wsp", "on", "--plot"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(
        st.status.success(),
        "{}",
        String::from_utf8_lossy(&st.stderr)
    );
    let fig = dir.join("adhesion.svg");
    let svg = std::fs::read_to_string(&fig).unwrap();
    for want in [
        ">Slip velocity, protection on</text>",
        ">Slip velocity, protection off</text>",
        ">regulator's set point</text>",
        ">detection: slip above 0.25 m/s</text>",
        ">runaway: above 3 m/s for 1 s</text>",
    ] {
        assert!(svg.contains(want), "{want}");
    }
    // Laid out without a label over another or off the canvas.
    let problems = wheelset_report::svg::lint::problems(&svg);
    assert!(problems.is_empty(), "{problems:#?}");
    let _ = std::fs::remove_dir_all(&dir);
    // The production type takes the same course.
    let (fx, c_fx) = run_core::<wheelset_control::Fx>(&sc, YawLaw::Lead, true).unwrap();
    let s_fx = wheelset_plant::traction::summary(&sc, &fx).unwrap();
    assert!(!s_fx.runaway && fx.info.diverged_at_s.is_none());
    assert_eq!(c_fx.wsp_events, c_on.wsp_events);
}

/// Records the measurements a sampled controller receives (one per control period).
struct Recorder<C> {
    inner: C,
    seen: Vec<wheelset_plant::control::Measurements>,
}

impl<C: wheelset_plant::control::SampledController> wheelset_plant::control::SampledController
    for Recorder<C>
{
    fn period_ns(&self) -> u64 {
        self.inner.period_ns()
    }
    fn step(
        &mut self,
        t_ns: u64,
        m: &wheelset_plant::control::Measurements,
    ) -> wheelset_plant::control::Actuation {
        self.seen.push(*m);
        self.inner.step(t_ns, m)
    }
}

#[test]
fn every_build_takes_the_same_decisions_on_the_same_codes() {
    // The wire codes the f64 core received on `low-adhesion` with protection, replayed
    // through the Q4.28, f32 and f64 cores (open loop: every build gets the same codes).
    // Q4.28 and f64 detect on the same ticks, and switch the lead and release on the
    // same ticks while their caps agree (`firmware/control/src/wsp.rs`, "Exact
    // decisions").
    use wheelset_control::{Fx, Sample};
    use wheelset_loop::core::CoreController;
    use wheelset_plant::control::SampledController;
    use wheelset_plant::sim::{run_sampled, ActuatorModel, SensorModel};
    let sc = Scenario::load("low-adhesion", &Params::default()).unwrap();
    let cfg = wheelset_loop::device_loop::control_config(&sc.params, YawLaw::Lead, sc.drive);
    let inner = CoreController::<f64>::try_new(&cfg, true).unwrap();
    let period = inner.period_ns();
    let mut rec = Recorder {
        inner,
        seen: Vec::new(),
    };
    let mut act = ActuatorModel::ideal();
    act.delay_ns = period;
    let tr = run_sampled(
        &sc,
        &mut rec,
        &mut SensorModel::ideal(),
        &mut act,
        YawLaw::Lead.has_spring(),
        "record",
    )
    .unwrap();
    assert!(tr.info.diverged_at_s.is_none());
    let mut a = CoreController::<f64>::try_new(&cfg, true).unwrap();
    let mut b = CoreController::<Fx>::try_new(&cfg, true).unwrap();
    let mut c = CoreController::<f32>::try_new(&cfg, true).unwrap();
    // Each build's detections (the ticks a protection starts) and, on the ticks where
    // the two caps agree within `tie`, their lead switch and release decisions.
    let tie = 1e-5;
    let (mut starts_a, mut starts_b) = (Vec::new(), Vec::new());
    let (mut compared, mut acting, mut first_apart) = (0u32, 0u32, None);
    let (mut was_a, mut was_b) = (false, false);
    for (k, m) in rec.seen.iter().enumerate() {
        let t = k as u64 * period;
        a.step(t, m);
        b.step(t, m);
        c.step(t, m);
        let (x, y) = (a.core().wsp_state(), b.core().wsp_state());
        if x.active && !was_a {
            starts_a.push(k);
        }
        if y.active && !was_b {
            starts_b.push(k);
        }
        (was_a, was_b) = (x.active, y.active);
        acting += u32::from(x.active);
        // Both acting (or `x` released on this tick, its cap the last one held).
        if (x.cap - y.cap.to_f64()).abs() < tie && (x.active || y.active) {
            compared += 1;
            assert_eq!(
                (x.active, x.sched),
                (y.active, y.sched),
                "Q4.28 against f64 at {:.4} s: caps {} / {}",
                t as f64 * 1e-9,
                y.cap.to_f64(),
                x.cap
            );
        } else if x.active && y.active && first_apart.is_none() {
            first_apart = Some(t as f64 * 1e-9);
        }
    }
    // Detection compares the slip with thresholds off its lattice: the same ticks.
    assert!(starts_a.len() >= 2, "{starts_a:?}");
    assert_eq!(starts_a, starts_b, "detections (ticks)");
    // The caps part in open loop: the set point rises with the cap, so on replayed codes
    // (no rail to answer) a difference grows as exp(ki slip_sp_per_a t) = exp(2.4 t/s),
    // from the Q4.28 slip's bias (the reference-speed scale's rounding, 3e-9 pu); 1.4 s
    // after the cut at 6.0 s they are `tie` apart. In closed loop the rail answers (the
    // harness's numerics, `hil run --scenario low-adhesion`).
    assert!(acting > 40_000, "{acting} ticks acting");
    assert!(
        compared > 5_000,
        "{compared} ticks compared, apart from {first_apart:?} s"
    );
    let (ca, cb, cc) = (
        a.core().counters(),
        b.core().counters(),
        c.core().counters(),
    );
    assert_eq!(cb.wsp_events, ca.wsp_events);
    // f32 (not guaranteed per tick: its slip rounds by as much as the margin) takes the
    // same course.
    assert_eq!(cc.wsp_events, ca.wsp_events);
}

/// The terms of the slip bound of `low-adhesion` with protection
/// (`firmware/control/src/wsp.rs`, "The slip bound on `low-adhesion`"), m/s or s.
#[derive(Debug)]
#[allow(dead_code)] // the fields are read through Debug in the messages
struct SlipBound {
    s0: f64,
    torsion: f64,
    torsion_cut: f64,
    t_detect: f64,
    t_cut: f64,
    rigid: f64,
    regulator: f64,
    transient: f64,
    set_point_max: f64,
    total: f64,
    low_peak_slip: f64,
}

/// The bound, from the scenario's parameters and the protection's defaults (not from a
/// run): the larger of the first transient
/// `s0 + r0 dT t_cut / J + (cut i_d - i_low)/kp + r0 dT/(J_w w_g) + r0 (1 - cut) T_d/(J_m w_g)`
/// and the regulator's set point at the full reference `slip_sp + slip_sp_per_a i_d`.
fn slip_bound(sc: &Scenario) -> SlipBound {
    let p = &sc.params;
    let w = wheelset_control::WspParams::default();
    let (q, v, r0) = (p.q(), p.v, p.r0);
    let t_d = sc.traction.value;
    let mu_d = t_d / (2.0 * q * r0);
    let dry = Condition::Dry.polach();
    let low = Condition::Low.polach();
    // s0: the dry rail's slip velocity at the demand (pure longitudinal creepage).
    let (s_pk, _) = dry.peak(q, p.f11, v, 0.2);
    let (mut lo, mut hi) = (0.0, s_pk);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if dry.force_over_q(q, p.f11, mid, v) < mu_d {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let s0 = hi * v;
    // The torque the low rail no longer carries: its characteristic rises from s0 to its
    // peak, so it carries at least mu_low(s0) on the way.
    let mu_low = low.force_over_q(q, p.f11, s0 / v, v);
    let (low_pk, _) = low.peak(q, p.f11, v, 0.2);
    let dt = t_d * (1.0 - mu_low / mu_d);
    // Two inertias at the wheel: the wheelset, the motor through the gear.
    let j_w = 2.0 * p.i_w;
    let j_m = p.n_gear * p.n_gear * p.i_m;
    let j = j_w + j_m;
    let w_g = (p.k_gear() * (1.0 / j_w + 1.0 / j_m)).sqrt();
    // The gear's twist: the wheel ahead of the motor by at most the amplitude of each
    // torque step's torsion, the rail's drop on the wheel and the cut on the motor.
    let torsion = r0 * dt / (j_w * w_g);
    let torsion_cut = r0 * (1.0 - w.cut_fraction) * t_d / (j_m * w_g);
    // Detection: the motor's rim acceleration r0 dT/J (1 - cos w_g t) reaches a_on, then
    // one traction step to measure it and one period until the cut acts; the current
    // follows the cut within the current loop's lag L_a / Kp.
    let period = 1.0 / 5000.0;
    let t_acc = (1.0 - w.accel_on_mps2 * j / (r0 * dt)).acos() / w_g;
    let t_detect = t_acc + 2.0 * period;
    let t_cut = t_detect + p.l_a / p.pi_kp;
    let rigid = r0 * dt * t_cut / j;
    // After the cut the motor's torque exceeds the low rail's by at most
    // (cut - mu_low/mu_d) T_d; the regulator's proportional term takes kp per m/s of the
    // slip's rise off the cap (its integral, the slip above the set point, takes more),
    // so the motor's slip rises at most (cut i_d - i_low)/kp before the cap is below
    // the current whose torque the low rail carries.
    let i_d = t_d / (p.n_gear * p.k_m);
    let i_low = mu_low / mu_d * i_d;
    let regulator = (w.cut_fraction * i_d - i_low).max(0.0) / w.kp_a_per_mps;
    let transient = s0 + rigid + regulator + torsion + torsion_cut;
    let set_point_max = w.slip_sp_mps + w.slip_sp_per_a * i_d;
    SlipBound {
        s0,
        torsion,
        torsion_cut,
        t_detect,
        t_cut,
        rigid,
        regulator,
        transient,
        set_point_max,
        total: transient.max(set_point_max),
        low_peak_slip: low_pk * v,
    }
}

#[test]
fn the_slip_bound_follows_from_the_thresholds_and_the_wheel_dynamics() {
    let sc = Scenario::load("low-adhesion", &Params::default()).unwrap();
    let b = slip_bound(&sc);
    // The figures the docs state (wsp.rs): 0.165 + 0.042 + 0.145 + 0.221 + 0.051 =
    // 0.624 m/s for the first transient, the cut acting 2.9 ms after the rail drops;
    // the set point at the full reference 0.564 m/s.
    let near = |x: f64, y: f64, tol: f64| (x - y).abs() < tol;
    assert!(near(b.s0, 0.165, 0.001), "{b:?}");
    assert!(near(b.torsion, 0.221, 0.001), "{b:?}");
    assert!(near(b.torsion_cut, 0.051, 0.001), "{b:?}");
    assert!(near(b.rigid, 0.042, 0.001), "{b:?}");
    assert!(near(b.regulator, 0.145, 0.001), "{b:?}");
    assert!(near(b.transient, 0.624, 0.001), "{b:?}");
    assert!(near(b.set_point_max, 0.564, 0.001), "{b:?}");
    assert!(near(b.total, 0.624, 0.001), "{b:?}");
    assert!(near(b.t_detect, 2.9e-3, 1e-4), "{b:?}");
    assert!(near(b.t_cut, 3.3e-3, 1e-4), "{b:?}");
    assert!(near(b.low_peak_slip, 0.60, 0.01), "{b:?}");
}

#[test]
fn the_sections_table_compares_the_protected_and_the_unprotected_core() {
    let out = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args([
            "run",
            "--scenario",
            "low-adhesion",
            "--control",
            "lead",
            "--loop",
            "core",
            "--sections-table",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(0));
    let text = String::from_utf8_lossy(&out.stdout);
    let rows: Vec<&str> = text.lines().filter(|l| l.starts_with("| ")).collect();
    assert_eq!(rows.len(), 6, "{text}");
    assert!(rows[0].contains("protection on") && rows[0].contains("protection off"));
    // The protected run's figures are its summary's, the unprotected one runs away in
    // the low section and stops before the wet one.
    let sc = Scenario::load("low-adhesion", &Params::default()).unwrap();
    let (on, _) = wheelset_loop::core::run_core::<f64>(&sc, YawLaw::Lead, true).unwrap();
    let s = wheelset_plant::traction::summary(&sc, &on).unwrap();
    for (row, sec) in rows[1..].iter().zip(&s.sections) {
        let want = format!(
            "| {} | {:.3} | {:.3} | {:.2} | {:.3} m/s |",
            sec.condition, sec.mu_peak, sec.mu_used_mean, sec.utilisation, sec.slip_peak_mps
        );
        assert!(row.contains(&want), "{row} / {want}");
    }
    assert!(rows[2].starts_with("| 6.0-10.0 s | low |"), "{}", rows[2]);
    assert!(rows[4].contains("(diverged at 10.4 s)"), "{}", rows[4]);
    assert!(text.contains("Protection on: runaway false"), "{text}");
    assert!(text.contains("Protection off: runaway true"), "{text}");
    // Only on the core loop of a scenario with sections.
    for args in [
        &[
            "run",
            "--scenario",
            "curve",
            "--loop",
            "core",
            "--sections-table",
        ][..],
        &["run", "--scenario", "low-adhesion", "--sections-table"][..],
    ] {
        let bad = Command::new(env!("CARGO_BIN_EXE_sim-host"))
            .args(args)
            .output()
            .unwrap();
        assert_eq!(bad.status.code(), Some(2), "{args:?}");
        assert!(String::from_utf8_lossy(&bad.stderr).contains("--sections-table"));
    }
}

#[test]
fn the_acceleration_test_alone_would_cut_a_wheel_that_does_not_slip() {
    // `firmware/control/src/wsp.rs`, "An unknown reference": why the protection does not
    // detect by the wheel's acceleration alone while `v_ref` is unknown. A step of the
    // demand to the full 12.4 kN m on dry rail (the device ramps the reference at its
    // 20 kA/s), the drive alone (protection off): the gear's twist makes the motor's
    // speed code rise by more than the acceleration threshold per traction step while
    // the wheel's slip stays below `slip_accel`, where the reference's gate holds the
    // test off.
    use wheelset_loop::core::CoreController;
    use wheelset_plant::control::SampledController;
    use wheelset_plant::sim::{run_sampled, ActuatorModel, SensorModel};
    let src = include_str!("../../scenarios/low-adhesion.toml")
        .replace("duration_s = 20.0", "duration_s = 3.0")
        .replace("ramp_s = 3.0", "ramp_s = 0.0")
        .replace("condition = \"low\"", "condition = \"dry\"")
        .replace("condition = \"wet\"", "condition = \"dry\"");
    let sc = Scenario::from_toml_str(&src, "dry-step", &Params::default()).unwrap();
    let cfg = wheelset_loop::device_loop::control_config(&sc.params, YawLaw::Lead, sc.drive);
    let inner = CoreController::<f64>::try_new(&cfg, false).unwrap();
    let period = inner.period_ns();
    let mut rec = Recorder {
        inner,
        seen: Vec::new(),
    };
    let mut act = ActuatorModel::ideal();
    act.delay_ns = period;
    let tr = run_sampled(
        &sc,
        &mut rec,
        &mut SensorModel::ideal(),
        &mut act,
        YawLaw::Lead.has_spring(),
        "dry step",
    )
    .unwrap();
    assert!(tr.info.diverged_at_s.is_none());
    let w = cfg.wsp;
    let n_r0 = sc.params.n_gear / w.r0_m;
    let t = period as f64 * 1e-9;
    // The threshold in motor-speed codes (1 mrad/s) per traction step.
    let threshold = w.accel_on_mps2 * n_r0 * t / wheelset_proto::units::SPEED_LSB_RAD_PER_S;
    let code = |m: &wheelset_plant::control::Measurements| {
        (m.w_m / wheelset_proto::units::SPEED_LSB_RAD_PER_S).round()
    };
    let (mut worst, mut slip_max) = (0.0f64, 0.0f64);
    for p in rec.seen.windows(2) {
        // The slip the device's gate sees (the motor's speed at the rim) and the
        // wheel's own.
        let gate = p[1].w_m / n_r0 - p[1].v_mps;
        slip_max = slip_max.max(p[1].w_wheel * w.r0_m - p[1].v_mps);
        if gate < w.slip_accel_mps {
            worst = worst.max(code(&p[1]) - code(&p[0]));
        }
    }
    eprintln!(
        "dry step: the motor's speed code rose by up to {worst} per step at a slip below \
         {} m/s (threshold {threshold:.2}); the wheel's slip peaked at {slip_max:.3} m/s",
        w.slip_accel_mps
    );
    assert!(
        worst > 2.0 * threshold,
        "{worst} codes, threshold {threshold}"
    );
    // The wheel never slipped: its slip stayed below the protection's own threshold.
    assert!(slip_max < w.slip_on_mps, "slip {slip_max} m/s");
}
