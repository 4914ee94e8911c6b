//! Linearisation about straight-track pure rolling (`y = psi = 0`, wheels at `v/r0`,
//! the PI integrator at the back-EMF): an analytic Jacobian ([`plant_jacobian`],
//! checked against the complex step by a test) and central differences for the adhesion
//! law. Free rolling is an equilibrium at any speed, so every model here has one
//! eigenvalue at exactly zero.

use crate::control::{closed_loop_rhs, ContinuousController, Exogenous, YawLaw};
use crate::params::Params;
use crate::plant::{ix, Inputs, Plant, PlantConfig, State, NX};
use crate::scenario::Axle;
use nalgebra::{DMatrix, SMatrix};

/// Full-size Jacobian (all 13 state slots; absent states have zero rows and columns).
pub type Jac = SMatrix<f64, NX, NX>;
/// Full-size input matrix for `[T_psi, u_a]`.
pub type InJac = SMatrix<f64, NX, 2>;

/// The operating point: pure rolling on straight track at `p.v`, the PI preset to the back-EMF.
pub fn operating_point(plant: &Plant, p: &Params) -> State {
    let mut x = plant.rolling_state(p.v);
    if plant.cfg.drive {
        x[ix::PI] = plant.back_emf(&x);
    }
    x
}

/// Analytic Jacobians `(df/dx, df/d[T_psi, u_a])` of the plant RHS at any `x` and `u`.
/// Creep-force gradients (`w_L` is `w_R` on a rigid axle):
/// `dF_xR/dpsi' = f11 Lg/v`, `dF_xR/dw_R = f11 (r0 + lambda y)/v`,
/// `dF_xR/dy = f11 lambda w_R/v`, `dF_xR/dv = -f11 (Lg psi' + w_R (r0 + lambda y))/v^2`;
/// `dF_xL/dpsi' = -f11 Lg/v`, `dF_xL/dw_L = f11 (r0 - lambda y)/v`,
/// `dF_xL/dy = -f11 lambda w_L/v`, `dF_xL/dv = f11 (Lg psi' - w_L (r0 - lambda y))/v^2`;
/// `dF_y/dy' = -f22/v`, `dF_y/dpsi = f22`, `dF_y/dv = f22 y'/v^2`.
pub fn plant_jacobian(plant: &Plant, p: &Params, x: &State, u: &Inputs<f64>) -> (Jac, InJac) {
    let cfg = plant.cfg;
    let rigid = cfg.axle == Axle::Rigid;
    let wl_ix = if rigid { ix::WR } else { ix::WL };
    let (f11, f22, lg, r0, lam) = (p.f11, p.f22, p.l_g, p.r0, p.lambda);
    let v = x[ix::V];
    let (y, yd, psid, wr, wl) = (x[ix::Y], x[ix::YD], x[ix::PSID], x[ix::WR], x[wl_ix]);
    let mut g_xr = [0.0; NX];
    g_xr[ix::PSID] = f11 * lg / v;
    g_xr[ix::WR] = f11 * (r0 + lam * y) / v;
    g_xr[ix::Y] = f11 * lam * wr / v;
    g_xr[ix::V] = -f11 * (lg * psid + wr * (r0 + lam * y)) / (v * v);
    let mut g_xl = [0.0; NX];
    g_xl[ix::PSID] = -f11 * lg / v;
    g_xl[wl_ix] += f11 * (r0 - lam * y) / v;
    g_xl[ix::Y] = -f11 * lam * wl / v;
    g_xl[ix::V] = f11 * (lg * psid - wl * (r0 - lam * y)) / (v * v);
    let mut g_y = [0.0; NX];
    g_y[ix::YD] = -f22 / v;
    g_y[ix::PSI] = f22;
    g_y[ix::V] = f22 * yd / (v * v);

    let (k_t, k_g, n) = (p.k_t(), p.k_gear(), p.n_gear);
    let m_long = p.m + p.m_v / 2.0;
    let mut a = Jac::zeros();
    let mut b = InJac::zeros();
    a[(ix::Y, ix::YD)] = 1.0;
    a[(ix::PSI, ix::PSID)] = 1.0;
    for j in 0..NX {
        a[(ix::YD, j)] = 2.0 * g_y[j] / p.m;
        a[(ix::PSID, j)] = -lg * (g_xr[j] - g_xl[j]) / p.j;
        a[(ix::V, j)] = (g_xr[j] + g_xl[j]) / m_long;
        if rigid {
            let row = -r0 * (g_xr[j] + g_xl[j]) / (2.0 * p.i_w);
            a[(ix::WR, j)] = row;
            a[(ix::WL, j)] = row;
        } else {
            a[(ix::WR, j)] = -r0 * g_xr[j] / p.i_w;
            a[(ix::WL, j)] = -r0 * g_xl[j] / p.i_w;
        }
    }
    // Direct terms of (4).
    a[(ix::YD, ix::YD)] -= p.c_lat / p.m;
    a[(ix::YD, ix::Y)] -= p.k_lat / p.m;
    a[(ix::YD, ix::V)] += 2.0 * v * u.curvature;
    // (5): spring and actuator.
    if cfg.yaw_spring {
        a[(ix::PSID, ix::PSI)] -= p.k_yaw / p.j;
    }
    b[(ix::PSID, 0)] = -1.0 / p.j;
    // (6), (7): torsion and gear.
    if rigid {
        if cfg.drive {
            a[(ix::WR, ix::WIND)] -= k_g / (2.0 * p.i_w);
            a[(ix::WL, ix::WIND)] -= k_g / (2.0 * p.i_w);
        }
    } else {
        a[(ix::WR, ix::TWIST)] -= k_t / p.i_w;
        a[(ix::WL, ix::TWIST)] += k_t / p.i_w;
        if cfg.drive {
            a[(ix::WL, ix::WIND)] -= k_g / p.i_w;
        }
        a[(ix::TWIST, ix::WR)] = 1.0;
        a[(ix::TWIST, ix::WL)] = -1.0;
    }
    if cfg.drive {
        a[(ix::WIND, wl_ix)] += 1.0;
        a[(ix::WIND, ix::WM)] = -1.0 / n;
        a[(ix::WM, ix::IA)] = p.k_m / p.i_m;
        a[(ix::WM, ix::WIND)] = k_g / (n * p.i_m);
        a[(ix::IA, ix::IA)] = -p.r_a / p.l_a;
        a[(ix::IA, ix::WM)] = -p.k_m / p.l_a;
        b[(ix::IA, 1)] = 1.0 / p.l_a;
    }
    (a, b)
}

/// Analytic closed-loop Jacobian: plant Jacobian plus `B dT/dx + B du_a/dx` plus the
/// controller rows (lead `x_c' = -p x_c + y'`, PI `x_i' = Kp (i_ref - i_a)/Ti`).
pub fn closed_loop_jacobian(
    plant: &Plant,
    p: &Params,
    ctrl: &ContinuousController,
    x: &State,
    e: &Exogenous<f64>,
) -> Jac {
    let drive = plant.cfg.drive;
    let (mut a, b) = plant_jacobian(plant, p, x, &ctrl.inputs(x, e, drive));
    let mut dt = [0.0; NX];
    match ctrl.law {
        YawLaw::Passive => {}
        YawLaw::Gain => dt[ix::YD] = ctrl.k,
        YawLaw::Lead => {
            dt[ix::YD] = ctrl.k * ctrl.lead_a;
            dt[ix::LEAD] = -ctrl.k * ctrl.lead_a * (ctrl.lead_p - ctrl.lead_z);
        }
    }
    let mut du = [0.0; NX];
    if drive {
        du[ix::IA] = -ctrl.kp;
        du[ix::PI] = 1.0;
    }
    for i in 0..NX {
        for j in 0..NX {
            a[(i, j)] += b[(i, 0)] * dt[j] + b[(i, 1)] * du[j];
        }
    }
    if ctrl.law == YawLaw::Lead {
        a[(ix::LEAD, ix::LEAD)] = -ctrl.lead_p;
        a[(ix::LEAD, ix::YD)] = 1.0;
    }
    if drive {
        a[(ix::PI, ix::IA)] = -ctrl.kp / ctrl.ti;
    }
    a
}

/// Relative step of [`closed_loop_jacobian_central`]: `h_j = CENTRAL_STEP max(|x_j|, 1e-2)`.
pub const CENTRAL_STEP: f64 = 1e-6;

/// Central-difference closed-loop Jacobian of [`closed_loop_rhs`] at any state:
/// `A[:, j] = (f(x + h_j e_j) - f(x - h_j e_j)) / (2 h_j)` (truncation `O(h^2)`). The
/// one to use with the adhesion law on: `num_complex`'s `atan` loses the imaginary part.
pub fn closed_loop_jacobian_central(
    plant: &Plant,
    ctrl: &ContinuousController,
    x: &State,
    e: &Exogenous<f64>,
) -> Jac {
    let mut a = Jac::zeros();
    for j in 0..NX {
        let h = CENTRAL_STEP * x[j].abs().max(1e-2);
        let (mut xp, mut xm) = (*x, *x);
        xp[j] += h;
        xm[j] -= h;
        let fp = closed_loop_rhs(plant, plant.cfg, ctrl, &xp, e);
        let fm = closed_loop_rhs(plant, plant.cfg, ctrl, &xm, e);
        for i in 0..NX {
            a[(i, j)] = (fp[i] - fm[i]) / (2.0 * h);
        }
    }
    a
}

/// A closed loop's states: the plant's, the lead state (lead law), the PI integrator (drive).
pub fn closed_loop_states(cfg: &PlantConfig, law: YawLaw) -> Vec<usize> {
    let mut s = cfg.plant_states();
    if law == YawLaw::Lead {
        s.push(ix::LEAD);
    }
    if cfg.drive {
        s.push(ix::PI);
    }
    s
}

/// Restricts a full-size matrix to the rows and columns in `states`.
pub fn select(a: &Jac, states: &[usize]) -> DMatrix<f64> {
    let mut out = DMatrix::zeros(0, 0);
    select_into(a, states, &mut out);
    out
}

/// [`select`] into `out` (its storage reused when it already has the size).
fn select_into(a: &Jac, states: &[usize], out: &mut DMatrix<f64>) {
    let n = states.len();
    if out.shape() != (n, n) {
        *out = DMatrix::zeros(n, n);
    }
    for (col, &sj) in out.as_mut_slice().chunks_exact_mut(n).zip(states) {
        let src = a.column(sj);
        for (o, &si) in col.iter_mut().zip(states) {
            *o = src[si];
        }
    }
}

/// The closed-loop `A` at the operating point for the controller `ctrl` on the plant
/// `axle`, `drive` (the yaw spring is set from `ctrl.law`), restricted to the loop's
/// states, analytic.
pub fn closed_loop_a(
    p: &Params,
    axle: Axle,
    drive: bool,
    ctrl: &ContinuousController,
) -> (DMatrix<f64>, Vec<usize>) {
    let cfg = PlantConfig {
        axle,
        drive,
        yaw_spring: ctrl.law.has_spring(),
    };
    let states = closed_loop_states(&cfg, ctrl.law);
    let mut a = DMatrix::zeros(0, 0);
    closed_loop_a_into(p, cfg, ctrl, &states, &mut a);
    (a, states)
}

/// [`closed_loop_a`] on the plant `cfg` into `out`, `states` its [`closed_loop_states`].
pub(crate) fn closed_loop_a_into(
    p: &Params,
    cfg: PlantConfig,
    ctrl: &ContinuousController,
    states: &[usize],
    out: &mut DMatrix<f64>,
) {
    let plant = Plant::new(p, cfg);
    let x = operating_point(&plant, p);
    let a = closed_loop_jacobian(&plant, p, ctrl, &x, &Exogenous::default());
    select_into(&a, states, out);
}

/// The open-loop plant linearised at pure rolling on straight track, inputs `T_psi`
/// (eq. 5 sign) and `u_a`, outputs `y'`, `i_a`, `theta_m'`; with the full-state slot
/// ([`crate::plant::ix`]) of each of its states.
pub fn linear_plant(p: &Params, cfg: PlantConfig) -> (LinearPlant, Vec<usize>) {
    let plant = Plant::new(p, cfg);
    let x = operating_point(&plant, p);
    let u_a = if cfg.drive { plant.back_emf(&x) } else { 0.0 };
    let u = Inputs {
        u_a,
        ..Inputs::default()
    };
    let (a, b) = plant_jacobian(&plant, p, &x, &u);
    let states = cfg.plant_states();
    let n = states.len();
    let bm = DMatrix::from_fn(n, 2, |i, k| b[(states[i], k)]);
    let out = [ix::YD, ix::IA, ix::WM];
    let c = DMatrix::from_fn(3, n, |r, j| if states[j] == out[r] { 1.0 } else { 0.0 });
    let a = select(&a, &states);
    (LinearPlant { a, b: bm, c }, states)
}

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

/// The reduced plant: the lateral/yaw dynamics of case (a) (rigid axle, straight track,
/// constant speed, eqs. 4-5 linearised) and the armature circuit at constant motor
/// speed (eq. 9). States `[y, y', psi, psi', i_a]`.
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

/// The plant the rate table closes the loops on.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Model {
    /// Case (d) linearisation: flexible axle, motor on its gear spring, armature.
    Full,
    /// Case (a) lateral/yaw plus the armature circuit alone.
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
                let cfg = PlantConfig {
                    axle: Axle::Flexible,
                    drive: true,
                    yaw_spring,
                };
                linear_plant(&q, cfg).0
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
