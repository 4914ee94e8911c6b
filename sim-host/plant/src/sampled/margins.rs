//! Stability and margins of each loop broken at its actuator, by the Nyquist criterion
//! on the sampled loop.
//!
//! ```text
//! yaw:      L(z) = -C_y(z) z^-d P_y(z),   P_y: T_psi -> y' (N m -> m/s)
//!           C_y = K_hf (1 - h (1 + z^-1)/(1 - a z^-1)) (1 + alpha (1 - z^-1)),
//!           a = 1 - kappa, h = kappa g/2, alpha = yaw_predict_ticks
//! traction: L(z) =  C_i(z) z^-d P_i(z),   P_i: u_a -> i_a (V -> A),
//!           C_i = Kp + Ki/(1 - z^-1)
//! P(z) = C (zI - Ad)^-1 Bd                (ZOH at the base period)
//! ```
//!
//! `T_psi = +C_y y'` acts through eq. 5's `-T_psi`, hence the yaw loop's minus sign; the
//! PI acts on `i_ref - i_a`; the other loop as [`Other`] says. **Stability:** `Z = P - W`
//! ([`Margins`]), `W` counted on `|z| = 1 + 1e-6` (the PI's integrator inside).
//! **Margins** of a stable loop: the loop-gain factors at which `L` crosses `-1` (a
//! crossing of the negative real axis at `-x` is the factor `1/x`; an open-loop-unstable
//! loop needs a minimum gain) and the extra phase lag and lead at a gain crossover that
//! bring `L` onto `-1` (`docs/audit.md`).

use super::*;
use crate::params::Params;
use nalgebra::{Complex, DMatrix, DVector};
use std::f64::consts::PI;
use wheelset_control::{Config, YawMode};

type C64 = Complex<f64>;

/// Radius of the Nyquist contour: just outside the unit circle.
const CONTOUR_RADIUS: f64 = 1.0 + 1e-6;

/// Which loop is broken.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Loop {
    /// The yaw damper (lead or gain), at the actuator torque `T_psi`.
    Yaw,
    /// The traction current loop, at the armature voltage `u_a`.
    Traction,
}

impl Loop {
    /// Name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Loop::Yaw => "yaw",
            Loop::Traction => "traction",
        }
    }

    /// The plant's (input, output) of this loop, and the sign `s` of `u = s C y`.
    fn port(self) -> (usize, usize, f64) {
        match self {
            Loop::Yaw => (0, 0, 1.0),
            Loop::Traction => (1, 1, -1.0),
        }
    }
}

/// What the loop not broken does while one loop's margins are read.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Other {
    /// Closed round the plant as the device runs it.
    Closed,
    /// Out of the way: the yaw loop without traction, the traction loop on the plant
    /// with the passive yaw spring.
    Open,
}

/// A controller `u = C(z) e`, `C = (n0 + n1 z^-1 + ..)/(1 + d1 z^-1 + ..)`, SI units.
#[derive(Debug, Clone, PartialEq)]
pub struct Law {
    /// Numerator coefficients in `z^-1`.
    pub num: Vec<f64>,
    /// Denominator coefficients in `z^-1`, `den[0] = 1`.
    pub den: Vec<f64>,
}

impl Law {
    /// The lead with the `y'` predictor: `k_hf` N m s/m, `g_half = g/2`, `kappa`, and the
    /// predictor's `alpha` (ticks).
    pub fn lead(k_hf: f64, g_half: f64, kappa: f64, alpha: f64) -> Law {
        let (a, h) = (1.0 - kappa, kappa * g_half);
        Law {
            num: vec![
                k_hf * (1.0 - h) * (1.0 + alpha),
                k_hf * (-(1.0 - h) * alpha - (a + h) * (1.0 + alpha)),
                k_hf * (a + h) * alpha,
            ],
            den: vec![1.0, -a],
        }
    }

    /// The pure gain `k` N m s/m with the predictor's `alpha` (ticks).
    pub fn gain(k: f64, alpha: f64) -> Law {
        Law {
            num: vec![k * (1.0 + alpha), -k * alpha],
            den: vec![1.0],
        }
    }

    /// The PI: `kp` V/A, `ki` V/A per tick.
    pub fn pi(kp: f64, ki: f64) -> Law {
        Law {
            num: vec![kp + ki, -kp],
            den: vec![1.0, -1.0],
        }
    }

    fn at(&self, zi: C64) -> C64 {
        let poly = |c: &[f64]| {
            c.iter()
                .rev()
                .fold(C64::new(0.0, 0.0), |acc, &k| acc * zi + k)
        };
        poly(&self.num) / poly(&self.den)
    }
}

/// The two controllers (`None`: the passive yaw spring, or no traction loop).
#[derive(Debug, Clone, PartialEq)]
pub struct Laws {
    /// The yaw law.
    pub yaw: Option<Law>,
    /// The traction PI.
    pub traction: Option<Law>,
}

impl Laws {
    /// The f64 controllers of `cfg`. Errors: divisors other than 1, an invalid configuration.
    pub fn of(cfg: &Config) -> Result<Laws, String> {
        cfg.validate().map_err(|e| e.to_string())?;
        if cfg.yaw_divisor != 1 || cfg.traction_divisor != 1 {
            return Err("margins: both loops must run every base tick (divisors 1)".into());
        }
        let (lead, pi) = discretised(cfg)?;
        let alpha = cfg.yaw_predict_ticks;
        Ok(Laws {
            yaw: match cfg.yaw_mode {
                YawMode::Passive => None,
                YawMode::Gain => Some(Law::gain(cfg.gain_k, alpha)),
                YawMode::Lead => Some(Law::lead(lead.k_hf, lead.g / 2.0, lead.kappa, alpha)),
            },
            traction: cfg.traction_enabled.then(|| Law::pi(pi.kp, pi.ki)),
        })
    }
}

/// A margin and the frequency it is read at (Hz).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct At {
    /// dB (gain margins) or degrees (phase margins).
    pub value: f64,
    /// Frequency of the crossing, Hz.
    pub hz: f64,
}

/// The stability and margins of one loop (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Margins {
    /// `Z = 0`.
    pub stable: bool,
    /// Open-loop poles outside the unit circle that the loop drives and sees, `P`.
    pub open_loop_unstable: usize,
    /// Counter-clockwise turns of `1 + L` round the origin, `W`.
    pub encirclements: i64,
    /// Closed-loop poles outside the unit circle, `Z = P - W`.
    pub closed_loop_unstable: i64,
    /// Gain increase to instability, dB (`None`: unstable, or none).
    pub gain_up: Option<At>,
    /// Gain decrease to instability, dB, negative (`None`: unstable, or stable down to
    /// zero gain).
    pub gain_down: Option<At>,
    /// Extra phase lag to instability, degrees (`None`: unstable, or no gain crossover).
    pub phase_lag: Option<At>,
    /// Extra phase lead to instability, degrees.
    pub phase_lead: Option<At>,
    /// The phase margin: the smaller of lag and lead, degrees.
    pub phase: Option<At>,
}

impl Margins {
    /// The gain margin: the smaller gain change to instability, dB (positive).
    pub fn gain(&self) -> Option<At> {
        let down = self.gain_down.map(|a| At {
            value: -a.value,
            ..a
        });
        smaller(down, self.gain_up)
    }
}

fn smaller(a: Option<At>, b: Option<At>) -> Option<At> {
    match (a, b) {
        (Some(a), Some(b)) => Some(if a.value <= b.value { a } else { b }),
        (a, b) => a.or(b),
    }
}

/// The margins of loop `which` of `cfg` (f64 controllers) with `delay_ticks` of delay,
/// the other loop out of the way, on the full plant (case d) at the operating point of
/// `p`. Errors: as [`Laws::of`].
pub fn margins(
    p: &Params,
    cfg: &Config,
    delay_ticks: usize,
    which: Loop,
) -> Result<Margins, String> {
    let laws = Laws::of(cfg)?;
    margins_of(p, cfg.base_period(), delay_ticks, &laws, which, Other::Open)
}

/// The margins of loop `which` with the controllers `laws` at the base period `t0` (s)
/// and `delay_ticks` of delay, the other loop as `other` says, on the full plant (with
/// the yaw spring when no yaw law acts). Errors: no law for `which`, a plant or
/// loop whose eigenvalues do not converge.
pub fn margins_of(
    p: &Params,
    t0: f64,
    delay_ticks: usize,
    laws: &Laws,
    which: Loop,
    other: Other,
) -> Result<Margins, String> {
    let (this, that, o) = match which {
        Loop::Yaw => (&laws.yaw, &laws.traction, Loop::Traction),
        Loop::Traction => (&laws.traction, &laws.yaw, Loop::Yaw),
    };
    let this = this
        .as_ref()
        .ok_or_else(|| format!("margins: no {} law to judge", which.name()))?;
    let sprung = laws.yaw.is_none() || (which == Loop::Traction && other == Other::Open);
    let plant = Model::Full.plant(p, p.f11, p.lambda, sprung);
    plant_order(&plant)?;
    let (ad, bd) = zoh(&plant.a, &plant.b, t0);
    let a_aug = match (other, that) {
        (Other::Closed, Some(l)) => close(&ad, &bd, &plant.c, l, o, delay_ticks),
        _ => ad.clone(),
    };
    let (input, output, sign) = which.port();
    let dim = a_aug.nrows();
    let n = ad.nrows();
    let a_c = a_aug.map(|x| C64::new(x, 0.0));
    let b_c = DVector::from_fn(dim, |i, _| {
        C64::new(if i < n { bd[(i, input)] } else { 0.0 }, 0.0)
    });
    let c_c = DVector::from_fn(dim, |j, _| {
        C64::new(if j < n { plant.c[(output, j)] } else { 0.0 }, 0.0)
    });
    let resp = |z: C64| -> Option<C64> {
        let m = DMatrix::from_diagonal_element(dim, dim, z) - &a_c;
        Some(c_c.dot(&m.lu().solve(&b_c)?))
    };
    // Open-loop poles outside the contour that this loop's transfer function has: a pole
    // makes the response grow a thousandfold as `z` comes a thousand times closer; a mode
    // the loop neither drives nor sees does not.
    let eig = crate::finite::eigenvalues(&a_aug, "the sampled open loop")?;
    let growth = |l: C64, d: f64| resp(l * (1.0 + d)).map_or(f64::INFINITY, |v| v.norm());
    let p_count = eig
        .iter()
        .filter(|l| l.norm() > CONTOUR_RADIUS)
        .filter(|l| growth(**l, 1e-7) > 100.0 * growth(**l, 1e-4))
        .count();
    let l = |z: C64| -> C64 {
        let zi = 1.0 / z;
        let pl = resp(z).unwrap_or(C64::new(f64::NAN, f64::NAN));
        -sign * this.at(zi) * zi.powi(delay_ticks as i32) * pl
    };
    let half = sample_half_contour(&l, 2.0 * PI * 1e-3 * t0);
    Ok(read(&nyquist(&half, 1.0 / t0), p_count))
}

/// The plant `Ad` with loop `lp` (at port `o`) closed round it through `d` ticks of
/// delay: states `[x; s; h_1..h_d]` (plant, the controller in transposed direct form II,
/// the held actuations).
fn close(
    ad: &DMatrix<f64>,
    bd: &DMatrix<f64>,
    c: &DMatrix<f64>,
    lp: &Law,
    o: Loop,
    d: usize,
) -> DMatrix<f64> {
    let (input, output, sign) = o.port();
    let n = ad.nrows();
    let m = lp.den.len().max(lp.num.len()) - 1;
    let d = d.max(1);
    let coef = |v: &[f64], i: usize| v.get(i).copied().unwrap_or(0.0);
    let n0 = coef(&lp.num, 0);
    let dim = n + m + d;
    let mut out = DMatrix::zeros(dim, dim);
    out.view_mut((0, 0), (n, n)).copy_from(ad);
    out.view_mut((0, n + m + d - 1), (n, 1))
        .copy_from(&bd.column(input));
    // s+ = A_c s + B_c e, e = sign c x; h_1+ = C_c s + D e; h_k+ = h_(k-1).
    for i in 0..m {
        out[(n + i, n)] = -coef(&lp.den, i + 1);
        if i + 1 < m {
            out[(n + i, n + i + 1)] = 1.0;
        }
        let bc = coef(&lp.num, i + 1) - coef(&lp.den, i + 1) * n0;
        out.view_mut((n + i, 0), (1, n))
            .copy_from(&(c.row(output) * (bc * sign)));
    }
    if m > 0 {
        out[(n + m, n)] = 1.0;
    }
    out.view_mut((n + m, 0), (1, n))
        .copy_from(&(c.row(output) * (n0 * sign)));
    for k in 1..d {
        out[(n + m + k, n + m + k - 1)] = 1.0;
    }
    out
}

fn wrap(d: f64) -> f64 {
    let d = d.rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

/// `(w, L(r e^{jw}))` round the upper half of the contour, `w` 0 to pi rad per tick, refined
/// until successive samples of `L` and of `1 + L` turn by under 20 degrees.
fn sample_half_contour(l: &dyn Fn(C64) -> C64, w_min: f64) -> Vec<(f64, C64)> {
    let at = |w: f64| (w, l(C64::from_polar(CONTOUR_RADIUS, w)));
    let m = 2000;
    let mut ws = vec![0.0];
    ws.extend((0..m).map(|i| w_min * (PI / w_min).powf(i as f64 / m as f64)));
    ws.push(PI);
    let mut out = Vec::with_capacity(ws.len() * 2);
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

fn refine(
    at: &dyn Fn(f64) -> (f64, C64),
    a: (f64, C64),
    b: (f64, C64),
    depth: u32,
    out: &mut Vec<(f64, C64)>,
) {
    let one = C64::new(1.0, 0.0);
    let turn = |a: C64, b: C64| (b / a).arg().abs();
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

/// What the Nyquist plot says: `W`, the critical gain factors and the phase distances
/// `wrap(180 + arg L)` at the gain crossovers, each with its frequency (Hz).
struct Nyquist {
    encirclements: i64,
    critical: Vec<(f64, f64)>,
    crossovers: Vec<(f64, f64)>,
}

fn nyquist(half: &[(f64, C64)], fs: f64) -> Nyquist {
    let one = C64::new(1.0, 0.0);
    let hz = |w: f64| w * fs / (2.0 * PI);
    let mut turned = 0.0;
    let mut critical = Vec::new();
    let mut crossovers = Vec::new();
    // At w = 0 and w = pi, L is real: on the negative real axis it is a crossing.
    for e in [half.first(), half.last()].into_iter().flatten() {
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
        if (a.im > 0.0) != (b.im > 0.0) && a.im != b.im {
            let t = a.im / (a.im - b.im);
            let x = a.re + t * (b.re - a.re);
            if x < 0.0 {
                critical.push((-1.0 / x, hz(wa + t * (wb - wa))));
            }
        }
        let (ga, gb) = (a.norm().ln(), b.norm().ln());
        if (ga > 0.0) != (gb > 0.0) && ga != gb {
            let t = ga / (ga - gb);
            let ph = wrap(180.0 + a.arg().to_degrees() + t * wrap((b / a).arg().to_degrees()));
            crossovers.push((ph, hz(wa + t * (wb - wa))));
        }
    }
    // The lower half is the mirror image of the upper: twice the upper half's turns.
    Nyquist {
        encirclements: (turned / PI).round() as i64,
        critical,
        crossovers,
    }
}

/// The verdict and margins from the Nyquist plot, given `P`.
fn read(n: &Nyquist, p: usize) -> Margins {
    let stable = n.encirclements == p as i64;
    let at = |(value, hz): (f64, f64)| At { value, hz };
    let db = |c: &(f64, f64)| (20.0 * c.0.log10(), c.1);
    let pick = |v: Option<At>| v.filter(|_| stable);
    let pick_by = |list: &[(f64, f64)], keep: fn(f64) -> bool, min: bool| {
        let kept = list.iter().copied().filter(|c| keep(c.0));
        let cmp = |a: &(f64, f64), b: &(f64, f64)| a.0.total_cmp(&b.0);
        if min {
            kept.min_by(cmp)
        } else {
            kept.max_by(cmp)
        }
    };
    let gain_down = pick_by(&n.critical, |x| x < 1.0, false).map(|c| at(db(&c)));
    let gain_up = pick_by(&n.critical, |x| x > 1.0, true).map(|c| at(db(&c)));
    let phase_lag = pick_by(&n.crossovers, |x| x > 0.0, true).map(at);
    let phase_lead = pick_by(&n.crossovers, |x| x <= 0.0, false).map(|c| at((-c.0, c.1)));
    Margins {
        stable,
        open_loop_unstable: p,
        encirclements: n.encirclements,
        closed_loop_unstable: p as i64 - n.encirclements,
        gain_up: pick(gain_up),
        gain_down: pick(gain_down),
        phase_lag: pick(phase_lag),
        phase_lead: pick(phase_lead),
        phase: pick(smaller(phase_lag, phase_lead)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Each loop alone: the Nyquist count against the sampled closed loop's eigenvalues,
    /// over the lead's gain and the delay; a stable loop's margins bracket its gain.
    #[test]
    fn the_nyquist_verdict_is_the_eigenvalues_verdict() {
        let p = Params::default();
        let mut seen = (false, false);
        for d in [1usize, 2] {
            for k in [0.2, 0.5, 1.0, 1.5, 3.0] {
                let mut c = Config::default();
                c.lead.k *= k;
                c.delay_ticks = d as u8;
                let m = margins(&p, &c, d, Loop::Yaw).expect("margins");
                c.traction_enabled = false;
                let plant = Model::Full.plant(&p, p.f11, p.lambda, false);
                let eig = closed_loop(&plant, &c, d).expect("loop").stable();
                assert_eq!(m.stable, eig, "lead x{k}, {d} ticks: {m:?}");
                assert_eq!(m.closed_loop_unstable == 0, m.stable);
                if m.stable {
                    assert!(m.gain_up.is_none_or(|a| a.value > 0.0), "{m:?}");
                    assert!(m.gain_down.is_none_or(|a| a.value < 0.0), "{m:?}");
                    assert!(m.phase.is_none_or(|a| a.value > 0.0), "{m:?}");
                    seen.0 = true;
                } else {
                    assert!(m.gain_up.is_none() && m.phase.is_none(), "{m:?}");
                    seen.1 = true;
                }
            }
        }
        assert!(seen.0 && seen.1);
    }

    /// The traction loop alone is stable in open loop and reads as usual: no lower gain
    /// limit.
    #[test]
    fn the_traction_loop_has_no_lower_gain_limit() {
        let m = margins(&Params::default(), &Config::default(), 1, Loop::Traction).expect("m");
        assert!(
            m.stable && m.open_loop_unstable == 0 && m.encirclements == 0,
            "{m:?}"
        );
        assert!(m.gain_down.is_none() && m.gain_up.is_some() && m.phase.is_some());
    }
}
