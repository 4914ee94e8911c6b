//! Configuration, validated once ([`Config::validate`]); the tick never fails.

use crate::lead::LeadParams;
use crate::pi::PiParams;
use crate::sample::Sample;
use crate::wsp::WspParams;
use wheelset_proto::units;

/// Yaw control mode ([`wheelset_proto::YawMode`]): `Passive` `T_psi = 0`, `Gain` `T_psi = K y'`, `Lead` `T_psi = Ks(s) y'`.
pub use wheelset_proto::YawMode;

/// Per-unit full scales, `x_pu = x / FS`: signals within `[-2, 2]` pu at their limits.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FullScales {
    /// Lateral velocity y' relative to the track (+ right), m/s (1).
    pub y_dot: f64,
    /// Yaw torque T_psi, N m (1e6: puts the lead's K_hf = 7.875e5 N m s/m at 0.7875 pu).
    pub torque: f64,
    /// Motor current i_a, A (1000).
    pub current: f64,
    /// Motor voltage u_a, V (1e4).
    pub voltage: f64,
    /// Motor speed, rad/s (1000; 925.6 rad/s at 83.3 m/s).
    pub speed: f64,
    /// Traction demand (wheel torque), N m (1e4).
    pub demand: f64,
}

impl Default for FullScales {
    fn default() -> Self {
        Self {
            y_dot: 1.0,
            torque: 1.0e6,
            current: 1.0e3,
            voltage: 1.0e4,
            speed: 1.0e3,
            demand: 1.0e4,
        }
    }
}

/// Input clamps (counted), output limits and the reference ramp (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Limits {
    /// |y'| clamp, m/s (1).
    pub y_dot: f64,
    /// |i_a| clamp, A (2000).
    pub current: f64,
    /// |omega_m| clamp, rad/s (2000).
    pub speed: f64,
    /// |demand| clamp, N m (2e4).
    pub demand: f64,
    /// |T_psi| output limit, N m (2e4).
    pub torque: f64,
    /// u_a lower limit, V (-6000).
    pub voltage_min: f64,
    /// u_a upper limit, V (6000).
    pub voltage_max: f64,
    /// Current-reference slew limit, A/s (2e4: the paper's 115 A step in 5.75 ms).
    pub current_ref_rate: f64,
}

impl Default for Limits {
    fn default() -> Self {
        Self {
            y_dot: 1.0,
            current: 2000.0,
            speed: 2000.0,
            demand: 2.0e4,
            torque: 2.0e4,
            voltage_min: -6000.0,
            voltage_max: 6000.0,
            current_ref_rate: 2.0e4,
        }
    }
}

/// Motor data used by the traction loop: `i_ref = demand/(n K_m)`, back-EMF `K_m omega_m`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motor {
    /// Motor constant `K_m`, V s/rad = N m/A (4.28).
    pub k_m: f64,
    /// Gear ratio `n` (5).
    pub n: f64,
}

impl Default for Motor {
    fn default() -> Self {
        Self { k_m: 4.28, n: 5.0 }
    }
}

/// Wire LSBs (SI value of one code); default the protocol's `wheelset_proto::units`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WireLsb {
    /// y', m/s per code ([`units::LAT_VEL_LSB_M_PER_S`]).
    pub y_dot: f64,
    /// Current, A per code ([`units::CURRENT_LSB_A`]).
    pub current: f64,
    /// Motor speed, rad/s per code ([`units::SPEED_LSB_RAD_PER_S`]).
    pub speed: f64,
    /// Demand, N m per code ([`units::DEMAND_LSB_NM`]).
    pub demand: f64,
    /// Yaw torque, N m per code ([`units::TORQUE_LSB_NM`]).
    pub torque: f64,
    /// Voltage, V per code ([`units::VOLTAGE_LSB_V`]).
    pub voltage: f64,
}

impl Default for WireLsb {
    fn default() -> Self {
        Self {
            y_dot: units::LAT_VEL_LSB_M_PER_S,
            current: units::CURRENT_LSB_A,
            speed: units::SPEED_LSB_RAD_PER_S,
            demand: units::DEMAND_LSB_NM,
            torque: units::TORQUE_LSB_NM,
            voltage: units::VOLTAGE_LSB_V,
        }
    }
}

/// Safe-state ramp times of the yaw torque limit and the current reference to zero.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SafeRamps {
    /// Yaw torque limit from `limits.torque` to 0, s (0.1).
    pub yaw_s: f64,
    /// Current reference from the largest reference (`limits.demand/(n K_m)`) to 0, s (0.5).
    pub traction_s: f64,
}

impl Default for SafeRamps {
    fn default() -> Self {
        Self {
            yaw_s: 0.1,
            traction_s: 0.5,
        }
    }
}

/// The whole controller configuration. `Default` is the project default.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// Base tick rate, Hz (one [`crate::Controller::tick`] per period).
    pub base_rate_hz: u32,
    /// The yaw loop runs every `yaw_divisor` ticks.
    pub yaw_divisor: u16,
    /// The traction loop runs every `traction_divisor` ticks.
    pub traction_divisor: u16,
    /// Ticks from sampling to actuation the gains are designed for ([`crate::design`]).
    pub delay_ticks: u8,
    /// Yaw mode at start.
    pub yaw_mode: YawMode,
    /// Traction loop on at start.
    pub traction_enabled: bool,
    /// Phase-lead parameters.
    pub lead: LeadParams,
    /// Pure-gain `K`, N m s/m (1.05e5).
    pub gain_k: f64,
    /// Yaw delay compensation `tau`, base ticks: `y'_p = y' + (tau/T_yaw) (y'[n] - y'[n-1])`,
    /// `tau/T_yaw` in `[0, 2)`; default 1.5 (the ZOH's half period plus the tick of delay), 0 = off.
    pub yaw_predict_ticks: f64,
    /// PI parameters.
    pub pi: PiParams,
    /// Motor constants.
    pub motor: Motor,
    /// Limits.
    pub limits: Limits,
    /// Safe-state ramps.
    pub safe: SafeRamps,
    /// Per-unit full scales.
    pub scales: FullScales,
    /// Wire LSBs.
    pub wire: WireLsb,
    /// Wheel-slip protection ([`crate::wsp`]).
    pub wsp: WspParams,
}

/// Default base rate, Hz (the rate analysis: `docs/closed-loop.md`).
pub const DEFAULT_BASE_RATE_HZ: u32 = 5000;

impl Default for Config {
    fn default() -> Self {
        Self {
            base_rate_hz: DEFAULT_BASE_RATE_HZ,
            yaw_divisor: 1,
            traction_divisor: 1,
            delay_ticks: 1,
            yaw_mode: YawMode::Lead,
            traction_enabled: true,
            lead: LeadParams::default(),
            gain_k: 1.05e5,
            yaw_predict_ticks: 1.5,
            pi: PiParams::default(),
            motor: Motor::default(),
            limits: Limits::default(),
            safe: SafeRamps::default(),
            scales: FullScales::default(),
            wire: WireLsb::default(),
            wsp: WspParams::default(),
        }
    }
}

/// A configuration error: names the field and the reason.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ConfigError {
    /// A parameter is NaN or infinite.
    NotFinite {
        /// Field (group) name.
        field: &'static str,
    },
    /// A parameter is out of its valid range.
    Range {
        /// Field name.
        field: &'static str,
        /// The offending value.
        value: f64,
        /// Why.
        reason: &'static str,
    },
    /// A (per-unit) coefficient or scale does not fit its fixed-point format.
    Coefficient {
        /// Coefficient name.
        name: &'static str,
        /// Its value.
        value: f64,
    },
}

impl core::fmt::Display for ConfigError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::NotFinite { field } => write!(f, "config field `{field}`: not a finite number"),
            Self::Range {
                field,
                value,
                reason,
            } => write!(f, "config field `{field}` = {value}: {reason}"),
            Self::Coefficient { name, value } => write!(
                f,
                "coefficient `{name}` = {value:e} does not fit the sample type's coefficient \
                 format (fixed point: Q1.31, (-1, 1)); change the full scales"
            ),
        }
    }
}

impl core::error::Error for ConfigError {}

impl ConfigError {
    /// `v`, or the [`ConfigError::Coefficient`] `name` = `value` that did not fit.
    pub(crate) fn fit<V>(v: Option<V>, name: &'static str, value: f64) -> Result<V, Self> {
        v.ok_or(Self::Coefficient { name, value })
    }
}

/// `value` quantised as a coefficient of `T`, or the error naming it.
pub(crate) fn coeff<T: Sample>(name: &'static str, value: f64) -> Result<T::Coeff, ConfigError> {
    ConfigError::fit(T::quantise(value), name, value)
}

/// `Ok` when `ok` holds for a finite `value`; else `NotFinite` or `Range` naming `field`.
pub(crate) fn range(
    field: &'static str,
    value: f64,
    ok: bool,
    reason: &'static str,
) -> Result<(), ConfigError> {
    if !value.is_finite() {
        return Err(ConfigError::NotFinite { field });
    }
    in_range(field, value, ok, reason)
}

/// `Ok` if `ok`, else [`ConfigError::Range`] naming `field` (`ok` judges a non-finite `value`).
pub(crate) fn in_range(
    field: &'static str,
    value: f64,
    ok: bool,
    reason: &'static str,
) -> Result<(), ConfigError> {
    if ok {
        Ok(())
    } else {
        Err(ConfigError::Range {
            field,
            value,
            reason,
        })
    }
}

/// [`range`] of each `(field, value)` in turn: the value must be positive.
fn positive(reason: &'static str, values: &[(&'static str, f64)]) -> Result<(), ConfigError> {
    values
        .iter()
        .try_for_each(|&(field, v)| range(field, v, v > 0.0, reason))
}

/// Largest per-unit magnitude of a clamped input or limit (the Q4.28 range analysis).
pub const MAX_LIMIT_PU: f64 = 2.0;

impl Config {
    /// Yaw loop period, s.
    pub fn yaw_period(&self) -> f64 {
        self.yaw_divisor as f64 / self.base_rate_hz as f64
    }
    /// Traction loop period, s.
    pub fn traction_period(&self) -> f64 {
        self.traction_divisor as f64 / self.base_rate_hz as f64
    }
    /// Base period, s.
    pub fn base_period(&self) -> f64 {
        1.0 / self.base_rate_hz as f64
    }

    /// Check every field, then the discretisations; the first problem found is returned.
    pub fn validate(&self) -> Result<(), ConfigError> {
        range(
            "base_rate_hz",
            self.base_rate_hz as f64,
            (100..=100_000).contains(&self.base_rate_hz),
            "base rate must be 100 Hz .. 100 kHz",
        )?;
        for (field, d) in [
            ("yaw_divisor", self.yaw_divisor),
            ("traction_divisor", self.traction_divisor),
        ] {
            range(field, f64::from(d), d >= 1, "divisor must be >= 1")?;
        }
        range(
            "delay_ticks",
            f64::from(self.delay_ticks),
            self.delay_ticks >= 1,
            "delay must be >= 1 tick",
        )?;
        let s = &self.scales;
        for (field, v) in [
            ("scales.y_dot", s.y_dot),
            ("scales.torque", s.torque),
            ("scales.current", s.current),
            ("scales.voltage", s.voltage),
            ("scales.speed", s.speed),
            ("scales.demand", s.demand),
        ] {
            range(field, v, v > 0.0, "full scale must be positive")?;
        }
        let l = &self.limits;
        let pu_ok = |v: f64, fs: f64| v > 0.0 && v / fs <= MAX_LIMIT_PU;
        const R: &str = "must be positive and at most 2 full scales (Q4.28 range analysis)";
        range("limits.y_dot", l.y_dot, pu_ok(l.y_dot, s.y_dot), R)?;
        range("limits.current", l.current, pu_ok(l.current, s.current), R)?;
        range("limits.speed", l.speed, pu_ok(l.speed, s.speed), R)?;
        range("limits.demand", l.demand, pu_ok(l.demand, s.demand), R)?;
        range("limits.torque", l.torque, pu_ok(l.torque, s.torque), R)?;
        range(
            "limits.voltage_max",
            l.voltage_max,
            l.voltage_max.abs() / s.voltage <= MAX_LIMIT_PU && l.voltage_max > l.voltage_min,
            "need voltage_min < voltage_max, both within 2 full scales",
        )?;
        range(
            "limits.voltage_min",
            l.voltage_min,
            l.voltage_min.abs() / s.voltage <= MAX_LIMIT_PU,
            R,
        )?;
        positive(
            "must be positive",
            &[
                ("limits.current_ref_rate", l.current_ref_rate),
                ("motor.k_m", self.motor.k_m),
                ("motor.n", self.motor.n),
            ],
        )?;
        range(
            "limits.demand",
            l.demand,
            l.demand / (self.motor.n * self.motor.k_m) / s.current <= MAX_LIMIT_PU,
            "the largest current reference demand/(n K_m) must be within 2 current full scales",
        )?;
        range("gain_k", self.gain_k, true, "")?;
        let alpha = self.yaw_predict_ticks / self.yaw_divisor as f64;
        range(
            "yaw_predict_ticks",
            self.yaw_predict_ticks,
            (0.0..2.0).contains(&alpha),
            "yaw_predict_ticks / yaw_divisor must be in [0, 2)",
        )?;
        positive(
            "must be positive",
            &[
                ("safe.yaw_s", self.safe.yaw_s),
                ("safe.traction_s", self.safe.traction_s),
            ],
        )?;
        let w = &self.wire;
        for (field, v) in [
            ("wire.y_dot", w.y_dot),
            ("wire.current", w.current),
            ("wire.speed", w.speed),
            ("wire.demand", w.demand),
            ("wire.torque", w.torque),
            ("wire.voltage", w.voltage),
        ] {
            range(field, v, v > 0.0, "LSB must be positive")?;
        }
        self.lead.discretise(self.yaw_period())?;
        self.pi.discretise(self.traction_period())?;
        crate::wsp::Wsp::<f64>::try_new(&self.wsp, &self.motor, s, l, self.wire.speed, &self.lead)?;
        Ok(())
    }
}
