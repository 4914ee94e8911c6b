//! Sampled-data stability of the loops as the firmware runs them: the plant discretised
//! exactly with a zero-order hold, one base period (or `delay_ticks`) of computation and
//! transport delay on the actuation, and the controllers of `wheelset-control` with the
//! f64 coefficients it computes, each loop at its own divisor of the base rate.
//!
//! # Method
//!
//! Continuous plant `x' = A x + B u`, `u = [T_psi (N m), u_a (V)]`, measured
//! `y = C x = [y' (m/s), i_a (A), theta_m' (rad/s)]`, linearised about straight track at
//! pure rolling. Over one base period `T0` with `u` held:
//!
//! ```text
//! exp([[A, B], [0, 0]] T0) = [[Ad, Bd], [0, I]]          (exact ZOH, nalgebra's expm)
//! ```
//!
//! Tick `k` samples `y[k] = C x[k]`; a loop that runs on tick `k` computes its new output
//! `o[k]` (the lead or gain on the predicted `y'_p = y' + alpha (y'[n] - y'[n-1])`,
//! `alpha = yaw_predict_ticks/yaw_divisor`; the PI on `-i_a`: small-signal deviations,
//! so the limits and the reference drop out); a loop that does not run holds `o[k-1]`. With
//! `delay_ticks = d` the plant sees `o[k-d]` during `[k T0, (k+1) T0)`: `d = 1` is the
//! firmware (the Actuation frame computed from the Sensor frame of tick `k` is applied
//! at the next tick boundary); `d = 0` the ideal ZOH without delay, for comparison.
//!
//! The loop state `X = [x; o[k-1], .., o[k-max(d,1)]; lead x1, z; PI I; y'[n-1]]` evolves by a
//! tick-dependent matrix `M_k`; the loop is periodic with the hyper-period
//! `L = lcm(yaw_divisor, traction_divisor)` ticks, and stable iff every eigenvalue `mu`
//! of the monodromy `Phi = M_{L-1} ... M_0` is inside the unit circle. Each is reported
//! as an equivalent continuous mode `s = ln(mu)/(L T0)`: frequency `|Im s|/2 pi`,
//! damping `zeta = -Re s/|s|`, and the spectral radius per base tick `|mu|^(1/L)`.
//!
//! Free rolling at any speed is an equilibrium of the loop (with the current held by the
//! PI; open loop the back-EMF brakes it): the continuous closed loop's zero eigenvalues
//! map to `mu = 1`; the same number of eigenvalues nearest `mu = 1` are left out of the
//! verdict and reported as excluded.

use crate::linear::linear_plant;
use crate::params::Params;
use crate::plant::PlantConfig;
use crate::scenario::Axle;
use nalgebra::{Complex, DMatrix};
use serde_json::{json, Value};
use wheelset_control::{Config, YawMode};

/// A linear plant `x' = A x + B u`, `y = C x`.
#[derive(Debug, Clone)]
pub struct LinearPlant {
    /// `n x n`.
    pub a: DMatrix<f64>,
    /// `n x 2`: columns `T_psi` (N m, eq. 5 sign), `u_a` (V).
    pub b: DMatrix<f64>,
    /// `3 x n`: rows `y'` (m/s), `i_a` (A), `theta_m'` (rad/s).
    pub c: DMatrix<f64>,
}

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
    /// All modes, excluded ones removed, sorted by decreasing radius.
    pub modes: Vec<Mode>,
    /// The free-rolling modes left out (nearest `mu = 1`).
    pub excluded: Vec<Mode>,
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

/// Loop timing: the base rate, the divisors and the actuation delay.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Timing {
    /// Base rate, Hz.
    pub base_hz: f64,
    /// Yaw loop every `yaw_divisor` ticks.
    pub yaw_divisor: usize,
    /// Traction loop every `traction_divisor` ticks.
    pub traction_divisor: usize,
    /// Ticks between sampling and applying (1 for the firmware).
    pub delay_ticks: usize,
}

impl Timing {
    /// The timing of a controller configuration with `delay_ticks` of delay.
    pub fn of(cfg: &Config, delay_ticks: usize) -> Self {
        Self {
            base_hz: cfg.base_rate_hz as f64,
            yaw_divisor: cfg.yaw_divisor as usize,
            traction_divisor: cfg.traction_divisor as usize,
            delay_ticks,
        }
    }
}

fn gcd(a: usize, b: usize) -> usize {
    if b == 0 {
        a
    } else {
        gcd(b, a % b)
    }
}

/// The per-tick loop matrices `M_0 .. M_{L-1}` over one hyper-period (see the module
/// docs for the layout of `X`). Traction is left out when `cfg.traction_enabled` is off
/// or the plant has no current output (no drive).
///
/// Errors: the configuration is invalid (`Config::validate`), or `plant` has the wrong
/// shape.
pub fn tick_matrices(
    plant: &LinearPlant,
    cfg: &Config,
    delay_ticks: usize,
) -> Result<Vec<DMatrix<f64>>, String> {
    cfg.validate().map_err(|e| e.to_string())?;
    let n = plant.a.nrows();
    if plant.a.ncols() != n || plant.b.shape() != (n, 2) || plant.c.shape() != (3, n) {
        return Err(format!(
            "plant shapes: A {:?}, B {:?}, C {:?}; want n x n, n x 2, 3 x n",
            plant.a.shape(),
            plant.b.shape(),
            plant.c.shape()
        ));
    }
    let traction = cfg.traction_enabled && plant.c.row(1).iter().any(|v| *v != 0.0);
    let tm = Timing::of(cfg, delay_ticks);
    let t0 = 1.0 / tm.base_hz;
    crate::numeric::check_finite(&plant.a, "the plant matrix A")?;
    crate::numeric::check_finite(&plant.b, "the plant matrix B")?;
    let (ad, bd) = zoh(&plant.a, &plant.b, t0);
    crate::numeric::check_finite(&ad, "the discretised plant matrix Ad")?;
    crate::numeric::check_finite(&bd, "the discretised plant matrix Bd")?;
    let lead = cfg
        .lead
        .discretise(cfg.yaw_period())
        .map_err(|e| e.to_string())?;
    let pi = cfg
        .pi
        .discretise(cfg.traction_period())
        .map_err(|e| e.to_string())?;
    // Layout of X.
    let d = tm.delay_ticks;
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
            for j in 0..n {
                t_row[(0, j)] = cfg.gain_k * (1.0 + alpha) * cy[j];
            }
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

    let l = tm.yaw_divisor / gcd(tm.yaw_divisor, tm.traction_divisor) * tm.traction_divisor;
    if l > MAX_HYPER_PERIOD {
        return Err(format!(
            "hyper-period lcm(yaw_divisor {}, traction_divisor {}) = {l} ticks: at most {MAX_HYPER_PERIOD}",
            tm.yaw_divisor, tm.traction_divisor
        ));
    }
    if delay_ticks > MAX_HYPER_PERIOD {
        return Err(format!(
            "delay {delay_ticks} ticks: at most {MAX_HYPER_PERIOD}"
        ));
    }
    let mut mats = Vec::with_capacity(l);
    for k in 0..l {
        let yaw = k % tm.yaw_divisor == 0;
        let tr = k % tm.traction_divisor == 0;
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
                for j in 0..n {
                    m[(ip, j)] = cy[j];
                }
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

/// Close the loop of `plant` with the controllers of `cfg` (its yaw mode, lead, gain, PI,
/// traction on/off, rates) and `delay_ticks` of delay; monodromy eigenvalues.
///
/// Errors: as [`tick_matrices`].
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
    let mut modes: Vec<Mode> = crate::numeric::eigenvalues(&phi, "the monodromy matrix")?
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
    // Leave out the free-rolling modes: as many as the continuous loop has zero
    // eigenvalues, nearest mu = 1.
    let nz = free_rolling_modes(plant, cfg);
    modes.sort_by(|a, b| {
        (a.mu - 1.0)
            .norm()
            .partial_cmp(&(b.mu - 1.0).norm())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    let excluded: Vec<Mode> = modes.drain(..nz.min(modes.len())).collect();
    // Drop the structurally zero eigenvalues of unused controller states (mu = 0 exactly
    // is fine to keep: radius 0).
    modes.sort_by(|a, b| {
        b.radius
            .partial_cmp(&a.radius)
            .unwrap_or(std::cmp::Ordering::Equal)
    });
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
        excluded,
        spectral_radius,
        worst,
    })
}

/// The continuous closed loop (no sampling): plant + continuous lead/gain + continuous
/// PI, for comparison. Returns the eigenvalues (free-rolling ones removed).
///
/// A matrix with a non-finite entry is not passed to the solver: the result is then one
/// NaN eigenvalue (neither stable nor unstable; [`rates`] refuses such a plant first).
pub fn continuous_closed_loop(plant: &LinearPlant, cfg: &Config) -> Vec<Complex<f64>> {
    let mut ev: Vec<Complex<f64>> = continuous_closed_loop_all(plant, cfg);
    let nz = count_zeros(&ev);
    ev.sort_by(|x, y| {
        x.norm()
            .partial_cmp(&y.norm())
            .unwrap_or(std::cmp::Ordering::Equal)
    });
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

/// The number of free-rolling modes of the loop: zero eigenvalues of the continuous
/// closed loop (with the current held by the PI, free rolling at any speed is an
/// equilibrium; open loop the back-EMF brakes it, so `A` alone may have none).
pub fn free_rolling_modes(plant: &LinearPlant, cfg: &Config) -> usize {
    let ev = continuous_closed_loop_all(plant, cfg);
    count_zeros(&ev)
}

fn continuous_closed_loop_all(plant: &LinearPlant, cfg: &Config) -> Vec<Complex<f64>> {
    crate::numeric::eigenvalues(&continuous_matrix(plant, cfg), "the continuous loop")
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

/// The armature circuit alone at constant motor speed, `L_a i' = u_a - R_a i_a` (the
/// back-EMF is a constant bias): the current loop's plant.
pub fn armature(l_a: f64, r_a: f64) -> LinearPlant {
    let a = DMatrix::from_element(1, 1, -r_a / l_a);
    let mut b = DMatrix::<f64>::zeros(1, 2);
    b[(0, 1)] = 1.0 / l_a;
    let mut c = DMatrix::<f64>::zeros(3, 1);
    c[(1, 0)] = 1.0;
    LinearPlant { a, b, c }
}

/// The reduced plant: the lateral/yaw dynamics of case (a) (rigid axle, straight
/// track, speed constant, eqs. 4-5 linearised; no yaw spring, the active modes replace
/// it; with the spring for [`YawMode::Passive`]) and the armature circuit at constant
/// motor speed (eq. 9). States `[y, y', psi, psi', i_a]`. For cross-checks and quick
/// looks; the rate table uses the full linearisation by default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reduced {
    /// Creep coefficients f11 = f22, N.
    pub creep: f64,
    /// Conicity.
    pub lambda: f64,
    /// Include the passive yaw spring `k_yaw psi`.
    pub yaw_spring: bool,
}

impl Reduced {
    /// Build the linear plant with the parameters of `docs/model.md` (defaults).
    pub fn plant(&self) -> LinearPlant {
        self.plant_with(&Params::default())
    }

    /// Build the linear plant with parameters `p` (creep and conicity from `self`).
    pub fn plant_with(&self, p: &Params) -> LinearPlant {
        let (m, j, c_lat, k_lat, k_yaw) = (p.m, p.j, p.c_lat, p.k_lat, p.k_yaw);
        let (lg, r0, v) = (p.l_g, p.r0, p.v);
        let (la, ra) = (p.l_a, p.r_a);
        let f = self.creep;
        let mut a = DMatrix::<f64>::zeros(5, 5);
        a[(0, 1)] = 1.0;
        // m y'' = -(2 f22/v + c_lat) y' - k_lat y + 2 f22 psi
        a[(1, 0)] = -k_lat / m;
        a[(1, 1)] = -(2.0 * f / v + c_lat) / m;
        a[(1, 2)] = 2.0 * f / m;
        a[(2, 3)] = 1.0;
        // J psi'' = -2 f11 Lg^2 psi'/v - 2 Lg f11 lambda y / r0 - T_psi (- k_yaw psi)
        a[(3, 0)] = -2.0 * lg * f * self.lambda / r0 / j;
        a[(3, 3)] = -2.0 * f * lg * lg / v / j;
        if self.yaw_spring {
            a[(3, 2)] = -k_yaw / j;
        }
        // L i' = u - R i (back-EMF constant: a bias)
        a[(4, 4)] = -ra / la;
        let mut b = DMatrix::<f64>::zeros(5, 2);
        b[(3, 0)] = -1.0 / j;
        b[(4, 1)] = 1.0 / la;
        let mut c = DMatrix::<f64>::zeros(3, 5);
        c[(0, 1)] = 1.0;
        c[(1, 4)] = 1.0;
        LinearPlant { a, b, c }
    }
}

/// Creep coefficients of the robustness grid (f11 = f22), N.
pub const CREEP_GRID: [f64; 6] = [1e6, 2e6, 3e6, 5e6, 7e6, 10e6];
/// Conicities of the robustness grid.
pub const CONICITY_GRID: [f64; 5] = [0.05, 0.1, 0.2, 0.3, 0.4];
/// The nominal point (docs/model.md defaults): 10 MN, conicity 0.2.
pub const NOMINAL: (f64, f64) = (10e6, 0.2);

/// Link budget assumptions: a Sensor frame in, an Actuation frame out, sequential within
/// one period (the reply must be back before the next tick for one period of delay),
/// evaluated by the one link budget, [`wheelset_proto::link`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LinkBudget {
    /// Sensor frame bytes on the wire (`wheelset_proto::SENSOR_ONE_LATERAL_MAX_FRAME`).
    pub bytes_in: u32,
    /// Actuation frame bytes (`wheelset_proto::ACTUATION_MAX_FRAME`).
    pub bytes_out: u32,
    /// One-way latency, ns; the round trip takes it twice (5 us: 10 us per period of
    /// device computation and turnaround).
    pub latency_ns: u64,
    /// Largest acceptable share of the period, permille (the design target,
    /// [`wheelset_proto::link::LINK_SHARE_WARN_PERMILLE`]).
    pub share_permille: u32,
    /// The baud the table quotes utilisation at.
    pub baud: u32,
}

impl Default for LinkBudget {
    fn default() -> Self {
        Self {
            bytes_in: wheelset_proto::SENSOR_ONE_LATERAL_MAX_FRAME as u32,
            bytes_out: wheelset_proto::ACTUATION_MAX_FRAME as u32,
            latency_ns: 5_000,
            share_permille: wheelset_proto::link::LINK_SHARE_WARN_PERMILLE,
            baud: 2_000_000,
        }
    }
}

impl LinkBudget {
    /// Fraction of the period `1/base_hz` the round trip takes at `baud`
    /// ([`wheelset_proto::link::round_trip_ns`]).
    pub fn utilisation(&self, base_hz: f64, baud: f64) -> f64 {
        let rt = wheelset_proto::link::round_trip_ns(
            baud as u32,
            self.bytes_in,
            self.bytes_out,
            self.latency_ns,
        );
        rt as f64 * base_hz / 1e9
    }
    /// The smallest baud that keeps the round trip within `share_permille`
    /// ([`wheelset_proto::link::min_baud`]; infinite if none does).
    pub fn min_baud(&self, base_hz: f64) -> f64 {
        wheelset_proto::link::min_baud(
            base_hz as u32,
            self.bytes_in,
            self.bytes_out,
            self.latency_ns,
            self.share_permille,
        )
        .map_or(f64::INFINITY, f64::from)
    }
    /// [`Self::share_permille`] as a fraction.
    pub fn max_utilisation(&self) -> f64 {
        f64::from(self.share_permille) / 1000.0
    }
}

/// Where on the grid, and which mode.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GridMode {
    /// Creep coefficient, N.
    pub creep: f64,
    /// Conicity.
    pub lambda: f64,
    /// The mode.
    pub freq_hz: f64,
    /// Its damping ratio.
    pub zeta: f64,
}

/// One row of the rate table.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RateRow {
    /// Base rate, Hz.
    pub base_hz: u32,
    /// Yaw divisor.
    pub yaw_divisor: u16,
    /// Traction divisor.
    pub traction_divisor: u16,
    /// Delay, ticks.
    pub delay_ticks: usize,
    /// Current loop (armature + PI alone): radius per base tick of its fast mode.
    pub current_radius: f64,
    /// Current loop: damping ratio of its fast mode (continuous: 1, real pole).
    pub current_zeta: f64,
    /// Least-damped mode of the sampled loop over the grid.
    pub worst_sampled: GridMode,
    /// Least-damped mode of the continuous loop over the grid.
    pub worst_continuous: GridMode,
    /// Least-damped sampled mode over the grid points where the continuous loop is
    /// stable (the region the rate is responsible for).
    pub worst_sampled_stable_region: GridMode,
    /// Largest damping loss `zeta_cont - zeta_sampled` of the worst modes, per grid point.
    pub max_damping_loss: f64,
    /// Grid points stable in continuous time but unstable sampled.
    pub newly_unstable: usize,
    /// Grid points unstable in continuous time already (the control law's own limit).
    pub unstable_continuous: usize,
    /// Worst sampled damping at the nominal point.
    pub nominal_zeta: f64,
    /// Spectral radius per base tick, worst over the grid (free rolling excluded).
    pub max_radius: f64,
    /// Link utilisation at `LinkBudget::baud`.
    pub link_utilisation: f64,
    /// Smallest baud for `LinkBudget::max_utilisation`.
    pub min_baud: f64,
}

fn worst_continuous(ev: &[Complex<f64>]) -> (f64, f64) {
    ev.iter()
        .filter(|e| e.im.abs() > 1e-9)
        .map(|e| (zeta_of(*e), e.im.abs() / (2.0 * std::f64::consts::PI)))
        .chain(
            ev.iter()
                .filter(|e| e.im.abs() <= 1e-9 && e.re >= 0.0)
                .map(|e| (-1.0 - e.re, 0.0)),
        )
        .fold((1.0, 0.0), |acc, z| if z.0 < acc.0 { z } else { acc })
}

fn worst_sampled(cl: &ClosedLoop) -> (f64, f64) {
    let unstable_real = cl
        .modes
        .iter()
        .filter(|m| m.freq_hz <= 1e-6 && m.radius >= 1.0)
        .map(|m| (-1.0 - (m.radius - 1.0), 0.0))
        .fold((1.0, 0.0), |a, z| if z.0 < a.0 { z } else { a });
    let osc = (cl.worst.zeta, cl.worst.freq_hz);
    if unstable_real.0 < osc.0 {
        unstable_real
    } else {
        osc
    }
}

/// Evaluate one candidate timing over the grid. `plant(creep, lambda, yaw_spring)` gives
/// the linear plant; `armature` the current-loop plant alone.
pub fn rate_row(
    base: &Config,
    candidate: (u32, u16, u16),
    delay_ticks: usize,
    plant: &dyn Fn(f64, f64, bool) -> LinearPlant,
    armature: &LinearPlant,
    link: &LinkBudget,
) -> Result<RateRow, String> {
    let mut cfg = Config {
        base_rate_hz: candidate.0,
        yaw_divisor: candidate.1,
        traction_divisor: candidate.2,
        ..*base
    };
    if cfg.yaw_predict_ticks > 0.0 {
        // The matched compensation for this divisor: ZOH + one tick.
        cfg.yaw_predict_ticks = 1.0 + candidate.1 as f64 / 2.0;
    }
    let spring = cfg.yaw_mode == YawMode::Passive;
    // Current loop alone.
    let cur = closed_loop(
        armature,
        &Config {
            yaw_mode: YawMode::Passive,
            traction_enabled: true,
            // The yaw divisor is irrelevant here; 1 keeps the hyper-period (and so the
            // equivalent continuous damping) free of aliasing.
            yaw_divisor: 1,
            yaw_predict_ticks: 0.0,
            ..cfg
        },
        delay_ticks,
    )?;
    // The current loop's fast mode: the slowest of the modes faster than 50 rad/s (the
    // PI's own slow pole near -1/Ti is not it).
    let fast = cur
        .modes
        .iter()
        .filter(|m| m.s.norm() > 50.0)
        .max_by(|a, b| {
            a.radius
                .partial_cmp(&b.radius)
                .unwrap_or(std::cmp::Ordering::Equal)
        })
        .copied()
        .unwrap_or(cur.worst);
    let mut row = RateRow {
        base_hz: cfg.base_rate_hz,
        yaw_divisor: cfg.yaw_divisor,
        traction_divisor: cfg.traction_divisor,
        delay_ticks,
        current_radius: fast.radius,
        current_zeta: fast.zeta,
        worst_sampled: GridMode {
            creep: 0.0,
            lambda: 0.0,
            freq_hz: 0.0,
            zeta: f64::INFINITY,
        },
        worst_continuous: GridMode {
            creep: 0.0,
            lambda: 0.0,
            freq_hz: 0.0,
            zeta: f64::INFINITY,
        },
        worst_sampled_stable_region: GridMode {
            creep: 0.0,
            lambda: 0.0,
            freq_hz: 0.0,
            zeta: f64::INFINITY,
        },
        max_damping_loss: f64::NEG_INFINITY,
        newly_unstable: 0,
        unstable_continuous: 0,
        nominal_zeta: f64::NAN,
        max_radius: 0.0,
        link_utilisation: link.utilisation(cfg.base_rate_hz as f64, link.baud as f64),
        min_baud: link.min_baud(cfg.base_rate_hz as f64),
    };
    for &creep in &CREEP_GRID {
        for &lambda in &CONICITY_GRID {
            let p = plant(creep, lambda, spring);
            let cl = closed_loop(&p, &cfg, delay_ticks)?;
            let ct = continuous_closed_loop(&p, &cfg);
            let (zs, fs) = worst_sampled(&cl);
            let (zc, fc) = worst_continuous(&ct);
            let cont_stable = ct.iter().all(|e| e.re < 0.0);
            row.unstable_continuous += (!cont_stable) as usize;
            row.newly_unstable += (cont_stable && !cl.stable()) as usize;
            row.max_damping_loss = row.max_damping_loss.max(zc - zs);
            row.max_radius = row.max_radius.max(cl.spectral_radius);
            if zs < row.worst_sampled.zeta {
                row.worst_sampled = GridMode {
                    creep,
                    lambda,
                    freq_hz: fs,
                    zeta: zs,
                };
            }
            if cont_stable && zs < row.worst_sampled_stable_region.zeta {
                row.worst_sampled_stable_region = GridMode {
                    creep,
                    lambda,
                    freq_hz: fs,
                    zeta: zs,
                };
            }
            if zc < row.worst_continuous.zeta {
                row.worst_continuous = GridMode {
                    creep,
                    lambda,
                    freq_hz: fc,
                    zeta: zc,
                };
            }
            if (creep, lambda) == NOMINAL {
                row.nominal_zeta = zs;
            }
        }
    }
    Ok(row)
}

/// The candidate timings the table covers: base rates 1-10 kHz, yaw at divisors giving
/// 0.5-10 kHz, traction at the base rate.
pub fn candidates() -> Vec<(u32, u16, u16)> {
    let mut v = Vec::new();
    for base in [1000u32, 2000, 2500, 4000, 5000, 8000, 10_000] {
        for yd in [1u16, 2, 4, 5, 10] {
            let yaw = base / yd as u32;
            if base % yd as u32 == 0 && (500..=10_000).contains(&yaw) {
                v.push((base, yd, 1));
            }
        }
    }
    v
}

/// The creep coefficient (N) below which the continuous loop of `cfg` is unstable at
/// conicity `lambda`, by bisection on 0.1-20 MN; `None` if stable (or unstable)
/// throughout.
pub fn critical_creep(
    cfg: &Config,
    lambda: f64,
    plant: &dyn Fn(f64, f64, bool) -> LinearPlant,
) -> Option<f64> {
    let spring = cfg.yaw_mode == YawMode::Passive;
    let stable = |c: f64| {
        continuous_closed_loop(&plant(c, lambda, spring), cfg)
            .iter()
            .all(|e| e.re < 0.0)
    };
    let (mut lo, mut hi) = (0.1e6, 20e6);
    if stable(lo) == stable(hi) {
        return None;
    }
    let s_hi = stable(hi);
    for _ in 0..40 {
        let mid = 0.5 * (lo + hi);
        if stable(mid) == s_hi {
            hi = mid;
        } else {
            lo = mid;
        }
    }
    Some(0.5 * (lo + hi))
}

#[cfg(test)]
mod tests {
    use super::*;
    use wheelset_control::{F64Controller, Inputs};

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
            .plant();
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
            .plant()
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
        // 61 bytes = 610 bits at 2 Mbaud = 305 us, + 2 x 5 us, at 2 kHz = 0.63.
        assert_eq!((l.bytes_in, l.bytes_out), (33, 28));
        assert!((l.utilisation(2000.0, 2e6) - 0.63).abs() < 1e-12);
        // The smallest baud: 610 bits / (0.7 x 200 us - 10 us) = 4.692 Mbaud.
        let b = l.min_baud(5000.0);
        assert_eq!(b, 4_692_308.0);
        assert!(l.utilisation(5000.0, b) <= 0.7);
        assert!(l.utilisation(5000.0, b - 1.0) > 0.7);
    }
}

/// The plant the rate table closes the loops on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Model {
    /// Case (d): flexible axle (40 Hz), motor on its gear spring, armature circuit,
    /// forward speed: `crate::linear::linear_plant`.
    Full,
    /// [`Reduced`]: lateral/yaw of case (a) plus the armature circuit.
    Reduced,
}

impl Model {
    /// Name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Model::Full => "full (case d: flexible axle, drive, armature)",
            Model::Reduced => "reduced (case a lateral/yaw + armature)",
        }
    }

    /// The linear plant at `creep` (f11 = f22) and `lambda`, spring for passive mode.
    pub fn plant(self, p: &Params, creep: f64, lambda: f64, yaw_spring: bool) -> LinearPlant {
        match self {
            Model::Full => {
                let mut q = p.clone();
                q.f11 = creep;
                q.f22 = creep;
                q.lambda = lambda;
                let m = linear_plant(
                    &q,
                    PlantConfig {
                        axle: Axle::Flexible,
                        drive: true,
                        yaw_spring,
                    },
                );
                LinearPlant {
                    a: m.a,
                    b: m.b,
                    c: m.c,
                }
            }
            Model::Reduced => Reduced {
                creep,
                lambda,
                yaw_spring,
            }
            .plant_with(p),
        }
    }
}

/// What a candidate must meet to be chosen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Criteria {
    /// Largest radius per base tick of the current loop's fast mode (0.75: damping
    /// ratio about 0.3 or better).
    pub max_current_radius: f64,
    /// The fastest UART the link may assume, baud.
    pub max_baud: f64,
}

impl Default for Criteria {
    fn default() -> Self {
        Self {
            max_current_radius: 0.75,
            max_baud: 6.0e6,
        }
    }
}

/// One variant of the table: with or without the yaw delay compensation.
#[derive(Debug, Clone)]
pub struct Variant {
    /// Yaw predictor on (matched to each divisor: `1 + yaw_divisor/2` ticks) or off.
    pub predict: bool,
    /// All candidates.
    pub rows: Vec<RateRow>,
    /// The chosen candidate: the lowest base rate meeting the criteria (current-loop
    /// radius, no grid point destabilised by sampling, link within `max_baud`), ties
    /// broken by the smaller damping loss.
    pub chosen: Option<RateRow>,
}

/// The rate table.
#[derive(Debug, Clone)]
pub struct RatesReport {
    /// The plant.
    pub model: Model,
    /// Yaw mode analysed.
    pub mode: YawMode,
    /// Delay in ticks.
    pub delay_ticks: usize,
    /// Link assumptions.
    pub link: LinkBudget,
    /// Selection criteria.
    pub criteria: Criteria,
    /// `(lambda, creep below which the continuous loop is unstable)`.
    pub critical_creep: Vec<(f64, Option<f64>)>,
    /// Without and with the delay compensation.
    pub variants: Vec<Variant>,
}

fn choose(rows: &[RateRow], c: &Criteria) -> Option<RateRow> {
    rows.iter()
        .filter(|r| {
            r.current_radius <= c.max_current_radius
                && r.newly_unstable == 0
                && r.min_baud <= c.max_baud
        })
        .min_by(|a, b| {
            a.base_hz.cmp(&b.base_hz).then(
                a.max_damping_loss
                    .partial_cmp(&b.max_damping_loss)
                    .unwrap_or(std::cmp::Ordering::Equal),
            )
        })
        .copied()
}

/// Build the rate table over [`candidates`] for `base` (its yaw mode and controller
/// parameters), with and without the yaw delay compensation.
pub fn rates(
    params: &Params,
    model: Model,
    base: &Config,
    delay_ticks: usize,
    link: &LinkBudget,
    criteria: &Criteria,
) -> Result<RatesReport, String> {
    let plant = |c: f64, l: f64, s: bool| model.plant(params, c, l, s);
    let arm = armature(params.l_a, params.r_a);
    let cfg = *base;
    // Every matrix finite before any eigenvalue or exponential: a non-finite one is
    // refused with the parameter to blame.
    let corners = |q: &Params| {
        let mut v = vec![armature(q.l_a, q.r_a).a];
        for &c in &[CREEP_GRID[0], CREEP_GRID[CREEP_GRID.len() - 1]] {
            for &l in &[CONICITY_GRID[0], CONICITY_GRID[CONICITY_GRID.len() - 1]] {
                for s in [false, true] {
                    let lp = model.plant(q, c, l, s);
                    let t0 = 1.0 / f64::from(base.base_rate_hz.max(1));
                    let finite = crate::numeric::check_finite(&lp.a, "").is_ok()
                        && crate::numeric::check_finite(&lp.b, "").is_ok();
                    if finite {
                        let (ad, bd) = zoh(&lp.a, &lp.b, t0);
                        v.extend([ad, bd]);
                    }
                    v.extend([lp.a, lp.b]);
                }
            }
        }
        v
    };
    if let Some(m) = corners(params)
        .iter()
        .find_map(|m| crate::numeric::check_finite(m, "a plant matrix").err())
    {
        return Err(match crate::numeric::blame_nonfinite(params, corners) {
            Some(key) => format!(
                "{m}; parameter `{key}` is to blame (its default makes the matrices finite)"
            ),
            None => m,
        });
    }
    let critical_creep = CONICITY_GRID
        .iter()
        .map(|&l| (l, critical_creep(&cfg, l, &plant)))
        .collect();
    let mut variants = Vec::new();
    for predict in [false, true] {
        let c = Config {
            yaw_predict_ticks: if predict { 1.5 } else { 0.0 },
            ..cfg
        };
        let rows = candidates()
            .into_iter()
            .map(|cand| rate_row(&c, cand, delay_ticks, &plant, &arm, link))
            .collect::<Result<Vec<_>, _>>()?;
        let chosen = choose(&rows, criteria);
        variants.push(Variant {
            predict,
            rows,
            chosen,
        });
    }
    Ok(RatesReport {
        model,
        mode: base.yaw_mode,
        delay_ticks,
        link: *link,
        criteria: *criteria,
        critical_creep,
        variants,
    })
}

fn grid_json(g: &GridMode) -> Value {
    json!({"creep_n": g.creep, "lambda": g.lambda, "freq_hz": g.freq_hz, "zeta": g.zeta})
}

fn row_json(r: &RateRow) -> Value {
    json!({
        "base_hz": r.base_hz,
        "yaw_divisor": r.yaw_divisor,
        "traction_divisor": r.traction_divisor,
        "yaw_hz": r.base_hz as f64 / r.yaw_divisor as f64,
        "delay_ticks": r.delay_ticks,
        "current_radius": r.current_radius,
        "current_zeta": r.current_zeta,
        "worst_sampled": grid_json(&r.worst_sampled),
        "worst_sampled_stable_region": grid_json(&r.worst_sampled_stable_region),
        "worst_continuous": grid_json(&r.worst_continuous),
        "max_damping_loss": r.max_damping_loss,
        "newly_unstable": r.newly_unstable,
        "unstable_continuous": r.unstable_continuous,
        "nominal_zeta": r.nominal_zeta,
        "max_radius": r.max_radius,
        "link_utilisation": r.link_utilisation,
        "min_baud": r.min_baud,
    })
}

fn mode_name(m: YawMode) -> &'static str {
    match m {
        YawMode::Passive => "passive",
        YawMode::Gain => "gain",
        YawMode::Lead => "lead",
    }
}

impl RatesReport {
    /// The report as JSON.
    pub fn to_json(&self) -> Value {
        json!({
            "model": self.model.name(),
            "control": mode_name(self.mode),
            "delay_ticks": self.delay_ticks,
            "grid": {"creep_n": CREEP_GRID, "conicity": CONICITY_GRID},
            "nominal": {"creep_n": NOMINAL.0, "lambda": NOMINAL.1},
            "link": {
                "bytes_in": self.link.bytes_in,
                "bytes_out": self.link.bytes_out,
                "latency_ns": self.link.latency_ns,
                "max_utilisation": self.link.max_utilisation(),
                "baud": self.link.baud,
            },
            "criteria": {
                "max_current_radius": self.criteria.max_current_radius,
                "max_baud": self.criteria.max_baud,
            },
            "critical_creep_n": self.critical_creep.iter().map(|(l, c)| json!({"lambda": l, "creep_n": c})).collect::<Vec<_>>(),
            "variants": self.variants.iter().map(|v| json!({
                "yaw_predict": if v.predict { "1 + yaw_divisor/2 ticks" } else { "off" },
                "rows": v.rows.iter().map(row_json).collect::<Vec<_>>(),
                "chosen": v.chosen.as_ref().map(row_json),
            })).collect::<Vec<_>>(),
        })
    }

    /// The report as a text table.
    pub fn render(&self) -> String {
        use std::fmt::Write;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "sampled-data rate analysis: {} plant, {} yaw control, ZOH + {} tick(s) of delay",
            self.model.name(),
            mode_name(self.mode),
            self.delay_ticks
        );
        let _ = writeln!(
            s,
            "grid: creep {:?} MN x conicity {:?}; free-rolling mode excluded",
            CREEP_GRID.map(|c| c / 1e6),
            CONICITY_GRID
        );
        for (l, c) in &self.critical_creep {
            let _ = match c {
                Some(c) => writeln!(
                    s,
                    "continuous loop: stability changes at creep {:.2} MN (conicity {l})",
                    c / 1e6
                ),
                None => writeln!(
                    s,
                    "continuous loop: no crossing in 0.1-20 MN (conicity {l})"
                ),
            };
        }
        let _ = writeln!(
            s,
            "link: {} + {} bytes x 10 bits + 2 x {:.0} us latency per period, <= {:.0} % (utilisation quoted at {} baud)",
            self.link.bytes_in,
            self.link.bytes_out,
            self.link.latency_ns as f64 * 1e-3,
            self.link.max_utilisation() * 100.0,
            self.link.baud
        );
        for v in &self.variants {
            let _ = writeln!(
                s,
                "\n== yaw delay compensation {}",
                if v.predict {
                    "on (1 + yaw_divisor/2 ticks)"
                } else {
                    "off"
                }
            );
            let _ = writeln!(
                s,
                "{:>6} {:>4} {:>6} | {:>7} {:>6} | {:>26} | {:>7} | {:>5} {:>5} | {:>7} | {:>5} {:>9}",
                "base", "yaw/", "yaw Hz", "cur r", "zeta", "worst zeta (stable region)", "loss", "new", "cont", "nominal", "util", "min baud"
            );
            for r in &v.rows {
                let w = &r.worst_sampled_stable_region;
                let _ = writeln!(
                    s,
                    "{:>6} {:>4} {:>6.0} | {:>7.3} {:>6.3} | {:>+7.3} {:>5.1} Hz {:>3.0} MN {:>4} | {:>7.4} | {:>5} {:>5} | {:>+7.3} | {:>5.2} {:>9.2e}",
                    r.base_hz,
                    r.yaw_divisor,
                    r.base_hz as f64 / r.yaw_divisor as f64,
                    r.current_radius,
                    r.current_zeta,
                    w.zeta,
                    w.freq_hz,
                    w.creep / 1e6,
                    w.lambda,
                    r.max_damping_loss,
                    r.newly_unstable,
                    r.unstable_continuous,
                    r.nominal_zeta,
                    r.link_utilisation,
                    r.min_baud
                );
            }
            let _ = match &v.chosen {
                Some(r) => writeln!(
                    s,
                    "chosen: base {} Hz, yaw divisor {}, traction divisor {} (current-loop radius {:.3} <= {}, no grid point destabilised, {:.2e} baud <= {:.1e})",
                    r.base_hz, r.yaw_divisor, r.traction_divisor, r.current_radius,
                    self.criteria.max_current_radius, r.min_baud, self.criteria.max_baud
                ),
                None => writeln!(
                    s,
                    "chosen: none meets the criteria (current-loop radius <= {}, no grid point destabilised by sampling, link <= {:.1e} baud)",
                    self.criteria.max_current_radius, self.criteria.max_baud
                ),
            };
        }
        let _ = writeln!(
            s,
            "\ncolumns: cur r/zeta = current loop (armature + PI) fast mode per base tick; worst zeta = least-damped \
             sampled mode where the continuous loop is stable; loss = max over the grid of zeta_cont - zeta_sampled \
             (worst modes); new = grid points stable continuous but unstable sampled; cont = grid points unstable in \
             continuous time; nominal = worst sampled zeta at 10 MN, 0.2; util = link utilisation at the quoted baud"
        );
        s
    }
}
