//! The nonlinear wheelset plant, eqs. (1)-(10) of `docs/model.md` as corrected, on
//! relative angles (no absolute rotation angle is a state, so long runs keep full
//! precision). States, units and sign conventions: [`ix`] and the book's chapter.

use crate::adhesion::Adhesion;
use crate::params::Params;
use crate::scenario::Axle;
use nalgebra::Complex;
use std::ops::{Add, Div, Mul, Neg, Sub};

/// Indices into the state vector.
pub mod ix {
    /// Lateral displacement `y`, m.
    pub const Y: usize = 0;
    /// Lateral velocity `y'`, m/s.
    pub const YD: usize = 1;
    /// Yaw angle `psi`, rad.
    pub const PSI: usize = 2;
    /// Yaw rate `psi'`, rad/s.
    pub const PSID: usize = 3;
    /// Right wheel speed, rad/s.
    pub const WR: usize = 4;
    /// Left wheel speed, rad/s.
    pub const WL: usize = 5;
    /// Axle twist `phi_R - phi_L`, rad.
    pub const TWIST: usize = 6;
    /// Gear wind-up `phi_L - theta_m / n`, rad.
    pub const WIND: usize = 7;
    /// Motor speed `theta_m'`, rad/s.
    pub const WM: usize = 8;
    /// Armature current `i_a`, A.
    pub const IA: usize = 9;
    /// Forward speed `v`, m/s.
    pub const V: usize = 10;
    /// Phase-lead compensator state.
    pub const LEAD: usize = 11;
    /// PI integrator state (volts).
    pub const PI: usize = 12;
}

/// Length of the state vector.
pub const NX: usize = 13;

/// Short names of the states, in index order (CSV/JSON labels).
pub const STATE_NAMES: [&str; NX] = [
    "y_m",
    "yd_mps",
    "psi_rad",
    "psid_radps",
    "w_r_radps",
    "w_l_radps",
    "twist_rad",
    "wind_rad",
    "w_m_radps",
    "i_a_A",
    "v_mps",
    "x_lead",
    "x_pi_V",
];

/// A state vector.
pub type State = [f64; NX];

/// The arithmetic the right-hand side needs: implemented for `f64` (simulation) and
/// `Complex<f64>` (complex-step differentiation). No branches on values, so the RHS is
/// analytic in every state and input.
pub trait Scalar:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// Lifts a real constant.
    fn c(x: f64) -> Self;
    /// The real part (for branches of the adhesion law only: see [`crate::adhesion`]).
    fn re(self) -> f64;
    /// Square root (principal branch).
    fn sqrt(self) -> Self;
    /// Arc tangent.
    fn atan(self) -> Self;
    /// Exponential.
    fn exp(self) -> Self;
}

/// [`Scalar`] for `$t`, whose `sqrt`, `atan` and `exp` are its own.
macro_rules! scalar {
    ($t:ty, $lift:expr, $re:expr) => {
        impl Scalar for $t {
            #[inline(always)]
            fn c(x: f64) -> Self {
                $lift(x)
            }
            #[inline(always)]
            fn re(self) -> f64 {
                $re(self)
            }
            #[inline(always)]
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn atan(self) -> Self {
                <$t>::atan(self)
            }
            #[inline(always)]
            fn exp(self) -> Self {
                <$t>::exp(self)
            }
        }
    };
}

scalar!(f64, |x| x, |x| x);
scalar!(Complex<f64>, |x| Complex::new(x, 0.0), |z: Complex<f64>| z
    .re);

/// Which parts of the plant are present.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PlantConfig {
    /// Rigid or flexible axle.
    pub axle: Axle,
    /// Traction drive (gear spring, motor, armature) present.
    pub drive: bool,
    /// Yaw spring `k_yaw psi` present (passive mode; active modes replace it by `T_psi`).
    pub yaw_spring: bool,
}

impl PlantConfig {
    /// Flexible axle (`WL`, `TWIST` are states).
    #[inline(always)]
    pub fn flexible(&self) -> bool {
        self.axle == Axle::Flexible
    }

    /// The states this configuration actually has (indices into the full vector),
    /// excluding controller states.
    pub fn plant_states(&self) -> Vec<usize> {
        let mut s = vec![ix::Y, ix::YD, ix::PSI, ix::PSID, ix::WR];
        if self.flexible() {
            s.extend([ix::WL, ix::TWIST]);
        }
        if self.drive {
            s.extend([ix::WIND, ix::WM, ix::IA]);
        }
        s.push(ix::V);
        s
    }
}

/// The configuration switches the right-hand side branches on, as a type: a
/// [`PlantConfig`] (read at run time) or a [`Fixed`] (compile-time constants, so a run's
/// RK4 step is compiled once per configuration, without the branches). Both give the
/// same floating-point operations in the same order.
pub trait Flags: Copy {
    /// The configuration.
    fn cfg(&self) -> PlantConfig;
    /// The adhesion law is known to be `None`, so [`Plant::creep`] need not look.
    #[inline(always)]
    fn linear_creep(&self) -> bool {
        false
    }
}

impl Flags for PlantConfig {
    #[inline(always)]
    fn cfg(&self) -> PlantConfig {
        *self
    }
}

/// A [`PlantConfig`] as constants ([`Flags`]), picked by [`with_flags!`](crate::with_flags).
#[derive(Debug, Clone, Copy, Default)]
pub struct Fixed<const FLEXIBLE: bool, const DRIVE: bool, const YAW_SPRING: bool>;

impl<const FLEXIBLE: bool, const DRIVE: bool, const YAW_SPRING: bool> Flags
    for Fixed<FLEXIBLE, DRIVE, YAW_SPRING>
{
    #[inline(always)]
    fn cfg(&self) -> PlantConfig {
        PlantConfig {
            axle: if FLEXIBLE {
                Axle::Flexible
            } else {
                Axle::Rigid
            },
            drive: DRIVE,
            yaw_spring: YAW_SPRING,
        }
    }
}

/// Flags `F` with [`Flags::linear_creep`] true: for a plant without an adhesion law only.
#[derive(Debug, Clone, Copy, Default)]
pub struct Linear<F>(pub F);

impl<F: Flags> Flags for Linear<F> {
    #[inline(always)]
    fn cfg(&self) -> PlantConfig {
        self.0.cfg()
    }
    #[inline(always)]
    fn linear_creep(&self) -> bool {
        true
    }
}

/// Evaluates `$body` with `$f` rebound to [`Linear`]`($f)` when `$plant` has no
/// adhesion law, and as it is otherwise.
#[macro_export]
macro_rules! with_creep_law {
    ($plant:expr, $f:ident => $body:expr) => {{
        if $plant.adhesion.is_none() {
            let $f = $crate::plant::Linear($f);
            $body
        } else {
            $body
        }
    }};
}

/// Evaluates `$body` with `$f` bound to the [`Fixed`] flags of the [`PlantConfig`]
/// `$cfg` (one copy of `$body` per configuration).
#[macro_export]
macro_rules! with_flags {
    ($cfg:expr, $f:ident => $body:expr) => {{
        let cfg: $crate::plant::PlantConfig = $cfg;
        $crate::with_flags!(@ [cfg.flexible(), cfg.drive, cfg.yaw_spring] [] $f => $body)
    }};
    (@ [$c:expr $(, $rest:expr)*] [$($b:tt)*] $f:ident => $body:expr) => {
        if $c {
            $crate::with_flags!(@ [$($rest),*] [$($b)* true] $f => $body)
        } else {
            $crate::with_flags!(@ [$($rest),*] [$($b)* false] $f => $body)
        }
    };
    (@ [] [$x:tt $y:tt $z:tt] $f:ident => $body:expr) => {{
        let $f = $crate::plant::Fixed::<$x, $y, $z>;
        $body
    }};
}

/// Plant inputs (SI; default: all zero).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Inputs<S> {
    /// Yaw torque from the actuator `T_psi`, N m (eq. 5 sign).
    pub t_psi: S,
    /// Armature voltage `u_a`, V (drive only).
    pub u_a: S,
    /// Track curvature `1/R`, 1/m.
    pub curvature: S,
    /// Cant angle `theta`, rad.
    pub cant: S,
    /// Running resistance `F_run`, N.
    pub f_run: S,
    /// Direct traction torque on the left wheel, N m (used only without the drive).
    pub t_drive: S,
}

/// Creep forces (eqs. 1-3), N: the rail's forces on the wheels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Creep<S> {
    /// Longitudinal force on the right wheel, + forward.
    pub fx_r: S,
    /// Longitudinal force on the left wheel, + forward.
    pub fx_l: S,
    /// Lateral force per wheel, + right.
    pub fy: S,
}

/// The plant: the coefficients the RHS needs and its configuration; cheap to copy, no allocation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Plant {
    /// Configuration.
    pub cfg: PlantConfig,
    /// The adhesion law in force, set per integration step; `None` = linear creep law.
    pub adhesion: Option<Adhesion>,
    m: f64,
    f11: f64,
    f22: f64,
    c_lat: f64,
    k_lat: f64,
    k_yaw: f64,
    k_t: f64,
    k_gear: f64,
    l_g: f64,
    r0: f64,
    lambda: f64,
    pub(crate) n: f64,
    pub(crate) k_m: f64,
    r_a: f64,
    inv: Inverses,
    pre: Products,
}

/// Parameter products formed once with the same operations (the RHS is bit-identical).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Products {
    m_g: f64,
    half_inv_i_w: f64,
    k_gear_inv_n: f64,
}

/// Reciprocals of the divisors, so the RHS multiplies instead of dividing.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Inverses {
    m: f64,
    m_long: f64,
    j: f64,
    i_w: f64,
    i_m: f64,
    n: f64,
    l_a: f64,
    f11: f64,
    f22: f64,
}

impl Plant {
    /// Builds the plant from parameters.
    pub fn new(p: &Params, cfg: PlantConfig) -> Plant {
        Plant {
            cfg,
            adhesion: None,
            m: p.m,
            f11: p.f11,
            f22: p.f22,
            c_lat: p.c_lat,
            k_lat: p.k_lat,
            k_yaw: p.k_yaw,
            k_t: p.k_t(),
            k_gear: p.k_gear(),
            l_g: p.l_g,
            r0: p.r0,
            lambda: p.lambda,
            n: p.n_gear,
            k_m: p.k_m,
            r_a: p.r_a,
            inv: Inverses {
                m: 1.0 / p.m,
                m_long: 1.0 / (p.m + p.m_v / 2.0),
                j: 1.0 / p.j,
                i_w: 1.0 / p.i_w,
                i_m: 1.0 / p.i_m,
                n: 1.0 / p.n_gear,
                l_a: 1.0 / p.l_a,
                f11: 1.0 / p.f11,
                f22: 1.0 / p.f22,
            },
            pre: Products {
                m_g: p.m * p.g,
                half_inv_i_w: 0.5 * (1.0 / p.i_w),
                k_gear_inv_n: p.k_gear() * (1.0 / p.n_gear),
            },
        }
    }

    /// Left wheel speed as the model sees it (the right one on a rigid axle).
    #[inline(always)]
    pub(crate) fn w_l<S: Scalar, F: Flags>(&self, f: F, x: &[S; NX]) -> S {
        if f.cfg().flexible() {
            x[ix::WL]
        } else {
            x[ix::WR]
        }
    }

    /// Creep forces, eqs. (1)-(3):
    ///
    /// `F_xR =  f11 [-1 + Lg psi'/v + phi_R' (r0 + lambda y)/v - Lg/R]`,
    /// `F_xL = -f11 [ 1 + Lg psi'/v - phi_L' (r0 - lambda y)/v - Lg/R]`,
    /// `F_y  = -f22 (y' - v psi)/v` per wheel; under the configuration `f`.
    #[inline(always)]
    pub fn creep<S: Scalar, F: Flags>(&self, f: F, x: &[S; NX], curvature: S) -> Creep<S> {
        let c = S::c;
        let v = x[ix::V];
        let y = x[ix::Y];
        let inv_v = c(1.0) / v;
        let lg_psid_v = c(self.l_g) * x[ix::PSID] * inv_v;
        let lg_k = c(self.l_g) * curvature;
        let ly = c(self.lambda) * y;
        let fx_r =
            c(self.f11) * (c(-1.0) + lg_psid_v + x[ix::WR] * (c(self.r0) + ly) * inv_v - lg_k);
        let fx_l =
            -c(self.f11) * (c(1.0) + lg_psid_v - self.w_l(f, x) * (c(self.r0) - ly) * inv_v - lg_k);
        let fy = -c(self.f22) * (x[ix::YD] * inv_v - x[ix::PSI]);
        let lin = Creep { fx_r, fx_l, fy };
        if f.linear_creep() {
            debug_assert!(self.adhesion.is_none());
            return lin;
        }
        match self.adhesion {
            None => lin,
            Some(a) => Self::limit(a, self.inv.f11, self.inv.f22, lin, v),
        }
    }

    /// The adhesion-limited forces of the two wheels; [`Creep::fy`] is the mean of the
    /// wheels' lateral forces, so `2 F_y` in eq. (4) is their sum. Out of line and given
    /// copies, so the caller need not reload the plant's coefficients each step.
    #[inline(never)]
    fn limit<S: Scalar>(a: Adhesion, ix: f64, iy: f64, lin: Creep<S>, v: S) -> Creep<S> {
        let (fx_r, fy_r) = a.apply(lin.fx_r, lin.fy, ix, iy, v);
        let (fx_l, fy_l) = a.apply(lin.fx_l, lin.fy, ix, iy, v);
        Creep {
            fx_r,
            fx_l,
            fy: S::c(0.5) * (fy_r + fy_l),
        }
    }

    /// Passive spring torque `k_yaw psi` under the configuration `f` (zero when the
    /// spring is absent), N m.
    #[inline(always)]
    pub fn spring_torque<S: Scalar, F: Flags>(&self, f: F, x: &[S; NX]) -> S {
        if f.cfg().yaw_spring {
            S::c(self.k_yaw) * x[ix::PSI]
        } else {
            S::c(0.0)
        }
    }

    /// Time derivative of the plant states (controller entries `LEAD`, `PI` are left
    /// zero) and the creep forces. Newton's laws on the creep forces:
    ///
    /// - (4) `m y'' = 2 F_y - c_lat y' - k_lat y + m v^2/R - m g theta`
    /// - (5) `J psi'' = -Lg (F_xR - F_xL) - T_spring - T_psi`
    /// - (6) `I_w phi_R'' = -r0 F_xR - k_t (phi_R - phi_L)`
    /// - (7) `I_w phi_L'' = -r0 F_xL + k_t (phi_R - phi_L) + k_gear (theta_m/n - phi_L)`
    /// - (8) `(m + m_v/2) v' = F_xR + F_xL - F_run`
    /// - (9) `L_a i_a' = u_a - R_a i_a - K_m theta_m'`
    /// - (10) `I_m theta_m'' = K_m i_a + (k_gear/n) (phi_L - theta_m/n)`
    ///
    /// Rigid axle: `2 I_w phi'' = -r0 (F_xR + F_xL) + gear torque`.
    #[inline(always)]
    pub fn rhs<S: Scalar, F: Flags>(
        &self,
        f: F,
        x: &[S; NX],
        u: &Inputs<S>,
    ) -> ([S; NX], Creep<S>) {
        let c = S::c;
        let zero = c(0.0);
        let mut dx = [zero; NX];
        let cr = self.creep(f, x, u.curvature);
        let v = x[ix::V];

        // (4) lateral
        dx[ix::Y] = x[ix::YD];
        dx[ix::YD] = (c(2.0) * cr.fy - c(self.c_lat) * x[ix::YD] - c(self.k_lat) * x[ix::Y]
            + c(self.m) * v * v * u.curvature
            - c(self.pre.m_g) * u.cant)
            * c(self.inv.m);
        // (5) yaw
        dx[ix::PSI] = x[ix::PSID];
        dx[ix::PSID] = (-c(self.l_g) * (cr.fx_r - cr.fx_l) - self.spring_torque(f, x) - u.t_psi)
            * c(self.inv.j);

        // Torque on the left wheel from the transmission.
        let t_gear = if f.cfg().drive {
            -c(self.k_gear) * x[ix::WIND]
        } else {
            u.t_drive
        };
        if f.cfg().flexible() {
            let t_tors = c(self.k_t) * x[ix::TWIST];
            dx[ix::WR] = (-c(self.r0) * cr.fx_r - t_tors) * c(self.inv.i_w);
            dx[ix::WL] = (-c(self.r0) * cr.fx_l + t_tors + t_gear) * c(self.inv.i_w);
            dx[ix::TWIST] = x[ix::WR] - x[ix::WL];
        } else {
            let a = (-c(self.r0) * (cr.fx_r + cr.fx_l) + t_gear) * c(self.pre.half_inv_i_w);
            dx[ix::WR] = a;
            dx[ix::WL] = a;
        }
        if f.cfg().drive {
            let w_l = self.w_l(f, x);
            dx[ix::WIND] = w_l - x[ix::WM] * c(self.inv.n);
            dx[ix::WM] = (c(self.k_m) * x[ix::IA] + c(self.pre.k_gear_inv_n) * x[ix::WIND])
                * c(self.inv.i_m);
            dx[ix::IA] =
                (u.u_a - c(self.r_a) * x[ix::IA] - c(self.k_m) * x[ix::WM]) * c(self.inv.l_a);
        }
        // (8) longitudinal
        dx[ix::V] = (cr.fx_r + cr.fx_l - u.f_run) * c(self.inv.m_long);
        (dx, cr)
    }

    /// Pure rolling on straight track at speed `v` (wheels at `v/r0`, motor at `n v/r0`).
    pub fn rolling_state(&self, v: f64) -> State {
        let mut x = [0.0; NX];
        x[ix::V] = v;
        x[ix::WR] = v / self.r0;
        x[ix::WL] = v / self.r0;
        if self.cfg.drive {
            x[ix::WM] = self.n * v / self.r0;
        }
        x
    }

    /// Motor back-EMF `K_m theta_m'`, V.
    pub fn back_emf(&self, x: &State) -> f64 {
        self.k_m * x[ix::WM]
    }
}
