//! Build-time bits: the runtime's configuration ([`RuntimeConfig`]), its compiled form as
//! exact bits ([`RuntimeBits`], written by the firmware's build script, the device's
//! start without float maths) and the coefficients of a rate switch ([`rates_for`]),
//! computed on the host with the device's control code.

use wheelset_control::design::DESIGNED;
use wheelset_control::{
    BitsError, Compiled, CompiledBits, Config as ControlConfig, ConfigError, Monitor, MonitorBits,
    MonitorParams, SampleBits, WireLsb,
};

use crate::{acc_factors, AccBits, Rates, DEFAULT_HOLD_TICKS};

/// The runtime configuration: the control core's configuration and the fault policy.
///
/// # The device's boot defaults
///
/// [`RuntimeConfig::default`] is what a board runs from power-on until a host's Config
/// (the firmware's build script compiles it into the binary): the control core's
/// defaults (lead, traction on, 5 kHz, `wheelset_control::Config::default`) with
///
/// - **the wheel-slip protection on** (`WspParams::enabled`): a drive without it runs a
///   slipping wheel away
///   (`sim-host/tests/adhesion.rs`); it needs the Sensor's `v_ref_mm_s`, and while that
///   is 0 (unknown: a host that sends no reference) it stays idle rather than reading a
///   rolling wheel as a slip (`wheelset_control::wsp`, "An unknown reference");
/// - **the stability monitor on** ([`Self::monitor`]), its alarms reported
///   (`HUNTING`, `ACTUATOR_FAULT`, `DRIVE_OSC`, `FAULT_LATCHED`);
/// - **its safe action off** (`Config.monitor_safe = false`, the runtime's start): the
///   safe state zeroes the yaw torque, and in the lead and gain modes the actuator
///   replaces the yaw spring, so zero torque leaves the wheelset with neither (without
///   the actuator it hunts at every conicity of the envelope: `wheelset_plant::fault`, test
///   `the_passive_less_wheelset_is_unstable`). A
///   hunting alarm is then not cured by the device's zero torque; it asks the vehicle
///   to slow down, which the host decides. A host that knows zero torque is the safer
///   failure (an actuator that may act reversed) sets `monitor_safe`;
/// - outputs enabled, `hold_ticks` [`crate::DEFAULT_HOLD_TICKS`], the `y''` wash-out
///   [`DEFAULT_ACC_WASHOUT_S`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RuntimeConfig {
    /// The control core's configuration. Its `wire` LSBs are overwritten with the
    /// protocol's (`WireLsb::default()`, `wheelset_proto::units`): the format has one
    /// definition.
    pub control: ControlConfig,
    /// Consecutive ticks without a new sensor frame that run on the held sample before
    /// the safe state (0: the first missing frame enters it).
    pub hold_ticks: u16,
    /// Outputs enabled at start.
    pub enable: bool,
    /// Wash-out time constant of the `y''` integrator, s (acceleration-only frames):
    /// `v[n] = v[n-1] (1 - T/tau) + a[n] T`. A high-pass against accelerometer offset
    /// drift; 0 disables the wash-out (a pure integrator).
    pub acc_washout_s: f64,
    /// The stability monitor (`wheelset_control::monitor`: hunting and actuator alarms on
    /// the received `y'`); `None`: off (no alarms).
    pub monitor: Option<MonitorParams>,
    /// The control configuration at the paper's point (5 kHz, one tick of delay) whose
    /// designs for the other rates and delays ([`wheelset_control::design`]) the device
    /// accepts; `None`: [`Self::control`] is that configuration.
    pub design: Option<ControlConfig>,
}

impl RuntimeConfig {
    /// The configuration at the design point `base_rate_hz`, `delay_ticks`: the control
    /// core [`ControlConfig::designed`] from the design base ([`Self::design`]), the rest
    /// as it is. What a host sends a device to change its rate.
    ///
    /// Errors: the point is not designed.
    pub fn designed(&self, base_rate_hz: u32, delay_ticks: u8) -> Result<Self, RuntimeError> {
        let base = self.design_base();
        let control = base.designed(base_rate_hz, delay_ticks)?;
        Ok(Self {
            control,
            // At the base's own point the configuration is its own design base.
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

/// Default wash-out of the `y''` integrator: 2 s (corner 0.08 Hz, below the 3 s curve
/// transitions' content and far below the ~10 Hz kinematic mode).
pub const DEFAULT_ACC_WASHOUT_S: f64 = 2.0;

impl Default for RuntimeConfig {
    /// The device's boot defaults (the type's docs).
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
    /// The design base ([`RuntimeConfig::design`]) differs from the control core in its
    /// rate-independent part: its designs could not be applied to this core.
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

/// A whole runtime configuration as exact bits: the compiled control core, the `y''`
/// integrator's factors, the fault policy. The firmware's build script writes the
/// default one as a constant ([`RuntimeBits::try_new`] on the host); the device starts
/// from it with [`Runtime::from_bits`], without float maths.
///
/// [`Runtime::from_bits`]: crate::Runtime::from_bits
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

/// The designs a device accepts: one per design point of
/// [`wheelset_control::design::DESIGNED`], in its order.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Designs {
    /// The rates as [`rates_for`] computes them from the design base. A received
    /// [`Rates`] must be one of them, bit for bit.
    pub rates: [Rates; DESIGNED.len()],
    /// Per design: its yaw law is designed (an active yaw mode is taken there), as
    /// [`wheelset_control::design::DesignPoint::yaw`].
    pub yaw: [bool; DESIGNED.len()],
}

impl RuntimeBits {
    /// Compile `cfg` for sample type `T` (f64 discretisation, then quantisation; the
    /// protocol's wire LSBs replace `cfg.control.wire`). Host and build-script use.
    pub fn try_new<T: SampleBits>(cfg: &RuntimeConfig) -> Result<Self, RuntimeError> {
        let mut control = cfg.control;
        control.wire = WireLsb::default();
        let monitor = match &cfg.monitor {
            Some(p) => {
                // The drive check's level is in pu of the core's current scale.
                let p = MonitorParams {
                    current_scale_a: control.scales.current,
                    ..*p
                };
                Monitor::<T>::try_new(&p, control.base_rate_hz)?.to_bits()
            }
            None => Monitor::<T>::off().to_bits(),
        };
        let compiled = Compiled::<T>::try_new(&control)?.to_bits();
        let mut designed = [rates_of(&compiled, acc_factors(cfg)?)?; DESIGNED.len()];
        for (slot, p) in designed.iter_mut().zip(DESIGNED) {
            let at = cfg.designed(p.base_rate_hz, p.delay_ticks)?;
            let mut c = at.control;
            c.wire = WireLsb::default();
            let bits = Compiled::<T>::try_new(&c)?.to_bits();
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

/// The [`Rates`] that switch a device running `T` with the rate-independent part of
/// `cfg` to the rates, delay and gains of `cfg` (use [`RuntimeConfig::designed`] for a
/// rate a device accepts): the coefficients computed here, with the device's control
/// code. Host use.
///
/// Errors: `cfg` is invalid, or `T` has no 32-bit wire form (`f64`).
pub fn rates_for<T: SampleBits>(cfg: &RuntimeConfig) -> Result<Rates, RuntimeError> {
    let mut control = cfg.control;
    control.wire = WireLsb::default();
    let b = Compiled::<T>::try_new(&control)?.to_bits();
    if T::NUMERIC > 1 {
        return Err(RuntimeError::Bits(BitsError { field: "numeric" }));
    }
    rates_of(&b, acc_factors(cfg)?)
}
