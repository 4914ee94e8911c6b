//! Phase-lead yaw damping `Ks(s) = K a (s + w1)/(s + w2)` by Tustin, evaluated as a
//! high-pass around a low-pass rather than a direct form (whose `b0 ~ -b1` loses the DC
//! gain in a narrow Q format). Sign: `T_psi = +Ks(s) y'`.
//!
//! ```text
//! Ks(s) = K_hf (1 - g w2/(s + w2)),  K_hf = K a,  g = (w2 - w1)/w2
//! c      = w2 T/2   (or w2 tan(wp T/2)/wp, pre-warped at wp)
//! alpha  = (1 - c)/(1 + c),  kappa = 1 - alpha = 2c/(1 + c)
//! z[n]   = z[n-1] + kappa ( (g/2)(x[n] + x[n-1]) - z[n-1] )
//! y[n]   = K_hf (x[n] - z[n])
//! ```

use crate::sample::Sample;
use crate::ConfigError;

/// The continuous phase lead `Ks(s) = k a (s + w1)/(s + w2)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeadParams {
    /// `K`, N m s/m (1.05e5).
    pub k: f64,
    /// `a`, dimensionless high-frequency gain factor (7.5).
    pub a: f64,
    /// Zero `w1`, rad/s (37).
    pub w1: f64,
    /// Pole `w2`, rad/s (274).
    pub w2: f64,
    /// Tustin pre-warping frequency, rad/s; `0` = none (plain bilinear).
    pub prewarp_rad_s: f64,
}

impl Default for LeadParams {
    /// The paper's lead: `1.05e5 * 7.5 (s + 37)/(s + 274)`, no pre-warping.
    fn default() -> Self {
        Self {
            k: 1.05e5,
            a: 7.5,
            w1: 37.0,
            w2: 274.0,
            prewarp_rad_s: 0.0,
        }
    }
}

impl LeadParams {
    /// DC gain `k a w1/w2`, N m s/m.
    pub fn dc_gain(&self) -> f64 {
        self.k * self.a * self.w1 / self.w2
    }

    /// Tustin discretisation at period `t_s` s; errors: bad parameters, `w1 >= w2`,
    /// `prewarp >= pi/T`, or `c >= 1` (a negative pole; the range analysis needs `alpha > 0`).
    pub fn discretise(&self, t_s: f64) -> Result<LeadDiscrete, ConfigError> {
        let fin = |v: f64| v.is_finite();
        if !(fin(self.k) && fin(self.a) && fin(self.w1) && fin(self.w2) && fin(t_s)) {
            return Err(ConfigError::NotFinite { field: "lead" });
        }
        if self.w1 <= 0.0 || self.w2 <= self.w1 || t_s <= 0.0 {
            return Err(ConfigError::Range {
                field: "lead.w1/w2",
                value: self.w1,
                reason: "need 0 < w1 < w2 (a phase lead) and a positive period",
            });
        }
        let wp = self.prewarp_rad_s;
        let c = if wp == 0.0 {
            self.w2 * t_s / 2.0
        } else if wp > 0.0 && wp * t_s < core::f64::consts::PI * 0.9 {
            self.w2 * tan_small(wp * t_s / 2.0) / wp
        } else {
            return Err(ConfigError::Range {
                field: "lead.prewarp_rad_s",
                value: wp,
                reason: "pre-warp frequency must be >= 0 and below 0.45 of the yaw sample rate",
            });
        };
        if c >= 1.0 {
            return Err(ConfigError::Range {
                field: "yaw rate",
                value: 1.0 / t_s,
                reason: "w2 T/2 >= 1: the yaw rate is too low for the lead (negative pole)",
            });
        }
        let alpha = (1.0 - c) / (1.0 + c);
        Ok(LeadDiscrete {
            t_s,
            k_hf: self.k * self.a,
            g: (self.w2 - self.w1) / self.w2,
            c,
            alpha,
            kappa: 2.0 * c / (1.0 + c),
        })
    }
}

/// `tan(x)` for `0 <= x < 1.42` without libm: Lambert's continued fraction, ~1e-15.
pub(crate) fn tan_small(x: f64) -> f64 {
    let x2 = x * x;
    let mut d = 25.0;
    for k in (1..=23u8).rev().step_by(2) {
        d = f64::from(k) - x2 / d;
    }
    x / d
}

/// The discrete lead in SI units (f64, auditable): see the module docs for equations.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeadDiscrete {
    /// Sample period, s.
    pub t_s: f64,
    /// `K_hf = K a`, N m s/m.
    pub k_hf: f64,
    /// Low-pass DC gain `g = (w2 - w1)/w2`.
    pub g: f64,
    /// Tustin's `c = w2 T/2` (or pre-warped).
    pub c: f64,
    /// Discrete pole `alpha = (1 - c)/(1 + c)`.
    pub alpha: f64,
    /// `kappa = 1 - alpha`.
    pub kappa: f64,
}

impl LeadDiscrete {
    /// DC gain of the discrete filter, `K_hf (1 - g)`, N m s/m.
    pub fn dc_gain(&self) -> f64 {
        self.k_hf * (1.0 - self.g)
    }

    /// The per-unit coefficients for `y_pu = T_psi/torque_fs`, `x_pu = y'/y_dot_fs`.
    pub fn to_pu(&self, y_dot_fs: f64, torque_fs: f64) -> LeadPu {
        LeadPu {
            k_hf: self.k_hf * y_dot_fs / torque_fs,
            g_half: self.g / 2.0,
            kappa: self.kappa,
        }
    }
}

/// Per-unit lead coefficients, the values the filter multiplies by.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeadPu {
    /// `K_hf y_dot_fs/torque_fs`.
    pub k_hf: f64,
    /// `g/2`.
    pub g_half: f64,
    /// `kappa`.
    pub kappa: f64,
}

/// The lead as it runs: quantised per-unit coefficients; `repr(C)` in read order.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Lead<T: Sample> {
    pub(crate) kappa: T::Coeff,
    pub(crate) k_hf: T::Coeff,
    pub(crate) g_half: T::Coeff,
}

/// The lead's state: previous input `x[n-1]` and the low-pass output `z[n-1]` (pu).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LeadState<T> {
    /// `x[n-1]`.
    pub x1: T,
    /// `z[n-1]`.
    pub z: T,
}

impl<T: Sample> Lead<T> {
    /// Quantise per-unit coefficients. Error names the coefficient that does not fit.
    pub fn new(pu: &LeadPu) -> Result<Self, ConfigError> {
        let q = crate::config::coeff::<T>;
        Ok(Self {
            k_hf: q("lead.k_hf (pu)", pu.k_hf)?,
            g_half: q("lead.g_half", pu.g_half)?,
            kappa: q("lead.kappa", pu.kappa)?,
        })
    }

    /// The quantised coefficients, exactly, as f64 (for the audit).
    pub fn quantised(&self) -> LeadPu {
        LeadPu {
            k_hf: T::coeff_to_f64(self.k_hf),
            g_half: T::coeff_to_f64(self.g_half),
            kappa: T::coeff_to_f64(self.kappa),
        }
    }

    /// One step: `z += kappa ((g/2)(x + x1) - z)`, `x1 = x`, `y = K_hf (x - z)` (pu).
    #[inline(always)]
    pub fn process(&self, s: &mut LeadState<T>, x: T) -> T {
        self.advance(s, x).mul_c(self.k_hf)
    }

    /// The state update alone, returning `x - z[n]` (pu); [`Self::process`] is `K_hf` times it.
    #[inline(always)]
    pub fn advance(&self, s: &mut LeadState<T>, x: T) -> T {
        let m = x.sat_add(s.x1);
        let e = m.mul_c(self.g_half).sat_sub(s.z);
        s.z = s.z.sat_add(e.mul_c(self.kappa));
        s.x1 = x;
        x.sat_sub(s.z)
    }

    /// The steady state for a constant `x` (`z = g x`): switching in from it is bumpless.
    pub fn steady_state(&self, x: T) -> LeadState<T> {
        LeadState {
            x1: x,
            z: x.sat_add(x).mul_c(self.g_half),
        }
    }
}
