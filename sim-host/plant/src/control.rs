//! The continuous and the sampled controllers. Signs (eq. 5, `J psi'' + ... = -T_psi`):
//! passive `T_psi = +k_yaw psi`, active `T_psi = +K y'`.

use crate::params::Params;
use crate::plant::{ix, Flags, Inputs, Plant, Scalar, NX};
use serde::{Deserialize, Serialize};

/// The yaw stabilisation law.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "lowercase")]
pub enum YawLaw {
    /// Mechanical yaw spring `k_yaw psi` (no actuator).
    Passive,
    /// Active yaw damping, pure gain `T = K y'` (spring replaced by the actuator).
    Gain,
    /// Active yaw damping with phase lead `K 7.5 (s+37)/(s+274)` on `y'`.
    Lead,
}

impl YawLaw {
    /// Whether the plant carries the passive yaw spring under this law.
    pub fn has_spring(self) -> bool {
        self == YawLaw::Passive
    }

    /// Lower-case name (`passive`, `gain`, `lead`).
    pub fn name(self) -> &'static str {
        match self {
            YawLaw::Passive => "passive",
            YawLaw::Gain => "gain",
            YawLaw::Lead => "lead",
        }
    }
}

impl From<YawLaw> for wheelset_control::YawMode {
    fn from(law: YawLaw) -> Self {
        match law {
            YawLaw::Passive => Self::Passive,
            YawLaw::Gain => Self::Gain,
            YawLaw::Lead => Self::Lead,
        }
    }
}

impl From<wheelset_control::YawMode> for YawLaw {
    fn from(m: wheelset_control::YawMode) -> Self {
        use wheelset_control::YawMode as M;
        match m {
            M::Passive => Self::Passive,
            M::Gain => Self::Gain,
            M::Lead => Self::Lead,
        }
    }
}

/// Continuous-time controllers as ODE states.
///
/// Phase lead: `Ks(s) = K a (s + z)/(s + p) = K a [1 - (p - z)/(s + p)]`, realised as
/// `x_c' = -p x_c + y'`, `T_psi = K a (y' - (p - z) x_c)`.
///
/// PI current loop: `Kt(s) = Kp (1 + 1/(Ti s))`, `e = i_ref - i_a`,
/// `u_a = Kp e + x_i`, `x_i' = Kp e / Ti`; `x_i` in volts, preset to the back-EMF.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ContinuousController {
    /// Yaw law.
    pub law: YawLaw,
    /// `K`, N m s/m (a negative value reverses the sign, for tests).
    pub k: f64,
    /// Lead factor `a`.
    pub lead_a: f64,
    /// Lead zero `z`, rad/s.
    pub lead_z: f64,
    /// Lead pole `p`, rad/s.
    pub lead_p: f64,
    /// PI `Kp`, V/A.
    pub kp: f64,
    /// PI `Ti`, s.
    pub ti: f64,
}

impl ContinuousController {
    /// The paper's controllers with `law`.
    pub fn new(p: &Params, law: YawLaw) -> Self {
        ContinuousController {
            law,
            k: p.k_active,
            lead_a: p.lead_gain,
            lead_z: p.lead_zero,
            lead_p: p.lead_pole,
            kp: p.pi_kp,
            ti: p.pi_ti,
        }
    }

    /// Control torque `T_psi`, N m, from the states (zero for passive).
    #[inline(always)]
    pub fn yaw_torque<S: Scalar>(&self, x: &[S; NX]) -> S {
        let c = S::c;
        match self.law {
            YawLaw::Passive => c(0.0),
            YawLaw::Gain => c(self.k) * x[ix::YD],
            YawLaw::Lead => {
                c(self.k * self.lead_a) * (x[ix::YD] - c(self.lead_p - self.lead_z) * x[ix::LEAD])
            }
        }
    }

    /// Armature voltage `u_a = Kp (i_ref - i_a) + x_i`, V.
    #[inline(always)]
    pub fn voltage<S: Scalar>(&self, x: &[S; NX], i_ref: S) -> S {
        S::c(self.kp) * (i_ref - x[ix::IA]) + x[ix::PI]
    }

    /// The plant's inputs under `e` at `x`: `T_psi` from the yaw law, and with the
    /// `drive` `u_a` from the PI, without it the demand as a torque on the left wheel.
    #[inline(always)]
    pub fn inputs<S: Scalar>(&self, x: &[S; NX], e: &Exogenous<S>, drive: bool) -> Inputs<S> {
        let zero = S::c(0.0);
        Inputs {
            t_psi: self.yaw_torque(x),
            u_a: if drive {
                self.voltage(x, e.i_ref)
            } else {
                zero
            },
            curvature: e.curvature,
            cant: e.cant,
            f_run: e.f_run,
            t_drive: if drive { zero } else { e.demand },
        }
    }
}

/// Exogenous inputs of a closed-loop run (SI; default: straight level track, nothing else).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Exogenous<S> {
    /// Track curvature `1/R`, 1/m.
    pub curvature: S,
    /// Cant angle, rad.
    pub cant: S,
    /// Running resistance, N.
    pub f_run: S,
    /// Current reference, A (drive).
    pub i_ref: S,
    /// Traction demand at the wheel, N m (acts directly on the left wheel without drive).
    pub demand: S,
}

/// The closed loop's right-hand side: the plant with `T_psi` from the yaw law and `u_a`
/// from the PI, plus the controller states (generic for the complex step and the flags).
#[inline(always)]
pub fn closed_loop_rhs<S: Scalar, F: Flags>(
    plant: &Plant,
    f: F,
    ctrl: &ContinuousController,
    x: &[S; NX],
    e: &Exogenous<S>,
) -> [S; NX] {
    let drive = f.cfg().drive;
    let (mut dx, _) = plant.rhs(f, x, &ctrl.inputs(x, e, drive));
    let c = S::c;
    if ctrl.law == YawLaw::Lead {
        dx[ix::LEAD] = -c(ctrl.lead_p) * x[ix::LEAD] + x[ix::YD];
    }
    if drive {
        dx[ix::PI] = c(ctrl.kp / ctrl.ti) * (e.i_ref - x[ix::IA]);
    }
    dx
}

/// What one sensor frame carries (SI units).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Measurements {
    /// Lateral velocity of the wheelset relative to the track `y'`, m/s.
    pub yd_mps: f64,
    /// Lateral acceleration relative to the track `y''`, m/s^2 (with the actuation held
    /// from the previous period).
    pub ydd_mps2: f64,
    /// Armature current `i_a`, A.
    pub i_a: f64,
    /// Motor speed `theta_m'`, rad/s.
    pub w_m: f64,
    /// Wheel speed (mean of the two wheels), rad/s.
    pub w_wheel: f64,
    /// Traction demand at the wheel, N m.
    pub demand_nm: f64,
    /// Current reference `demand / (n K_m)`, A.
    pub i_ref: f64,
    /// Forward speed `v` (a vehicle's reference speed), m/s.
    pub v_mps: f64,
}

/// What the controller commands (SI units).
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize)]
pub struct Actuation {
    /// Yaw torque `T_psi`, N m, with the sign of eq. 5 (`... = -T_psi`).
    pub t_psi: f64,
    /// Armature voltage `u_a`, V.
    pub u_a: f64,
}

/// A discrete controller called at a fixed period; the plant holds its output (ZOH).
pub trait SampledController {
    /// Sampling period, ns (a multiple of the integration step).
    fn period_ns(&self) -> u64;
    /// One control step at `t_ns` from the (sensor-modelled) measurements.
    fn step(&mut self, t_ns: u64, meas: &Measurements) -> Actuation;
    /// Actuation before the first step (zero torque, `u_a` = the back-EMF).
    fn initial(&self, meas: &Measurements, k_m: f64) -> Actuation {
        Actuation {
            t_psi: 0.0,
            u_a: k_m * meas.w_m,
        }
    }
    /// Whether the actuation is known only when due (a device answering one period late):
    /// [`run_sampled`](crate::sim::run_sampled) then asks [`Self::take_deferred`].
    fn defers(&self) -> bool {
        false
    }
    /// The actuation of the oldest step not yet taken, due from `due_ns`; called once per
    /// step, in order, only when [`Self::defers`].
    fn take_deferred(&mut self, due_ns: u64) -> Actuation {
        let _ = due_ns;
        Actuation::default()
    }
}
