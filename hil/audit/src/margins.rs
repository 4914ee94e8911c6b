//! Stability and margins of the two loops after quantisation (`docs/audit.md`): the plant
//! linearised about straight track at pure rolling (`wheelset_plant::sampled::Model::Full`),
//! discretised with a zero-order hold at the base period, one period of actuation delay,
//! and the controller quantised as the device holds it or ideal (f64). Each loop is
//! broken at its actuator with the other loop closed:
//!
//! ```text
//! yaw:      L(z) = -C_y(z) z^-1 P_y(z),   P_y: T_psi -> y',  C_y = (T_fs/y'_fs) H(z) (1 + 2p (1 - z^-1))
//!           H(z) = K_hf (1 - h (1 + z^-1)/(1 - a z^-1)),  a = 1 - kappa,  h = kappa g/2
//! traction: L(z) =  C_i(z) z^-1 P_i(z),   P_i: u_a -> i_a,  C_i = (V_fs/I_fs)(Kp + Ki/(1 - z^-1))
//! ```
//!
//! (`T_psi = +C_y y'` acts through eq. 5's `-T_psi`, hence the minus; the PI acts on
//! `i_ref - i_a`.) **Stability (Nyquist):** with `P` the open-loop poles outside the unit
//! circle and `W` the counter-clockwise turns of `1 + L(z)` round `|z| = 1 + 1e-6` (the
//! PI's integrator at `z = 1` inside), the closed loop has `Z = P - W` unstable poles.
//! **Margins** of a stable loop: the gain interval `(k_lo, k_hi)` from the crossings of
//! the negative real axis (a crossing at `-x` is the factor `1/x`; `k_lo = 0` for an
//! open-loop-stable loop), and the extra phase lag and lead at a gain crossover that
//! bring `L` onto `-1`. The reported margins are the smaller gain change (dB) and the
//! smaller of lag and lead; an unstable loop has none (`null`).

use nalgebra::{DMatrix, DVector};
use serde::Serialize;
use wheelset_control::Config;
use wheelset_plant::params::Params;
use wheelset_plant::sampled::{zoh, Model};

use super::bounds::Quantised;

use super::response::C64 as Complex64;

/// Radius of the Nyquist contour: just outside the unit circle.
const CONTOUR_RADIUS: f64 = 1.0 + 1e-6;

/// One loop's stability and margins, ideal vs quantised.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Margin {
    /// `yaw (lead)` or `traction (PI)`.
    #[serde(rename = "loop")]
    pub loop_name: String,
    /// Gain margin with the f64 controller: the smaller of the gain increase and the
    /// gain reduction to instability, dB (positive for a stable loop; `null`: the loop is
    /// unstable, or no gain change destabilises it).
    pub gain_db_ideal: Option<f64>,
    /// Gain margin with the quantised controller, dB.
    pub gain_db_quantised: Option<f64>,
    /// Phase margin with the f64 controller: the smaller of the phase lag and lead to
    /// instability, degrees (positive for a stable loop; `null`: unstable, or no gain
    /// crossover).
    pub phase_deg_ideal: Option<f64>,
    /// Phase margin with the quantised controller, degrees.
    pub phase_deg_quantised: Option<f64>,
    /// Where the gain margin is read (the crossing of the negative real axis), Hz
    /// (quantised).
    pub phase_crossover_hz: Option<f64>,
    /// Where the phase margin is read (`|L| = 1`), Hz (quantised).
    pub gain_crossover_hz: Option<f64>,
    /// Open-loop poles outside the unit circle, `P` (plant and controller).
    pub open_loop_unstable_poles: usize,
    /// Counter-clockwise turns of `1 + L` round the origin on the Nyquist contour, `W`
    /// (quantised controller).
    pub encirclements: i64,
    /// Closed-loop poles outside the unit circle, `Z = P - W` (quantised controller).
    pub closed_loop_unstable_poles: i64,
    /// `Z = 0` (quantised controller).
    pub stable: bool,
    /// The gain reduction to instability, dB (negative: how far the loop gain may drop;
    /// `null`: no lower limit, as for an open-loop-stable plant) (quantised).
    pub gain_reduction_db: Option<f64>,
    /// The gain increase to instability, dB (`null`: none) (quantised).
    pub gain_increase_db: Option<f64>,
    /// The extra phase lag to instability, degrees (`null`: none) (quantised).
    pub phase_lag_deg: Option<f64>,
    /// The extra phase lead to instability, degrees (`null`: none) (quantised).
    pub phase_lead_deg: Option<f64>,
}

/// `c (zI - A)^-1 b` at `z`, by LU decomposition (`None`: `z` is a pole).
fn freq_resp(
    a: &DMatrix<Complex64>,
    b: &DVector<Complex64>,
    c: &DVector<Complex64>,
    z: Complex64,
) -> Option<Complex64> {
    let n = a.nrows();
    let m = DMatrix::from_diagonal_element(n, n, z) - a;
    let x = m.lu().solve(b)?;
    Some(c.dot(&x))
}

fn wrap(d: f64) -> f64 {
    let mut d = d % 360.0;
    if d > 180.0 {
        d -= 360.0;
    }
    if d <= -180.0 {
        d += 360.0;
    }
    d
}

/// A loop's return ratio sampled round the upper half of the Nyquist contour: angles
/// `w` (rad per sample, 0 to pi) and `L(r e^{jw})`, refined until successive samples of
/// `L` and of `1 + L` turn by under 20 degrees.
fn sample_half_contour(l: &dyn Fn(Complex64) -> Complex64, f_min: f64) -> Vec<(f64, Complex64)> {
    let at = |w: f64| (w, l(Complex64::from_polar(CONTOUR_RADIUS, w)));
    // A log grid from `f_min` (rad) to pi, with the end points 0 and pi.
    let m = 2000;
    let mut ws = vec![0.0];
    ws.extend((0..m).map(|i| f_min * (std::f64::consts::PI / f_min).powf(i as f64 / m as f64)));
    ws.push(std::f64::consts::PI);
    let mut out: Vec<(f64, Complex64)> = Vec::with_capacity(ws.len() * 2);
    let mut prev = at(ws[0]);
    out.push(prev);
    for &w in &ws[1..] {
        let next = at(w);
        refine(&at, prev, next, 0, &mut out);
        out.push(next);
        prev = next;
    }
    out
}

fn turn(a: Complex64, b: Complex64) -> f64 {
    (b / a).arg().abs()
}

fn refine(
    at: &dyn Fn(f64) -> (f64, Complex64),
    a: (f64, Complex64),
    b: (f64, Complex64),
    depth: u32,
    out: &mut Vec<(f64, Complex64)>,
) {
    let one = Complex64::new(1.0, 0.0);
    let limit = 20f64.to_radians();
    let coarse = turn(a.1, b.1) > limit || turn(one + a.1, one + b.1) > limit;
    if depth >= 24 || !coarse || !(a.1.norm().is_finite() && b.1.norm().is_finite()) {
        return;
    }
    let mid = at(0.5 * (a.0 + b.0));
    refine(at, a, mid, depth + 1, out);
    out.push(mid);
    refine(at, mid, b, depth + 1, out);
}

/// What the Nyquist plot of one loop says: `W`, the critical gain factors and the
/// phase distances at the gain crossovers, each with its frequency (Hz).
struct Nyquist {
    encirclements: i64,
    /// Loop-gain factors at which the closed loop is marginal, with their frequency.
    critical: Vec<(f64, f64)>,
    /// `wrap(180 + arg L)` at each gain crossover, with its frequency.
    crossovers: Vec<(f64, f64)>,
}

fn nyquist(half: &[(f64, Complex64)], fs: f64) -> Nyquist {
    let one = Complex64::new(1.0, 0.0);
    let hz = |w: f64| w * fs / (2.0 * std::f64::consts::PI);
    // Turns of 1 + L: twice the upper half (the lower half is its mirror image).
    let mut turned = 0.0;
    let mut critical = Vec::new();
    let mut crossovers = Vec::new();
    for e in [half.first(), half.last()].into_iter().flatten() {
        // At w = 0 and w = pi, L is real: on the negative real axis it is a crossing.
        if e.1.re < 0.0 && e.1.im.abs() <= 1e-9 * e.1.norm() {
            critical.push((-1.0 / e.1.re, hz(e.0)));
        }
    }
    for p in half.windows(2) {
        let ((wa, a), (wb, b)) = (p[0], p[1]);
        if !(a.norm().is_finite() && b.norm().is_finite()) {
            continue;
        }
        turned += ((one + b) / (one + a)).arg();
        // A crossing of the negative real axis between the samples.
        if (a.im > 0.0) != (b.im > 0.0) && a.im != b.im {
            let t = a.im / (a.im - b.im);
            let x = a.re + t * (b.re - a.re);
            if x < 0.0 {
                critical.push((-1.0 / x, hz(wa + t * (wb - wa))));
            }
        }
        // A gain crossover.
        let (ga, gb) = (a.norm().ln(), b.norm().ln());
        if (ga > 0.0) != (gb > 0.0) && ga != gb {
            let t = ga / (ga - gb);
            let ph = wrap(180.0 + a.arg().to_degrees() + t * wrap((b / a).arg().to_degrees()));
            crossovers.push((ph, hz(wa + t * (wb - wa))));
        }
    }
    Nyquist {
        encirclements: (2.0 * turned / (2.0 * std::f64::consts::PI)).round() as i64,
        critical,
        crossovers,
    }
}

/// The margins of one return ratio, given its open-loop unstable poles `p`.
struct Read {
    w: i64,
    stable: bool,
    reduction: Option<(f64, f64)>,
    increase: Option<(f64, f64)>,
    lag: Option<(f64, f64)>,
    lead: Option<(f64, f64)>,
}

impl Read {
    fn of(l: &dyn Fn(Complex64) -> Complex64, p: usize, fs: f64) -> Read {
        let half = sample_half_contour(l, 2.0 * std::f64::consts::PI * 1e-3 / fs);
        let n = nyquist(&half, fs);
        let stable = n.encirclements == p as i64;
        let db = |k: f64| 20.0 * k.log10();
        let below = n
            .critical
            .iter()
            .filter(|c| c.0 < 1.0)
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map(|c| (db(c.0), c.1));
        let above = n
            .critical
            .iter()
            .filter(|c| c.0 > 1.0)
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .map(|c| (db(c.0), c.1));
        let lag = n
            .crossovers
            .iter()
            .filter(|c| c.0 > 0.0)
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .copied();
        let lead = n
            .crossovers
            .iter()
            .filter(|c| c.0 <= 0.0)
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map(|c| (-c.0, c.1));
        Read {
            w: n.encirclements,
            stable,
            reduction: below,
            increase: above,
            lag,
            lead,
        }
    }

    /// The smaller gain change to instability, dB (positive), and where.
    fn gain(&self) -> Option<(f64, f64)> {
        if !self.stable {
            return None;
        }
        let down = self.reduction.map(|(g, f)| (-g, f));
        match (down, self.increase) {
            (Some(a), Some(b)) => Some(if a.0 <= b.0 { a } else { b }),
            (a, b) => a.or(b),
        }
    }

    /// The smaller phase change to instability, degrees (positive), and where.
    fn phase(&self) -> Option<(f64, f64)> {
        if !self.stable {
            return None;
        }
        match (self.lag, self.lead) {
            (Some(a), Some(b)) => Some(if a.0 <= b.0 { a } else { b }),
            (a, b) => a.or(b),
        }
    }
}

/// A discrete controller `(n0 + n1 z^-1 + ...)/(1 + d1 z^-1 + ...)` (SI units), the sign
/// with which it acts on the plant's output (`+1`: `u = C y`; `-1`: `u = C (-y)`), and the
/// plant's input and output it connects.
struct Loop<'a> {
    num: Vec<f64>,
    den: Vec<f64>,
    sign: f64,
    b: &'a DMatrix<f64>,
    c: &'a DMatrix<f64>,
}

/// The plant `(A, b_in, c_out)` with `lp` closed round it through one period of delay:
/// states `[x; s; d]` (plant, the controller in transposed direct form II, the held
/// actuation).
fn close(a: &DMatrix<f64>, lp: &Loop<'_>) -> DMatrix<f64> {
    let n = a.nrows();
    let m = lp.den.len().max(lp.num.len()) - 1;
    let coef = |v: &[f64], i: usize| v.get(i).copied().unwrap_or(0.0);
    let n0 = coef(&lp.num, 0);
    let dim = n + m + 1;
    let mut out = DMatrix::zeros(dim, dim);
    out.view_mut((0, 0), (n, n)).copy_from(a);
    // x+ = A x + b d
    for i in 0..n {
        out[(i, n + m)] = lp.b[(i, 0)];
    }
    // s+ = A_c s + B_c e, e = sign c x; d+ = C_c s + D e.
    for i in 0..m {
        out[(n + i, n)] = -coef(&lp.den, i + 1);
        if i + 1 < m {
            out[(n + i, n + i + 1)] = 1.0;
        }
        let bc = coef(&lp.num, i + 1) - coef(&lp.den, i + 1) * n0;
        for j in 0..n {
            out[(n + i, j)] = bc * lp.sign * lp.c[(0, j)];
        }
    }
    if m > 0 {
        out[(n + m, n)] = 1.0;
    }
    for j in 0..n {
        out[(n + m, j)] = n0 * lp.sign * lp.c[(0, j)];
    }
    out
}

/// The stability and margins of the yaw (lead) and traction (PI) loops for `cfg` (one
/// base period of delay) at the operating point `p`, ideal (f64 coefficients) and
/// quantised (`q`, as the device holds them).
pub fn margins(cfg: &Config, q: &Quantised, p: &Params) -> Result<Vec<Margin>, String> {
    let plant = Model::Full.plant(p, p.f11, p.lambda, false);
    let t0 = cfg.base_period();
    let (ad, bd) = zoh(&plant.a, &plant.b, t0);
    let (b_t, b_u) = (bd.columns(0, 1).into_owned(), bd.columns(1, 1).into_owned());
    let (c_y, c_i) = (
        plant.c.rows(0, 1).into_owned(),
        plant.c.rows(1, 1).into_owned(),
    );
    let s = &cfg.scales;
    let ideal_lead = cfg
        .lead
        .discretise(cfg.yaw_period())
        .map_err(|e| e.to_string())?
        .to_pu(s.y_dot, s.torque);
    let ideal_pi = cfg
        .pi
        .discretise(cfg.traction_period())
        .map_err(|e| e.to_string())?
        .to_pu(s.current, s.voltage);
    let ideal_ph = cfg.yaw_predict_ticks / (2.0 * cfg.yaw_divisor as f64);
    let fs = 1.0 / t0;
    // The controllers as transfer functions in z^-1, SI units:
    // C_y = g K [(1-h) - (a+h) z^-1][(1+2p) - 2p z^-1] / (1 - a z^-1),
    // C_i = s [(Kp+Ki) - Kp z^-1] / (1 - z^-1).
    let yaw = |k: f64, g: f64, kap: f64, ph: f64| -> Loop<'_> {
        let (a, h) = (1.0 - kap, kap * g);
        let gain = k * s.torque / s.y_dot;
        Loop {
            num: vec![
                gain * (1.0 - h) * (1.0 + 2.0 * ph),
                gain * (-(1.0 - h) * 2.0 * ph - (a + h) * (1.0 + 2.0 * ph)),
                gain * (a + h) * 2.0 * ph,
            ],
            den: vec![1.0, -a, 0.0],
            sign: 1.0,
            b: &b_t,
            c: &c_y,
        }
    };
    let trac = |kp: f64, ki: f64| -> Loop<'_> {
        let g = s.voltage / s.current;
        Loop {
            num: vec![g * (kp + ki), -g * kp],
            den: vec![1.0, -1.0],
            sign: -1.0,
            b: &b_u,
            c: &c_i,
        }
    };
    // One loop broken at its actuator with the other closed, as the device runs them:
    // its stability and margins.
    let read = |this: &Loop<'_>, other: &Loop<'_>| -> Result<(usize, Read), String> {
        let a_aug = close(&ad, other);
        let dim = a_aug.nrows();
        let n = ad.nrows();
        let cplx = |m: &DMatrix<f64>| m.map(|x| Complex64::new(x, 0.0));
        let a_c = cplx(&a_aug);
        let b_c = DVector::from_fn(dim, |i, _| {
            Complex64::new(if i < n { this.b[(i, 0)] } else { 0.0 }, 0.0)
        });
        let c_c = DVector::from_fn(dim, |j, _| {
            Complex64::new(if j < n { this.c[(0, j)] } else { 0.0 }, 0.0)
        });
        // Open-loop poles outside the contour that this loop's transfer function has (the
        // controller's own poles, the lead's `a` and the PI's integrator, lie inside it):
        // a pole makes `c (zI - A)^-1 b` grow a thousandfold as `z` comes a thousand times
        // closer; a mode the loop neither drives nor sees does not.
        let eig = wheelset_plant::modes::eigenvalues(&a_aug)
            .ok_or("the sampled loop's eigenvalues did not converge")?;
        let growth = |l: Complex64, d: f64| {
            freq_resp(&a_c, &b_c, &c_c, l * (1.0 + d)).map_or(f64::INFINITY, |v| v.norm())
        };
        let unstable = eig
            .iter()
            .filter(|l| l.norm() > CONTOUR_RADIUS)
            .filter(|l| growth(**l, 1e-7) > 100.0 * growth(**l, 1e-4))
            .count();
        let poly = |c: &[f64], zi: Complex64| {
            c.iter()
                .rev()
                .fold(Complex64::new(0.0, 0.0), |acc, &k| acc * zi + k)
        };
        let l = |z: Complex64| -> Complex64 {
            let zi = 1.0 / z;
            let ctrl = poly(&this.num, zi) / poly(&this.den, zi);
            let pl = freq_resp(&a_c, &b_c, &c_c, z).unwrap_or(Complex64::new(f64::NAN, f64::NAN));
            -this.sign * ctrl * zi * pl
        };
        Ok((unstable, Read::of(&l, unstable, fs)))
    };
    let (yl_i, yl_q) = (
        yaw(
            ideal_lead.k_hf,
            ideal_lead.g_half,
            ideal_lead.kappa,
            ideal_ph,
        ),
        yaw(q.lead.k_hf, q.lead.g_half, q.lead.kappa, q.ph),
    );
    let (tl_i, tl_q) = (trac(ideal_pi.kp, ideal_pi.ki), trac(q.kp, q.ki));
    let (_, yi) = read(&yl_i, &tl_i)?;
    let (p_yaw, yq) = read(&yl_q, &tl_q)?;
    let (_, ti) = read(&tl_i, &yl_i)?;
    let (p_trac, tq) = read(&tl_q, &yl_q)?;
    let mk = |name: &str, p: usize, i: &Read, q: &Read| Margin {
        loop_name: name.into(),
        gain_db_ideal: i.gain().map(|x| x.0),
        gain_db_quantised: q.gain().map(|x| x.0),
        phase_deg_ideal: i.phase().map(|x| x.0),
        phase_deg_quantised: q.phase().map(|x| x.0),
        phase_crossover_hz: q.gain().map(|x| x.1),
        gain_crossover_hz: q.phase().map(|x| x.1),
        open_loop_unstable_poles: p,
        encirclements: q.w,
        closed_loop_unstable_poles: p as i64 - q.w,
        stable: q.stable,
        gain_reduction_db: q.reduction.map(|x| x.0),
        gain_increase_db: q.increase.map(|x| x.0),
        phase_lag_deg: q.lag.map(|x| x.0),
        phase_lead_deg: q.lead.map(|x| x.0),
    };
    Ok(vec![
        mk("yaw (lead)", p_yaw, &yi, &yq),
        mk("traction (PI)", p_trac, &ti, &tq),
    ])
}

#[cfg(test)]
mod tests;
