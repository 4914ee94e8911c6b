//! Build-time bits: [`RuntimeConfig`], its exact bits [`RuntimeBits`], and [`rates_for`].

use wheelset_control::design::DESIGNED;
use wheelset_control::{
    BitsError, Compiled, CompiledBits, Config as ControlConfig, ConfigError, Monitor, MonitorBits,
    MonitorParams, SampleBits, WireLsb,
};

use crate::{acc_factors, AccBits, Rates, DEFAULT_HOLD_TICKS};

/// The runtime configuration: the core's configuration and the fault policy. Boot defaults:
/// protection on, monitor on, its safe action off: the actuator replaces the yaw spring, so
/// zero torque would leave the wheelset with neither (`the_passive_less_wheelset_is_unstable`).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RuntimeConfig {
    /// The core's configuration; its `wire` LSBs are overwritten with the protocol's.
    pub control: ControlConfig,
    /// Ticks without a new sensor frame bridged by the held sample (0: none).
    pub hold_ticks: u16,
    /// Outputs enabled at start.
    pub enable: bool,
    /// Wash-out time constant of the `y''` integrator, s, `v[n] = v[n-1] (1 - T/tau) + a[n] T`
    /// (against accelerometer offset drift; 0: a pure integrator).
    pub acc_washout_s: f64,
    /// The stability monitor (`wheelset_control::monitor`); `None`: off.
    pub monitor: Option<MonitorParams>,
    /// The configuration at the paper's point whose designs the device accepts (`None`: `control`).
    pub design: Option<ControlConfig>,
}

impl RuntimeConfig {
    /// The configuration at a design point: what a host sends to change the rate.
    pub fn designed(&self, base_rate_hz: u32, delay_ticks: u8) -> Result<Self, RuntimeError> {
        let base = self.design_base();
        let control = base.designed(base_rate_hz, delay_ticks)?;
        Ok(Self {
            control,
            design: if control == base {
                self.design
            } else {
                Some(base)
            },
            ..*self
        })
    }

    /// The configuration the designs are scaled from ([`Self::design`]).
    pub fn design_base(&self) -> ControlConfig {
        self.design.unwrap_or(self.control)
    }
}

/// Default wash-out of the `y''` integrator: 2 s (corner 0.08 Hz, far below the ~10 Hz kinematic mode).
pub const DEFAULT_ACC_WASHOUT_S: f64 = 2.0;

impl Default for RuntimeConfig {
    fn default() -> Self {
        Self {
            control: ControlConfig::default(),
            hold_ticks: DEFAULT_HOLD_TICKS,
            enable: true,
            acc_washout_s: DEFAULT_ACC_WASHOUT_S,
            monitor: Some(MonitorParams::default()),
            design: None,
        }
    }
}

/// Why a runtime could not be built.
#[derive(Debug, Clone, Copy, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RuntimeError {
    /// The control configuration is invalid.
    Control(ConfigError),
    /// The wash-out time constant is negative, not finite, or shorter than one tick.
    Washout,
    /// Exact bits ([`RuntimeBits`], [`Rates`]) are invalid: the field named.
    Bits(BitsError),
    /// The design base differs from the core in its rate-independent part.
    Design,
}

impl core::fmt::Display for RuntimeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            Self::Control(e) => write!(f, "runtime: control configuration: {e}"),
            Self::Washout => write!(
                f,
                "runtime: acc_washout_s must be 0 or a finite time of at least one tick"
            ),
            Self::Bits(e) => write!(f, "runtime: {e}"),
            Self::Design => write!(
                f,
                "runtime: the design base differs from the control core beyond its rates and gains"
            ),
        }
    }
}

impl From<BitsError> for RuntimeError {
    fn from(e: BitsError) -> Self {
        Self::Bits(e)
    }
}

impl From<ConfigError> for RuntimeError {
    fn from(e: ConfigError) -> Self {
        Self::Control(e)
    }
}

/// A whole runtime configuration as exact bits: the firmware's build-time constant.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RuntimeBits {
    /// The control core ([`Compiled::to_bits`]).
    pub control: CompiledBits,
    /// The `y''` integrator.
    pub acc: AccBits,
    /// [`RuntimeConfig::hold_ticks`].
    pub hold_ticks: u16,
    /// [`RuntimeConfig::enable`].
    pub enable: bool,
    /// The stability monitor ([`RuntimeConfig::monitor`]; `rate_hz` 0: off).
    pub monitor: MonitorBits,
    /// The rates a Config may set ([`Designs`]).
    pub designs: Designs,
}

/// The designs a device accepts, one per point of [`wheelset_control::design::DESIGNED`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Designs {
    /// The rates [`rates_for`] computes; a received [`Rates`] must be one, bit for bit.
    pub rates: [Rates; DESIGNED.len()],
    /// Per design: its yaw law is designed ([`wheelset_control::design::DesignPoint::yaw`]).
    pub yaw: [bool; DESIGNED.len()],
}

impl RuntimeBits {
    /// Compile `cfg` for `T` (the protocol's wire LSBs replace `cfg.control.wire`). Host use.
    pub fn try_new<T: SampleBits>(cfg: &RuntimeConfig) -> Result<Self, RuntimeError> {
        let control = &cfg.control;
        let monitor = match &cfg.monitor {
            Some(p) => {
                // The drive check's level is in pu of the core's current scale.
                let p = MonitorParams {
                    current_scale_a: control.scales.current,
                    ..*p
                };
                Monitor::<T>::try_new(&p, control.base_rate_hz)?.to_bits()
            }
            None => Monitor::<T>::default().to_bits(),
        };
        let compiled = compile::<T>(cfg)?;
        let mut designed = [rates_of(&compiled, acc_factors(cfg)?)?; DESIGNED.len()];
        for (slot, p) in designed.iter_mut().zip(DESIGNED) {
            let at = cfg.designed(p.base_rate_hz, p.delay_ticks)?;
            let bits = compile::<T>(&at)?;
            if bits.fingerprint() != compiled.fingerprint() {
                return Err(RuntimeError::Design);
            }
            *slot = rates_of(&bits, acc_factors(&at)?)?;
        }
        Ok(Self {
            control: compiled,
            acc: acc_factors(cfg)?,
            hold_ticks: cfg.hold_ticks,
            enable: cfg.enable,
            monitor,
            designs: Designs {
                rates: designed,
                yaw: DESIGNED.map(|p| p.yaw),
            },
        })
    }
}

/// The bits of `cfg.control` with the protocol's wire LSBs.
fn compile<T: SampleBits>(cfg: &RuntimeConfig) -> Result<CompiledBits, RuntimeError> {
    let control = ControlConfig {
        wire: WireLsb::default(),
        ..cfg.control
    };
    Ok(Compiled::<T>::try_new(&control)?.to_bits())
}

/// The [`Rates`] of compiled bits and the `y''` integrator's factors.
fn rates_of(b: &CompiledBits, acc: AccBits) -> Result<Rates, RuntimeError> {
    let s = b.schedule;
    let w = |field, v: u64| u32::try_from(v).map_err(|_| RuntimeError::Bits(BitsError { field }));
    Ok(Rates {
        numeric: b.numeric,
        fingerprint: b.fingerprint(),
        base_rate_hz: s.base_rate_hz,
        yaw_div: s.yaw_divisor,
        traction_div: s.traction_divisor,
        delay_ticks: s.delay_ticks,
        kappa: w("kappa", s.kappa)?,
        lead_k_hf: w("lead_k_hf", s.lead_k_hf)?,
        wsp_lead_k_hf: w("wsp_lead_k_hf", s.wsp_lead_k_hf)?,
        kp: w("kp", s.kp)?,
        ki: w("ki", s.ki)?,
        ki_shift: s.ki_shift,
        predict_half: w("predict_half", s.predict_half)?,
        iref_step: w("iref_step", s.iref_step)?,
        iref_safe_step: w("iref_safe_step", s.iref_safe_step)?,
        torque_step: w("torque_step", s.torque_step)?,
        acc_gain_q32: acc.gain_q32,
        acc_leak_q32: acc.leak_q32,
    })
}

/// The [`Rates`] that switch a device running `T` to the rates and gains of `cfg`; errors:
/// `cfg` invalid, or `T` without a 32-bit wire form (`f64`).
pub fn rates_for<T: SampleBits>(cfg: &RuntimeConfig) -> Result<Rates, RuntimeError> {
    let b = compile::<T>(cfg)?;
    if T::NUMERIC > 1 {
        return Err(RuntimeError::Bits(BitsError { field: "numeric" }));
    }
    rates_of(&b, acc_factors(cfg)?)
}
