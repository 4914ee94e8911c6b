//! The loop matrices and their modes, sampled and continuous.

use super::*;
use nalgebra::{Complex, DMatrix};
use wheelset_control::{Config, YawMode};

/// Exact zero-order-hold discretisation: `(Ad, Bd)` from `exp([[A, B], [0, 0]] t)`.
pub fn zoh(a: &DMatrix<f64>, b: &DMatrix<f64>, t: f64) -> (DMatrix<f64>, DMatrix<f64>) {
    let n = a.nrows();
    let m = b.ncols();
    let mut aug = DMatrix::<f64>::zeros(n + m, n + m);
    aug.view_mut((0, 0), (n, n)).copy_from(&(a * t));
    aug.view_mut((0, n), (n, m)).copy_from(&(b * t));
    let e = aug.exp();
    (
        e.view((0, 0), (n, n)).into_owned(),
        e.view((0, n), (n, m)).into_owned(),
    )
}

/// The order `n` of `plant`, checked: `A` n x n, `B` n x 2, `C` 3 x n.
pub(crate) fn plant_order(plant: &LinearPlant) -> Result<usize, String> {
    let n = plant.a.nrows();
    if plant.a.ncols() != n || plant.b.shape() != (n, 2) || plant.c.shape() != (3, n) {
        return Err(format!(
            "plant shapes: A {:?}, B {:?}, C {:?}; want n x n, n x 2, 3 x n",
            plant.a.shape(),
            plant.b.shape(),
            plant.c.shape()
        ));
    }
    Ok(n)
}

/// The lead at the yaw period and the PI at the traction period of `cfg` (f64).
pub(crate) fn discretised(
    cfg: &Config,
) -> Result<(wheelset_control::LeadDiscrete, wheelset_control::PiDiscrete), String> {
    let lead = cfg
        .lead
        .discretise(cfg.yaw_period())
        .map_err(|e| e.to_string())?;
    let pi = cfg
        .pi
        .discretise(cfg.traction_period())
        .map_err(|e| e.to_string())?;
    Ok((lead, pi))
}

/// One closed-loop mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Mode {
    /// Eigenvalue of the monodromy matrix (one hyper-period).
    pub mu: Complex<f64>,
    /// Equivalent continuous eigenvalue `ln(mu)/(L T0)`, 1/s.
    pub s: Complex<f64>,
    /// `|Im s|/(2 pi)`, Hz.
    pub freq_hz: f64,
    /// `-Re s/|s|` (1 for a real stable pole, negative when unstable).
    pub zeta: f64,
    /// `|mu|^(1/L)`: contraction per base tick.
    pub radius: f64,
}

/// The closed loop's modes and verdict.
#[derive(Debug, Clone)]
pub struct ClosedLoop {
    /// All modes but the free-rolling ones (nearest `mu = 1`), sorted by decreasing radius.
    pub modes: Vec<Mode>,
    /// Largest radius per base tick among `modes` (< 1: stable).
    pub spectral_radius: f64,
    /// The least damped oscillatory mode (or the slowest real one).
    pub worst: Mode,
}

impl ClosedLoop {
    /// Stable: spectral radius below 1.
    pub fn stable(&self) -> bool {
        self.spectral_radius < 1.0
    }
}

/// Largest hyper-period (ticks) and delay the analysis accepts.
pub const MAX_HYPER_PERIOD: usize = 1000;

/// The per-tick loop matrices `M_0 .. M_{L-1}` over one hyper-period (`X` as in the
/// module docs); no traction when it is off or the plant has no drive.
pub fn tick_matrices(
    plant: &LinearPlant,
    cfg: &Config,
    delay_ticks: usize,
) -> Result<Vec<DMatrix<f64>>, String> {
    cfg.validate().map_err(|e| e.to_string())?;
    let n = plant_order(plant)?;
    let traction = cfg.traction_enabled && plant.c.row(1).iter().any(|v| *v != 0.0);
    let (yaw_div, tr_div) = (cfg.yaw_divisor as usize, cfg.traction_divisor as usize);
    let t0 = 1.0 / cfg.base_rate_hz as f64;
    crate::finite::check_finite(&plant.a, "the plant matrix A")?;
    crate::finite::check_finite(&plant.b, "the plant matrix B")?;
    let (ad, bd) = zoh(&plant.a, &plant.b, t0);
    crate::finite::check_finite(&ad, "the discretised plant matrix Ad")?;
    crate::finite::check_finite(&bd, "the discretised plant matrix Bd")?;
    let (lead, pi) = discretised(cfg)?;
    let d = delay_ticks;
    let nreg = d.max(1); // output registers o[k-1] .. o[k-nreg], 2 each
    let ir = n; // registers start
    let il = ir + 2 * nreg; // lead x1, z
    let ii = il + 2; // PI integrator
    let ip = ii + 1; // the predictor's y'[n-1]
    let nx = ip + 1;
    // Delay compensation: x = (1 + alpha) y' - alpha y'[n-1] feeds the yaw law.
    let alpha = cfg.yaw_predict_ticks / cfg.yaw_divisor as f64;
    let cy = plant.c.row(0);
    let ci = plant.c.row(1);

    // New outputs as rows over X: T (row 0) and u (row 1), plus the lead's update.
    let mut t_row = DMatrix::<f64>::zeros(1, nx);
    let mut lead_upd = DMatrix::<f64>::zeros(2, nx); // x1', z'
    match cfg.yaw_mode {
        YawMode::Passive => {}
        YawMode::Gain => {
            let k = cfg.gain_k * (1.0 + alpha);
            t_row.view_mut((0, 0), (1, n)).copy_from(&(cy * k));
            t_row[(0, ip)] = -cfg.gain_k * alpha;
        }
        YawMode::Lead => {
            let h = lead.kappa * lead.g / 2.0;
            for j in 0..n {
                t_row[(0, j)] = lead.k_hf * (1.0 - h) * (1.0 + alpha) * cy[j];
                lead_upd[(0, j)] = (1.0 + alpha) * cy[j];
                lead_upd[(1, j)] = h * (1.0 + alpha) * cy[j];
            }
            t_row[(0, ip)] = -lead.k_hf * (1.0 - h) * alpha;
            lead_upd[(0, ip)] = -alpha;
            lead_upd[(1, ip)] = -h * alpha;
            t_row[(0, il)] = -lead.k_hf * h;
            t_row[(0, il + 1)] = -lead.k_hf * (1.0 - lead.kappa);
            lead_upd[(1, il)] = h;
            lead_upd[(1, il + 1)] = 1.0 - lead.kappa;
        }
    }
    let mut u_row = DMatrix::<f64>::zeros(1, nx);
    let mut i_upd = DMatrix::<f64>::zeros(1, nx);
    if traction {
        for j in 0..n {
            u_row[(0, j)] = -(pi.kp + pi.ki) * ci[j];
            i_upd[(0, j)] = -pi.ki * ci[j];
        }
        u_row[(0, ii)] = 1.0;
        i_upd[(0, ii)] = 1.0;
    }

    let l = num_integer::lcm(yaw_div, tr_div);
    if l > MAX_HYPER_PERIOD {
        return Err(format!(
            "hyper-period lcm(yaw_divisor {}, traction_divisor {}) = {l} ticks: at most {MAX_HYPER_PERIOD}",
            yaw_div, tr_div
        ));
    }
    if delay_ticks > MAX_HYPER_PERIOD {
        return Err(format!(
            "delay {delay_ticks} ticks: at most {MAX_HYPER_PERIOD}"
        ));
    }
    let mut mats = Vec::with_capacity(l);
    for k in 0..l {
        let yaw = k % yaw_div == 0;
        let tr = k % tr_div == 0;
        // o[k] as rows over X (new or held register 0).
        let mut o = DMatrix::<f64>::zeros(2, nx);
        if yaw {
            o.row_mut(0).copy_from(&t_row.row(0));
        } else {
            o[(0, ir)] = 1.0;
        }
        if tr {
            o.row_mut(1).copy_from(&u_row.row(0));
        } else {
            o[(1, ir + 1)] = 1.0;
        }
        // Applied input during this tick.
        let applied = if d == 0 {
            o.clone()
        } else {
            let mut a = DMatrix::<f64>::zeros(2, nx);
            a[(0, ir + 2 * (d - 1))] = 1.0;
            a[(1, ir + 2 * (d - 1) + 1)] = 1.0;
            a
        };
        let mut m = DMatrix::<f64>::zeros(nx, nx);
        // x' = Ad x + Bd applied
        m.view_mut((0, 0), (n, n)).copy_from(&ad);
        let bx = &bd * &applied;
        let mut top = m.view_mut((0, 0), (n, nx));
        top += &bx;
        // registers: r0' = o[k], r_j' = r_{j-1}
        m.view_mut((ir, 0), (2, nx)).copy_from(&o);
        for j in 1..nreg {
            m[(ir + 2 * j, ir + 2 * (j - 1))] = 1.0;
            m[(ir + 2 * j + 1, ir + 2 * (j - 1) + 1)] = 1.0;
        }
        // lead (an unused lead or PI state is zeroed, not held: it affects no output, and
        // held it would add a spurious mu = 1)
        if cfg.yaw_mode == YawMode::Lead {
            if yaw {
                m.view_mut((il, 0), (2, nx)).copy_from(&lead_upd);
            } else {
                m[(il, il)] = 1.0;
                m[(il + 1, il + 1)] = 1.0;
            }
        }
        // predictor state: y'[n-1] <- y' on yaw ticks (zeroed in passive mode)
        if cfg.yaw_mode != YawMode::Passive {
            if yaw {
                m.view_mut((ip, 0), (1, n)).copy_from(&cy);
            } else {
                m[(ip, ip)] = 1.0;
            }
        }
        // PI
        if traction {
            if tr {
                m.view_mut((ii, 0), (1, nx)).copy_from(&i_upd);
            } else {
                m[(ii, ii)] = 1.0;
            }
        }
        mats.push(m);
    }
    Ok(mats)
}

/// The monodromy's modes of `plant` closed by `cfg`'s controllers with `delay_ticks` of delay.
pub fn closed_loop(
    plant: &LinearPlant,
    cfg: &Config,
    delay_ticks: usize,
) -> Result<ClosedLoop, String> {
    let mats = tick_matrices(plant, cfg, delay_ticks)?;
    let l = mats.len();
    let t0 = 1.0 / cfg.base_rate_hz as f64;
    let nx = mats[0].nrows();
    let phi = mats
        .iter()
        .fold(DMatrix::<f64>::identity(nx, nx), |acc, m| m * acc);
    let th = l as f64 * t0;
    let mut modes: Vec<Mode> = crate::finite::eigenvalues(&phi, "the monodromy matrix")?
        .iter()
        .map(|&mu| {
            let s = if mu.norm() > 0.0 {
                mu.ln() / th
            } else {
                Complex::new(f64::NEG_INFINITY, 0.0)
            };
            let zeta = if s.norm().is_finite() && s.norm() > 0.0 {
                -s.re / s.norm()
            } else {
                1.0
            };
            Mode {
                mu,
                s,
                freq_hz: s.im.abs() / (2.0 * std::f64::consts::PI),
                zeta,
                radius: mu.norm().powf(1.0 / l as f64),
            }
        })
        .collect();
    // Leave out as many modes nearest mu = 1 as the continuous loop has zero eigenvalues.
    let nz = count_zeros(&continuous_closed_loop_all(plant, cfg));
    modes.sort_by(|a, b| (a.mu - 1.0).norm().total_cmp(&(b.mu - 1.0).norm()));
    modes.drain(..nz.min(modes.len()));
    modes.sort_by(|a, b| b.radius.total_cmp(&a.radius));
    let spectral_radius = modes.first().map_or(0.0, |m| m.radius);
    let worst = modes
        .iter()
        .filter(|m| m.freq_hz > 1e-6 && m.radius > 1e-6)
        .min_by(|a, b| {
            a.zeta
                .partial_cmp(&b.zeta)
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .or(modes.first())
        .copied()
        .unwrap_or(Mode {
            mu: Complex::new(0.0, 0.0),
            s: Complex::new(f64::NEG_INFINITY, 0.0),
            freq_hz: 0.0,
            zeta: 1.0,
            radius: 0.0,
        });
    Ok(ClosedLoop {
        modes,
        spectral_radius,
        worst,
    })
}

/// The continuous closed loop's eigenvalues, free rolling removed (one NaN if not finite).
pub fn continuous_closed_loop(plant: &LinearPlant, cfg: &Config) -> Vec<Complex<f64>> {
    let mut ev: Vec<Complex<f64>> = continuous_closed_loop_all(plant, cfg);
    let nz = count_zeros(&ev);
    ev.sort_by(|x, y| x.norm().total_cmp(&y.norm()));
    ev.drain(..nz.min(ev.len()));
    ev
}

/// The continuous closed-loop state matrix: plant, lead state (if used), PI state (if
/// used and the plant has a current output).
pub fn continuous_matrix(plant: &LinearPlant, cfg: &Config) -> DMatrix<f64> {
    let n = plant.a.nrows();
    let lead = cfg.yaw_mode == YawMode::Lead;
    let pi = cfg.traction_enabled && plant.c.row(1).iter().any(|v| *v != 0.0);
    // States: x, lead state w if used (Ks = K_hf (1 - g w2/(s + w2)):
    // w' = -w2 w + g w2 y', T = K_hf (y' - w)), PI state q if used (u = -Kp i + q,
    // q' = -(Kp/Ti) i).
    let iw = n;
    let iq = n + lead as usize;
    let nx = iq + pi as usize;
    let mut a = DMatrix::<f64>::zeros(nx, nx);
    a.view_mut((0, 0), (n, n)).copy_from(&plant.a);
    let cy = plant.c.row(0).into_owned();
    let ci = plant.c.row(1).into_owned();
    let bt = plant.b.column(0).into_owned();
    let bu = plant.b.column(1).into_owned();
    let p = &cfg.lead;
    let (k_hf, g, w2) = (p.k * p.a, (p.w2 - p.w1) / p.w2, p.w2);
    let mut t_row = DMatrix::<f64>::zeros(1, nx);
    match cfg.yaw_mode {
        YawMode::Passive => {}
        YawMode::Gain => t_row
            .view_mut((0, 0), (1, n))
            .copy_from(&(&cy * cfg.gain_k)),
        YawMode::Lead => {
            t_row.view_mut((0, 0), (1, n)).copy_from(&(&cy * k_hf));
            t_row[(0, iw)] = -k_hf;
            a.view_mut((iw, 0), (1, n)).copy_from(&(&cy * (g * w2)));
            a[(iw, iw)] = -w2;
        }
    }
    let mut u_row = DMatrix::<f64>::zeros(1, nx);
    if pi {
        u_row
            .view_mut((0, 0), (1, n))
            .copy_from(&(&ci * -cfg.pi.kp));
        u_row[(0, iq)] = 1.0;
        a.view_mut((iq, 0), (1, n))
            .copy_from(&(&ci * (-cfg.pi.kp / cfg.pi.ti)));
    }
    let fb = &bt * &t_row + &bu * &u_row;
    let mut top = a.view_mut((0, 0), (n, nx));
    top += &fb;
    a
}

/// How many of `ev` are zero to working precision (`|s| < 1e-9 max |s|`).
fn count_zeros(ev: &[Complex<f64>]) -> usize {
    let scale = ev.iter().map(|e| e.norm()).fold(1.0, f64::max);
    ev.iter().filter(|e| e.norm() < 1e-9 * scale).count()
}

fn continuous_closed_loop_all(plant: &LinearPlant, cfg: &Config) -> Vec<Complex<f64>> {
    crate::finite::eigenvalues(&continuous_matrix(plant, cfg), "the continuous loop")
        .unwrap_or_else(|_| vec![Complex::new(f64::NAN, 0.0)])
}

/// Damping ratio of a continuous eigenvalue (`1` for a real stable one).
pub fn zeta_of(s: Complex<f64>) -> f64 {
    if s.norm() > 0.0 {
        -s.re / s.norm()
    } else {
        0.0
    }
}
