//! PI traction current controller `Kt(s) = Kp (1 + 1/(Ti s))`, backward Euler, with
//! clamping anti-windup:
//!
//! ```text
//! e[n] = r[n] - i[n]                                            (A; pu inside)
//! I[n] = clamp(I[n-1] + Ki e[n], u_min, u_max),  Ki = Kp T/Ti
//! u[n] = clamp(Kp e[n] + I[n], u_min, u_max)
//! fixed point:  Ki e[n] = floor((e c + r) / 2^(31+s)),  c = round(Ki 2^(31+s)), remainder carried in r
//! ```
//!
//! The integrator's pole is exactly `z = 1` (no coefficient multiplies the state).

use crate::sample::Sample;
use crate::ConfigError;

/// The slowest traction period a device accepts, s: `Ki`'s shift is set to fit `Ki` there.
pub const KI_SHIFT_PERIOD_S: f64 = 1.0 / wheelset_proto::plausible::LOOP_RATE_MIN_HZ as f64;

/// The continuous PI: `Kp (1 + 1/(Ti s))`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiParams {
    /// Proportional gain `Kp`, V/A (1).
    pub kp: f64,
    /// Integral time `Ti`, s (0.5; the appendix's 0.05 is also valid).
    pub ti: f64,
}

impl Default for PiParams {
    fn default() -> Self {
        Self { kp: 1.0, ti: 0.5 }
    }
}

impl PiParams {
    /// Backward-Euler discretisation at period `t_s`.
    pub fn discretise(&self, t_s: f64) -> Result<PiDiscrete, ConfigError> {
        if !(self.kp.is_finite() && self.ti.is_finite() && t_s.is_finite()) {
            return Err(ConfigError::NotFinite { field: "pi" });
        }
        if self.kp <= 0.0 || self.ti <= 0.0 || t_s <= 0.0 {
            return Err(ConfigError::Range {
                field: "pi.kp/ti",
                value: self.kp.min(self.ti),
                reason: "Kp and Ti must be positive",
            });
        }
        Ok(PiDiscrete {
            t_s,
            kp: self.kp,
            ki: self.kp * t_s / self.ti,
        })
    }
}

/// The discrete PI in SI units (V/A).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiDiscrete {
    /// Sample period, s.
    pub t_s: f64,
    /// `Kp`, V/A.
    pub kp: f64,
    /// `Ki = Kp T/Ti`, V/A per sample.
    pub ki: f64,
}

impl PiDiscrete {
    /// Per-unit coefficients for `e_pu = e/current_fs`, `u_pu = u/voltage_fs`.
    pub fn to_pu(&self, current_fs: f64, voltage_fs: f64) -> PiPu {
        let s = current_fs / voltage_fs;
        PiPu {
            kp: self.kp * s,
            ki: self.ki * s,
        }
    }
}

/// Per-unit PI coefficients.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PiPu {
    /// `Kp current_fs/voltage_fs`.
    pub kp: f64,
    /// `Ki current_fs/voltage_fs`.
    pub ki: f64,
}

/// The PI as it runs: quantised coefficients and output limits; `repr(C)` in read order.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Pi<T: Sample> {
    /// `Ki 2^ki_shift`, quantised.
    pub(crate) ki: T::Coeff,
    /// `Ki`'s shift `s` ([`Sample::acc_shift`]; 0 for floats).
    pub(crate) ki_shift: u32,
    /// Lower output (and integrator) limit, pu.
    pub u_min: T,
    /// Upper output (and integrator) limit, pu.
    pub u_max: T,
    pub(crate) kp: T::Coeff,
}

/// The PI's state: the integrator `I[n-1]` (pu) and its sub-LSB remainder.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct PiState<T: Sample> {
    /// Integrator, pu of voltage.
    pub integ: T,
    /// The increment's remainder below one LSB (error feedback, [`Sample::mul_c_acc`]).
    pub residue: T::Residue,
}

impl<T: Sample> PiState<T> {
    /// A state with the integrator at `integ` (pu) and no remainder.
    pub fn new(integ: T) -> Self {
        Self {
            integ,
            residue: T::Residue::default(),
        }
    }
}

/// Which limits engaged in one PI step.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct PiFlags {
    /// The integrator was clamped (anti-windup active).
    pub integ: bool,
    /// The output was clamped.
    pub output: bool,
}

impl<T: Sample> Pi<T> {
    /// Quantise the coefficients; limits in pu (`u_min < u_max`); `Ki`'s shift for `pu.ki`.
    pub fn new(pu: &PiPu, u_min: f64, u_max: f64) -> Result<Self, ConfigError> {
        Self::with_ki_max(pu, pu.ki, u_min, u_max)
    }

    /// As [`Self::new`], `Ki`'s shift chosen for `ki_max` (pu, `>= pu.ki`).
    pub fn with_ki_max(
        pu: &PiPu,
        ki_max: f64,
        u_min: f64,
        u_max: f64,
    ) -> Result<Self, ConfigError> {
        let q = crate::config::coeff::<T>;
        let ki_shift = ConfigError::fit(T::acc_shift(ki_max.max(pu.ki)), "pi.ki (pu)", pu.ki)?;
        if u_min.partial_cmp(&u_max) != Some(core::cmp::Ordering::Less) {
            return Err(ConfigError::Range {
                field: "limits.voltage_min/max",
                value: u_min,
                reason: "need voltage_min < voltage_max",
            });
        }
        Ok(Self {
            kp: q("pi.kp (pu)", pu.kp)?,
            ki: q("pi.ki (pu)", pu.ki * pow2(ki_shift))?,
            ki_shift,
            u_min: T::from_f64(u_min),
            u_max: T::from_f64(u_max),
        })
    }

    /// The quantised coefficients as f64.
    pub fn quantised(&self) -> PiPu {
        PiPu {
            kp: T::coeff_to_f64(self.kp),
            ki: T::coeff_to_f64(self.ki) / pow2(self.ki_shift),
        }
    }

    /// `Ki`'s shift `s`: the coefficient is held as `Ki 2^s` (0 for floats).
    pub fn ki_shift(&self) -> u32 {
        self.ki_shift
    }

    /// One step on the error `e` (pu), reporting which limits engaged.
    #[inline(always)]
    pub fn process_flags(&self, s: &mut PiState<T>, e: T) -> (T, PiFlags) {
        let (i, fi) = s
            .integ
            .sat_add(e.mul_c_acc_shr(self.ki, self.ki_shift, &mut s.residue))
            .limit(self.u_min, self.u_max);
        s.integ = i;
        let (u, fo) = e.mul_c(self.kp).sat_add(i).limit(self.u_min, self.u_max);
        (
            u,
            PiFlags {
                integ: fi,
                output: fo,
            },
        )
    }

    /// One step on the error `e` (pu): `u = clamp(Kp e + I)`.
    #[inline]
    pub fn process(&self, s: &mut PiState<T>, e: T) -> T {
        self.process_flags(s, e).0
    }

    /// Preset the integrator to `u0` (pu), clamped to the limits; NaN gives 0.
    pub fn preset(&self, s: &mut PiState<T>, u0: T) {
        *s = PiState::new(u0.sanitize().0.limit(self.u_min, self.u_max).0);
    }
}

/// `2^s` exactly (`s < 64`).
pub(crate) fn pow2(s: u32) -> f64 {
    (1u64 << s) as f64
}
