//! SI <-> wire codes on the host (`std`): `count = round(x / LSB)`, `x = count * LSB`.
//!
//! ```
//! use wheelset_proto::{Lateral, LateralSensing, Sensor, SensorSi};
//! let m = SensorSi { y_dot: 2.0004e-3, i_a: 115.0, w_m: 925.6, demand_nm: 2460.0,
//!                    ..SensorSi::default() };
//! let q = Sensor::from_si(7, 1_400_000, &m, LateralSensing::Velocity);
//! assert_eq!(q.msg.lateral, Lateral::Velocity(2_000));  // 1 um/s LSB
//! assert_eq!((q.msg.i_a_ma, q.msg.omega_m_mrad_s), (115_000, 925_600));
//! assert_eq!(q.msg.t_us, 1_400);                          // t_ns / 1000 mod 2^16
//! assert_eq!(q.clamped, 0);
//! ```

use crate::units::{
    self, CURRENT_LSB_A, DEMAND_LSB_NM, LAT_ACC_LSB_M_PER_S2, LAT_VEL_LSB_M_PER_S,
    SPEED_LSB_RAD_PER_S, TORQUE_LSB_NM, VOLTAGE_LSB_V, V_REF_LSB_M_PER_S,
};
use crate::{Actuation, Lateral, Sensor};

/// What a Sensor frame carries of the lateral motion.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LateralSensing {
    /// `y'` only ([`Lateral::Velocity`], the default).
    #[default]
    Velocity,
    /// `y''` only ([`Lateral::Acceleration`]): the device integrates it.
    Acceleration,
    /// Both ([`Lateral::Both`]).
    Both,
}

/// The measurements the host samples, SI; signs as in [`Sensor`].
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SensorSi {
    /// Lateral velocity of the wheelset relative to the track `y'`, m/s.
    pub y_dot: f64,
    /// Lateral acceleration relative to the track `y''`, m/s^2.
    pub y_ddot: f64,
    /// Motor armature current `i_a`, A.
    pub i_a: f64,
    /// Motor speed `theta_m'`, rad/s.
    pub w_m: f64,
    /// Traction demand as wheel torque `n K_m i_ref`, N m.
    pub demand_nm: f64,
    /// Vehicle reference speed `v`, m/s, positive forwards (0: unknown).
    pub v_ref: f64,
}

/// The actuation a device commands, SI units: what the plant applies.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct ActuationSi {
    /// Yaw torque `T_psi`, N m (sign as in [`Actuation::t_psi_dnm`]).
    pub t_psi: f64,
    /// Motor voltage `u_a`, V.
    pub u_a: f64,
}

/// A message quantised from SI values, with the number of values that did not fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Quantized<M> {
    /// The message.
    pub msg: M,
    /// Values clamped to the `i32` range or NaN mapped to 0 (see [`units::quantize`]).
    pub clamped: u32,
}

/// Host timestamp field of the sample instant `t_ns`: `t_ns / 1000` modulo 2^16 (us).
#[must_use]
pub fn t_us_of(t_ns: u64) -> u16 {
    ((t_ns / 1_000) & 0xffff) as u16
}

impl Sensor {
    /// The Sensor frame `seq` of the sample `m` at `t_ns` (host time, ns), lateral as asked.
    #[must_use]
    pub fn from_si(seq: u16, t_ns: u64, m: &SensorSi, lateral: LateralSensing) -> Quantized<Self> {
        let mut clamped = 0u32;
        let mut q = |x: f64, lsb: f64| {
            let (v, c) = units::quantize(x, lsb);
            clamped += u32::from(c);
            v
        };
        let lateral = match lateral {
            LateralSensing::Velocity => Lateral::Velocity(q(m.y_dot, LAT_VEL_LSB_M_PER_S)),
            LateralSensing::Acceleration => {
                Lateral::Acceleration(q(m.y_ddot, LAT_ACC_LSB_M_PER_S2))
            }
            LateralSensing::Both => Lateral::Both {
                vel_um_s: q(m.y_dot, LAT_VEL_LSB_M_PER_S),
                acc_dmm_s2: q(m.y_ddot, LAT_ACC_LSB_M_PER_S2),
            },
        };
        let msg = Sensor {
            seq,
            t_us: t_us_of(t_ns),
            lateral,
            i_a_ma: q(m.i_a, CURRENT_LSB_A),
            omega_m_mrad_s: q(m.w_m, SPEED_LSB_RAD_PER_S),
            demand_nm: q(m.demand_nm, DEMAND_LSB_NM),
            v_ref_mm_s: q(m.v_ref, V_REF_LSB_M_PER_S),
        };
        Quantized { msg, clamped }
    }
}

impl Actuation {
    /// The commanded actuation in SI: `T_psi = t_psi_dnm * 0.1 N m`, `u_a = u_a_cv * 10 mV`.
    #[must_use]
    pub fn to_si(&self) -> ActuationSi {
        ActuationSi {
            t_psi: units::to_si(self.t_psi_dnm, TORQUE_LSB_NM),
            u_a: units::to_si(self.u_a_cv, VOLTAGE_LSB_V),
        }
    }
}
