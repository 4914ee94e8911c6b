//! Modes of the closed loop working near the adhesion peak (README "Why the
//! scheduled lead").
//!
//! ```text
//! adh_modes <dry|wet|low> <lead|passive> <gain scale>
//! env FR=0.6,0.7   fractions of the rail's peak adhesion (default 0.6,0.7), each in (0, 1)
//! env LZ=15        the lead's zero, rad/s (default the paper's 37; the pole 274 is kept)
//! ```
//!
//! # Method
//!
//! Plant of case (d) (flexible axle, drive, forward speed as a state), Polach's adhesion
//! law of the rail condition on ([`wheelset_plant::adhesion`]), the continuous reference
//! controllers of `sim-host` ([`ContinuousController`]: the yaw law, its gain `K` times
//! `<gain scale>`, and the PI current loop), straight level track at the parameters'
//! speed `v`.
//!
//! **Steady traction point** at fraction `fr` of the peak, in closed form: on straight
//! track with `y = y' = psi = psi' = 0` and both wheels at the same speed `w`, both
//! wheels have the longitudinal creepage `s = w r0 / v - 1` and the same force
//! `F = Q (F/Q)(s)` (rail on wheel, + forward); `s` in `(0, s_peak)` is found by
//! bisection so that `F/Q = fr mu_peak` (the rising side of the characteristic). Then
//! `k_t twist = -r0 F` (right wheel), `k_gear wind = -2 r0 F` (left wheel), `theta_m' =
//! n w`, `i_a = i_ref = -k_gear wind / (n K_m) = 2 r0 F / (n K_m)`, PI integrator `x_i =
//! u_a = R_a i_a + K_m theta_m'`, lead state 0, and the running resistance `F_run = 2 F`
//! holds the speed. The example prints the largest `|x'|` of the closed-loop
//! right-hand side there (the steady-state residual, ~0).
//!
//! **Linearisation** by central differences of `closed_loop_rhs`
//! ([`wheelset_plant::linear::closed_loop_jacobian_central`]),
//! `A[:, j] = (f(x + h_j e_j) - f(x - h_j e_j)) / (2 h_j)`, `h_j = 1e-6 max(|x_j|, 1e-2)`
//! (SI units of each state). Not the complex step: `num_complex`'s `atan` is computed as
//! a difference of two logarithms and loses the imaginary part, so the complex-step
//! Jacobian with adhesion is wrong. `A` is restricted to the loop's states and its
//! eigenvalues computed ([`wheelset_plant::modes::eigenvalues`]).
//!
//! # Output (per fraction)
//!
//! - `slip`: the slip velocity `s v`, m/s (+ the wheel faster than the vehicle);
//! - `creep slope`: `dF/ds` at the point, N (the tangent of the characteristic per unit
//!   creepage; `f11` = 10 MN at zero creepage, 0 at the peak);
//! - the four eigenvalues with the largest real part, rad/s (`re +- j im`); a positive
//!   real part is an unstable mode. A conjugate pair is printed once (`re +-im j`) and
//!   counts as one of the four. The structural near-zero real eigenvalue of the speed
//!   direction (`|re| < 1e-3`) is printed as `(speed)` and left out of the verdict
//!   (`stable` / `UNSTABLE`).
//!
//! Bad arguments print a message and exit with code 2.

use nalgebra::Complex;
use std::process::ExitCode;
use wheelset_plant::adhesion::{Adhesion, Condition};
use wheelset_plant::control::{closed_loop_rhs, ContinuousController, Exogenous, YawLaw};
use wheelset_plant::linear::{closed_loop_jacobian_central, closed_loop_states, select};
use wheelset_plant::modes::eigenvalues;
use wheelset_plant::params::Params;
use wheelset_plant::plant::{ix, Plant, PlantConfig, State, NX};
use wheelset_plant::scenario::Axle;

/// A real eigenvalue smaller than this (rad/s) is the speed direction's structural
/// near-zero one (free rolling at any speed; with adhesion `mu` depends weakly on the
/// slip velocity `s v`, so it is not exactly 0): printed as `(speed)`, left out of the
/// verdict.
const STRUCTURAL: f64 = 1e-3;

/// A steady traction point.
struct Point {
    x: State,
    e: Exogenous<f64>,
    slip_mps: f64,
    slope_n: f64,
}

/// The steady point at fraction `fr` of the peak (see the module docs).
fn steady_point(p: &Params, adh: &Adhesion, fr: f64) -> Point {
    let (q, f11, v) = (adh.q, p.f11, p.v);
    let law = adh.law;
    let (s_peak, mu_peak) = law.peak(q, f11, v, 0.2);
    let target = fr * mu_peak;
    let (mut lo, mut hi) = (0.0, s_peak);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if law.force_over_q(q, f11, mid, v) < target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let s = 0.5 * (lo + hi);
    let f = law.force_over_q(q, f11, s, v) * q;
    let ds = 1e-6 * s;
    let slope_n = (law.force_over_q(q, f11, s + ds, v) - law.force_over_q(q, f11, s - ds, v)) * q
        / (2.0 * ds);
    let w = (1.0 + s) * v / p.r0;
    let mut x = [0.0; NX];
    x[ix::V] = v;
    x[ix::WR] = w;
    x[ix::WL] = w;
    x[ix::TWIST] = -p.r0 * f / p.k_t();
    x[ix::WIND] = -2.0 * p.r0 * f / p.k_gear();
    x[ix::WM] = p.n_gear * w;
    let ia = 2.0 * p.r0 * f / (p.n_gear * p.k_m);
    x[ix::IA] = ia;
    x[ix::PI] = p.r_a * ia + p.k_m * x[ix::WM];
    let e = Exogenous {
        curvature: 0.0,
        cant: 0.0,
        f_run: 2.0 * f,
        i_ref: ia,
        demand: 0.0,
    };
    Point {
        x,
        e,
        slip_mps: s * v,
        slope_n,
    }
}

fn parse_fractions(s: &str) -> Result<Vec<f64>, String> {
    let mut out = Vec::new();
    for t in s.split(',') {
        let f: f64 = t
            .trim()
            .parse()
            .map_err(|_| format!("FR: `{t}` is not a number"))?;
        if !(f > 0.0 && f < 1.0) {
            return Err(format!(
                "FR: {f} is not a fraction of the peak in (0, 1) (past the peak there is no rising-side point)"
            ));
        }
        out.push(f);
    }
    Ok(out)
}

struct Args {
    condition: Condition,
    law: YawLaw,
    scale: f64,
    fractions: Vec<f64>,
    lead_zero: Option<f64>,
}

fn parse_args() -> Result<Args, String> {
    let usage =
        "usage: adh_modes <dry|wet|low> <lead|passive> <gain scale>  (env FR=0.6,0.7, LZ=rad/s)";
    let a: Vec<String> = std::env::args().skip(1).collect();
    if a.len() != 3 {
        return Err(format!("expected 3 arguments, got {}\n{usage}", a.len()));
    }
    let condition = Condition::from_name(&a[0])
        .ok_or_else(|| format!("unknown rail condition `{}` (dry, wet, low)\n{usage}", a[0]))?;
    let law = match a[1].as_str() {
        "lead" => YawLaw::Lead,
        "passive" => YawLaw::Passive,
        other => {
            return Err(format!(
                "unknown yaw law `{other}` (lead, passive)\n{usage}"
            ))
        }
    };
    let scale: f64 = a[2]
        .parse()
        .map_err(|_| format!("gain scale `{}` is not a number\n{usage}", a[2]))?;
    if !(scale.is_finite() && scale > 0.0) {
        return Err(format!("gain scale {scale} must be finite and > 0"));
    }
    let fractions = match std::env::var("FR") {
        Ok(s) => parse_fractions(&s)?,
        Err(std::env::VarError::NotPresent) => vec![0.6, 0.7],
        Err(_) => return Err("FR is not valid unicode".into()),
    };
    let lead_zero = match std::env::var("LZ") {
        Ok(s) => {
            let z: f64 = s
                .trim()
                .parse()
                .map_err(|_| format!("LZ: `{s}` is not a number"))?;
            if !(z.is_finite() && z > 0.0) {
                return Err(format!("LZ: {z} must be finite and > 0 rad/s"));
            }
            Some(z)
        }
        Err(std::env::VarError::NotPresent) => None,
        Err(_) => return Err("LZ is not valid unicode".into()),
    };
    Ok(Args {
        condition,
        law,
        scale,
        fractions,
        lead_zero,
    })
}

fn main() -> ExitCode {
    let args = match parse_args() {
        Ok(a) => a,
        Err(m) => {
            eprintln!("adh_modes: {m}");
            return ExitCode::from(2);
        }
    };
    let p = Params::default();
    let cfg = PlantConfig {
        axle: Axle::Flexible,
        drive: true,
        yaw_spring: args.law.has_spring(),
    };
    let mut plant = Plant::new(&p, cfg);
    let adh = Adhesion::new(args.condition, p.q());
    plant.adhesion = Some(adh);
    let mut ctrl = ContinuousController::new(&p, args.law);
    ctrl.k *= args.scale;
    if let Some(z) = args.lead_zero {
        ctrl.lead_z = z;
    }
    let states = closed_loop_states(&cfg, args.law);
    let (_, mu_peak) = adh.law.peak(adh.q, p.f11, p.v, 0.2);
    println!(
        "{} rail, mu_peak {:.4} at v = {} m/s; law {}, gain x{}, lead zero {} rad/s, pole {} rad/s",
        args.condition,
        mu_peak,
        p.v,
        args.law.name(),
        args.scale,
        ctrl.lead_z,
        ctrl.lead_p
    );
    for &fr in &args.fractions {
        let pt = steady_point(&p, &adh, fr);
        let dx = closed_loop_rhs(&plant, plant.cfg, &ctrl, &pt.x, &pt.e);
        let resid = states.iter().map(|&i| dx[i].abs()).fold(0.0, f64::max);
        let a = select(
            &closed_loop_jacobian_central(&plant, &ctrl, &pt.x, &pt.e),
            &states,
        );
        let Some(mut ev) = eigenvalues(&a) else {
            eprintln!("adh_modes: non-finite Jacobian at fraction {fr}");
            return ExitCode::from(1);
        };
        ev.sort_by(|x, y| y.re.total_cmp(&x.re));
        // One line per conjugate pair (the positive imaginary part) or real eigenvalue.
        let shown: Vec<&Complex<f64>> = ev.iter().filter(|z| z.im >= 0.0).take(4).collect();
        let list: Vec<String> = shown
            .iter()
            .map(|z| {
                if z.im > 0.0 {
                    format!("{:+.3} +-{:.1}j", z.re, z.im)
                } else if z.re.abs() < STRUCTURAL {
                    format!("{:+.0e} (speed)", z.re)
                } else {
                    format!("{:+.3}", z.re)
                }
            })
            .collect();
        let verdict = if shown
            .iter()
            .any(|z| z.re > 0.0 && !(z.im == 0.0 && z.re < STRUCTURAL))
        {
            "UNSTABLE"
        } else {
            "stable"
        };
        println!(
            "fr {fr:.3}: slip {:.4} m/s, creep slope {:.3} MN, residual {:.1e}; rightmost {}  [{verdict}]",
            pt.slip_mps,
            pt.slope_n / 1e6,
            resid,
            list.join(", ")
        );
    }
    ExitCode::SUCCESS
}
