//! Stability margins of the two loops after quantisation: the plant linearised about
//! straight track at pure rolling (`wheelset_plant::sampled::Model::Full`, the rate table's
//! plant), discretised exactly with a zero-order hold at the base period
//! (`wheelset_plant::sampled::zoh`), one period of actuation delay, and the controller as the
//! device holds it (quantised) or ideal (the f64 discretisation).
//!
//! Each loop is broken at its actuator with the other loop open (on straight track the
//! linearised lateral/yaw and drive dynamics do not couple):
//!
//! ```text
//! yaw:      L(z) = -C_y(z) z^-1 P_y(z),   P_y: T_psi -> y',  C_y = (T_fs/y'_fs) H(z) (1 + 2p (1 - z^-1))
//!           H(z) = K_hf (1 - h (1 + z^-1)/(1 - a z^-1)),  a = 1 - kappa,  h = kappa g/2
//! traction: L(z) =  C_i(z) z^-1 P_i(z),   P_i: u_a -> i_a,  C_i = (V_fs/I_fs)(Kp + Ki/(1 - z^-1))
//! ```
//!
//! (`T_psi = +C_y y'` acts through eq. 5's `-T_psi`, so the yaw loop's return ratio carries
//! the minus sign; the PI acts on `i_ref - i_a`.) On a log grid of 4000 frequencies from
//! 0.05 Hz to Nyquist: the **gain margin** at each phase crossover (`arg L = -180 deg`)
//! is `-20 log10 |L|`, reported at the crossover with the smallest `|margin|`; the
//! **phase margin** at each gain crossover (`|L| = 1`) is `180 + arg L` (wrapped to
//! `(-180, 180]`), the smallest in magnitude. The yaw plant is open-loop unstable without
//! the passive spring, so these are the classical crossover figures, not a Nyquist
//! verdict (the stability verdict is `sim-host rates`'s monodromy).

use serde::Serialize;
use wheelset_control::Config;
use wheelset_plant::params::Params;
use wheelset_plant::sampled::{zoh, Model};

use super::bounds::Quantised;
use super::response::C64;

/// One loop's margins, ideal vs quantised.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Margin {
    /// `yaw (lead)` or `traction (PI)`.
    #[serde(rename = "loop")]
    pub loop_name: String,
    /// Gain margin with the f64 controller, dB (`null`: no phase crossover).
    pub gain_db_ideal: Option<f64>,
    /// Gain margin with the quantised controller, dB.
    pub gain_db_quantised: Option<f64>,
    /// Phase margin with the f64 controller, degrees (`null`: no gain crossover).
    pub phase_deg_ideal: Option<f64>,
    /// Phase margin with the quantised controller, degrees.
    pub phase_deg_quantised: Option<f64>,
    /// Phase crossover frequency (quantised), Hz.
    pub phase_crossover_hz: Option<f64>,
    /// Gain crossover frequency (quantised), Hz.
    pub gain_crossover_hz: Option<f64>,
}

/// `C (zI - A)^-1 B` for one input column and one output row, by Gaussian elimination
/// with partial pivoting in complex arithmetic.
#[allow(clippy::needless_range_loop)]
fn freq_resp(a: &[Vec<f64>], b: &[f64], c: &[f64], z: C64) -> C64 {
    let n = a.len();
    let mut m: Vec<Vec<C64>> = (0..n)
        .map(|i| {
            let mut r: Vec<C64> = (0..n).map(|j| C64::new(-a[i][j], 0.0)).collect();
            r[i] = r[i].plus(z);
            r.push(C64::new(b[i], 0.0));
            r
        })
        .collect();
    for col in 0..n {
        let p = (col..n)
            .max_by(|&x, &y| m[x][col].abs().total_cmp(&m[y][col].abs()))
            .unwrap_or(col);
        m.swap(col, p);
        let piv = m[col][col];
        if piv.abs() == 0.0 {
            return C64::new(f64::NAN, f64::NAN);
        }
        for r in col + 1..n {
            let f = m[r][col].over(piv);
            if f.abs() == 0.0 {
                continue;
            }
            for k in col..=n {
                let v = m[col][k].times(f);
                m[r][k] = m[r][k].plus(v.scale(-1.0));
            }
        }
    }
    let mut x = vec![C64::new(0.0, 0.0); n];
    for i in (0..n).rev() {
        let mut s = m[i][n];
        for k in i + 1..n {
            s = s.plus(m[i][k].times(x[k]).scale(-1.0));
        }
        x[i] = s.over(m[i][i]);
    }
    x.iter()
        .zip(c)
        .fold(C64::new(0.0, 0.0), |acc, (v, ci)| acc.plus(v.scale(*ci)))
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

/// A margin and the frequency it is read at, Hz.
type Crossing = Option<(f64, f64)>;

/// `(gain margin dB, at Hz, phase margin deg, at Hz)` of `l` on the grid `f`.
fn margins_of(f: &[f64], l: &[C64]) -> (Crossing, Crossing) {
    let mut gm: Option<(f64, f64)> = None;
    let mut pm: Option<(f64, f64)> = None;
    for i in 1..l.len() {
        let (a, b) = (l[i - 1], l[i]);
        if !(a.abs().is_finite() && b.abs().is_finite()) {
            continue;
        }
        // Phase crossover: arg L passes -180 (the wrap point of atan2 at +-180).
        let (pa, pb) = (a.arg_deg(), b.arg_deg());
        if (pa - pb).abs() > 180.0 && a.re < 0.0 && b.re < 0.0 {
            let g = -20.0 * (0.5 * (a.abs() + b.abs())).log10();
            if gm.is_none_or(|(x, _)| g.abs() < x.abs()) {
                gm = Some((g, 0.5 * (f[i - 1] + f[i])));
            }
        }
        // Gain crossover.
        let (ga, gb) = (a.abs().log10(), b.abs().log10());
        if ga * gb <= 0.0 && ga != gb {
            let t = ga / (ga - gb);
            let ph = wrap(180.0 + pa + t * wrap(pb - pa));
            if pm.is_none_or(|(x, _)| ph.abs() < x.abs()) {
                pm = Some((ph, f[i - 1] + t * (f[i] - f[i - 1])));
            }
        }
    }
    (gm, pm)
}

/// The margins of the yaw (lead) and traction (PI) loops for `cfg` (one base period of
/// delay) at the operating point `p`, ideal (f64 coefficients) and quantised (`q`, as the device holds them).
pub fn margins(cfg: &Config, q: &Quantised, p: &Params) -> Result<Vec<Margin>, String> {
    let plant = Model::Full.plant(p, p.f11, p.lambda, false);
    let t0 = cfg.base_period();
    let (ad, bd) = zoh(&plant.a, &plant.b, t0);
    let n = ad.nrows();
    let a: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| ad[(i, j)]).collect())
        .collect();
    let col = |k: usize| -> Vec<f64> { (0..n).map(|i| bd[(i, k)]).collect() };
    let row = |r: usize| -> Vec<f64> { (0..n).map(|j| plant.c[(r, j)]).collect() };
    let (b_t, b_u) = (col(0), col(1));
    let (c_y, c_i) = (row(0), row(1));
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
    let m = 4000;
    let (f0, f1) = (0.05f64, 0.4999 * fs);
    let f: Vec<f64> = (0..m)
        .map(|i| f0 * (f1 / f0).powf(i as f64 / (m - 1) as f64))
        .collect();
    let yaw = |k: f64, g: f64, kap: f64, ph: f64| -> Vec<C64> {
        f.iter()
            .map(|&fr| {
                let zi = C64::expj(-2.0 * std::f64::consts::PI * fr * t0);
                let z = C64::new(1.0, 0.0).over(zi);
                let one = C64::new(1.0, 0.0);
                let h = kap * g;
                let lp = one.plus(zi).scale(h).over(one.plus(zi.scale(-(1.0 - kap))));
                let hz = one.plus(lp.scale(-1.0)).scale(k * s.torque / s.y_dot);
                let pred = one.plus(one.plus(zi.scale(-1.0)).scale(2.0 * ph));
                let pl = freq_resp(&a, &b_t, &c_y, z);
                hz.times(pred).times(zi).times(pl).scale(-1.0)
            })
            .collect()
    };
    let trac = |kp: f64, ki: f64| -> Vec<C64> {
        f.iter()
            .map(|&fr| {
                let zi = C64::expj(-2.0 * std::f64::consts::PI * fr * t0);
                let z = C64::new(1.0, 0.0).over(zi);
                let one = C64::new(1.0, 0.0);
                let c = C64::new(kp, 0.0)
                    .plus(C64::new(ki, 0.0).over(one.plus(zi.scale(-1.0))))
                    .scale(s.voltage / s.current);
                let pl = freq_resp(&a, &b_u, &c_i, z);
                c.times(zi).times(pl)
            })
            .collect()
    };
    let (yi_g, yi_p) = margins_of(
        &f,
        &yaw(
            ideal_lead.k_hf,
            ideal_lead.g_half,
            ideal_lead.kappa,
            ideal_ph,
        ),
    );
    let (yq_g, yq_p) = margins_of(&f, &yaw(q.lead.k_hf, q.lead.g_half, q.lead.kappa, q.ph));
    let (ti_g, ti_p) = margins_of(&f, &trac(ideal_pi.kp, ideal_pi.ki));
    let (tq_g, tq_p) = margins_of(&f, &trac(q.kp, q.ki));
    let mk =
        |n: &str, gi: Option<(f64, f64)>, gq: Option<(f64, f64)>, pi, pq: Option<(f64, f64)>| {
            let pi: Option<(f64, f64)> = pi;
            Margin {
                loop_name: n.into(),
                gain_db_ideal: gi.map(|x| x.0),
                gain_db_quantised: gq.map(|x| x.0),
                phase_deg_ideal: pi.map(|x| x.0),
                phase_deg_quantised: pq.map(|x| x.0),
                phase_crossover_hz: gq.map(|x| x.1),
                gain_crossover_hz: pq.map(|x| x.1),
            }
        };
    Ok(vec![
        mk("yaw (lead)", yi_g, yq_g, yi_p, yq_p),
        mk("traction (PI)", ti_g, tq_g, ti_p, tq_p),
    ])
}
