//! The controller's signals: per-unit inputs and outputs, their wire codes and
//! conversion, and the clamp and event counters.

use crate::config::{ConfigError, FullScales, WireLsb};
use crate::sample::Sample;

/// One tick's inputs, per unit (`x_SI / FS`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Inputs<T> {
    /// Lateral velocity `y'` relative to the track, pu of `scales.y_dot` (+ = right).
    pub y_dot: T,
    /// Motor current `i_a`, pu of `scales.current`.
    pub current: T,
    /// Motor speed `theta_m'`, pu of `scales.speed`.
    pub speed: T,
    /// Traction demand (wheel torque), pu of `scales.demand`; `i_ref = demand/(n K_m)`.
    pub demand: T,
}

impl<T: Sample> Inputs<T> {
    /// From SI values (m/s, A, rad/s, N m): `x / FS`, rounded to `T`.
    pub fn from_si(s: &FullScales, y_dot: f64, current: f64, speed: f64, demand: f64) -> Self {
        Self {
            y_dot: T::from_f64(y_dot / s.y_dot),
            current: T::from_f64(current / s.current),
            speed: T::from_f64(speed / s.speed),
            demand: T::from_f64(demand / s.demand),
        }
    }
}

/// One tick's outputs, per unit.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Outputs<T> {
    /// Yaw control torque `T_psi`, pu of `scales.torque`; sign: eq. 5 `J psi'' + ... = -T_psi`.
    pub yaw_torque: T,
    /// Motor voltage `u_a`, pu of `scales.voltage` (0 while traction is off).
    pub voltage: T,
}

impl<T: Sample> Outputs<T> {
    /// To SI: `(T_psi in N m, u_a in V)`.
    pub fn to_si(&self, s: &FullScales) -> (f64, f64) {
        (
            self.yaw_torque.to_f64() * s.torque,
            self.voltage.to_f64() * s.voltage,
        )
    }
}

/// How often one signal was invalid (NaN, floats only) or clamped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct SignalCounts {
    /// NaN replaced by 0.
    pub invalid: u32,
    /// Clamped to its limit.
    pub clamped: u32,
}

impl SignalCounts {
    #[inline(always)]
    pub(super) fn count(&mut self, invalid: bool, clamped: bool) {
        self.invalid = self.invalid.wrapping_add(invalid as u32);
        self.clamped = self.clamped.wrapping_add(clamped as u32);
    }
}

/// Saturation and invalid-input counters (wrapping `u32`), readable by the runtime.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Counters {
    /// Ticks run.
    pub ticks: u32,
    /// Yaw-loop steps run.
    pub yaw_steps: u32,
    /// Traction-loop steps run.
    pub traction_steps: u32,
    /// Input `y'` (clamp `limits.y_dot`).
    pub y_dot: SignalCounts,
    /// Input current (clamp `limits.current`; read on traction steps with traction on).
    pub current: SignalCounts,
    /// Input speed (clamp `limits.speed`; read for the bumpless preset and by the protection).
    pub speed: SignalCounts,
    /// Input demand (clamp `limits.demand`; as the current).
    pub demand: SignalCounts,
    /// Output yaw torque against `limits.torque` (the safe-state ramp's clamps not counted).
    pub yaw_torque: SignalCounts,
    /// PI output against the voltage limits.
    pub voltage: SignalCounts,
    /// PI integrator clamps (anti-windup engaged).
    pub integrator: SignalCounts,
    /// Traction steps on which the wheel-slip protection acted ([`crate::wsp`]).
    pub wsp_ticks: u32,
    /// Times the wheel-slip protection started acting.
    pub wsp_events: u32,
}

/// Bit positions of the per-tick event mask (inputs: `bit` invalid, `bit + 1` clamped).
pub(super) mod event {
    pub const Y_DOT: u32 = 0;
    pub const CURRENT: u32 = 2;
    pub const SPEED: u32 = 4;
    pub const DEMAND: u32 = 6;
    pub const TORQUE: u32 = 9;
    pub const VOLTAGE: u32 = 11;
    pub const INTEGRATOR: u32 = 13;
    /// The wheel-slip protection acted on this tick's traction step (`wsp_ticks`).
    pub const WSP_ACTING: u32 = 15;
    /// The wheel-slip protection started acting on this tick (`wsp_events`).
    pub const WSP_STARTED: u32 = 16;
}

/// What one [`super::Controller::tick`] counted, one bit per [`Counters`] increment.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TickEvents(pub(super) u32);

impl TickEvents {
    /// Nothing counted (a tick of normal running, or no tick).
    pub const NONE: Self = Self(0);
    /// The input bits (invalid and clamped of `y'`, current, speed, demand).
    const INPUTS: u32 = 0xFF;

    /// Something was counted on this tick.
    #[inline(always)]
    pub fn any(self) -> bool {
        self.0 != 0
    }
    /// The yaw torque was clamped by `limits.torque` (`Counters::yaw_torque.clamped` + 1).
    #[inline(always)]
    pub fn yaw_saturated(self) -> bool {
        self.0 & (1 << event::TORQUE) != 0
    }
    /// The PI output (voltage) was clamped (`Counters::voltage.clamped` moved by one).
    #[inline(always)]
    pub fn traction_saturated(self) -> bool {
        self.0 & (1 << event::VOLTAGE) != 0
    }
    /// Input events on this tick, 0..=8: the four inputs' `invalid + clamped` moved by this much.
    #[inline(always)]
    pub fn inputs(self) -> u32 {
        (self.0 & Self::INPUTS).count_ones()
    }
    /// The wheel-slip protection acted on this tick (`Counters::wsp_ticks` + 1).
    #[inline(always)]
    pub fn wsp_acting(self) -> bool {
        self.0 & (1 << event::WSP_ACTING) != 0
    }
    /// The wheel-slip protection started acting on this tick (`Counters::wsp_events` + 1).
    #[inline(always)]
    pub fn wsp_started(self) -> bool {
        self.0 & (1 << event::WSP_STARTED) != 0
    }
}

impl Counters {
    /// Count the events of one tick (cold: only runs when something was clamped).
    #[cold]
    #[inline(never)]
    pub(super) fn record(&mut self, ev: u32) {
        let bit = |b: u32| (ev >> b) & 1 == 1;
        for (c, b) in [
            (&mut self.y_dot, event::Y_DOT),
            (&mut self.current, event::CURRENT),
            (&mut self.speed, event::SPEED),
            (&mut self.demand, event::DEMAND),
            (&mut self.yaw_torque, event::TORQUE - 1),
            (&mut self.voltage, event::VOLTAGE - 1),
            (&mut self.integrator, event::INTEGRATOR - 1),
        ] {
            c.count(bit(b), bit(b + 1));
        }
        self.wsp_ticks = self.wsp_ticks.wrapping_add(bit(event::WSP_ACTING) as u32);
        self.wsp_events = self.wsp_events.wrapping_add(bit(event::WSP_STARTED) as u32);
    }
}

/// Integer wire codes of the inputs (LSBs in [`WireLsb`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct InputCodes {
    /// y', codes of `wire.y_dot`.
    pub y_dot: i32,
    /// Current, codes of `wire.current`.
    pub current: i32,
    /// Speed, codes of `wire.speed`.
    pub speed: i32,
    /// Demand, codes of `wire.demand`.
    pub demand: i32,
}

/// Integer wire codes of the outputs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct OutputCodes {
    /// Yaw torque, codes of `wire.torque`.
    pub yaw_torque: i32,
    /// Voltage, codes of `wire.voltage`.
    pub voltage: i32,
}

/// Wire-code <-> per-unit conversion, `pu = code * LSB/FS` (for [`crate::Fx`] integer work).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Codec<T: Sample> {
    pub(crate) y_dot: T::Scale,
    pub(crate) current: T::Scale,
    pub(crate) speed: T::Scale,
    pub(crate) demand: T::Scale,
    pub(crate) torque: T::Scale,
    pub(crate) voltage: T::Scale,
}

impl<T: Sample> Codec<T> {
    /// Precompute the six factors; an error names a factor that does not fit.
    pub fn try_new(lsb: &WireLsb, fs: &FullScales) -> Result<Self, ConfigError> {
        let sc = |name, f| ConfigError::fit(T::scale_in(f), name, f);
        let so = |name, f| ConfigError::fit(T::scale_out(f), name, f);
        Ok(Self {
            y_dot: sc("wire.y_dot/scales.y_dot", lsb.y_dot / fs.y_dot)?,
            current: sc("wire.current/scales.current", lsb.current / fs.current)?,
            speed: sc("wire.speed/scales.speed", lsb.speed / fs.speed)?,
            demand: sc("wire.demand/scales.demand", lsb.demand / fs.demand)?,
            torque: so("scales.torque/wire.torque", fs.torque / lsb.torque)?,
            voltage: so("scales.voltage/wire.voltage", fs.voltage / lsb.voltage)?,
        })
    }

    /// Codes -> per-unit inputs; always inlined, so the scaling folds into the tick.
    #[inline(always)]
    pub fn decode(&self, c: &InputCodes) -> Inputs<T> {
        Inputs {
            y_dot: T::from_code(c.y_dot, &self.y_dot),
            current: T::from_code(c.current, &self.current),
            speed: T::from_code(c.speed, &self.speed),
            demand: T::from_code(c.demand, &self.demand),
        }
    }

    /// Per-unit outputs -> codes (rounded, saturating at the `i32` range).
    #[inline(always)]
    pub fn encode(&self, o: &Outputs<T>) -> OutputCodes {
        OutputCodes {
            yaw_torque: o.yaw_torque.to_code(&self.torque),
            voltage: o.voltage.to_code(&self.voltage),
        }
    }
}
