//! The wheelset's control laws, `no_std`: discretised phase-lead yaw damping ([`lead`]),
//! the PI traction current loop ([`pi`]) and its wheel-slip protection ([`wsp`]), generic
//! over the sample type (`f64` reference, `f32`, fixed-point [`Fx`] = Q4.28 for production).
//!
//! No allocation, division, `libm` or panic on the tick path (the discretisation runs once,
//! in f64); the tick never fails: it sanitises (NaN -> 0), clamps, and counts ([`Counters`]).
//!
//! ```
//! use wheelset_control::{Config, FixedController, InputCodes};
//! let mut c = FixedController::try_new(&Config::default()).unwrap();
//! // 83.3 m/s: motor speed 925.6 rad/s (codes of 1 mrad/s), y' = 1 mm/s (codes of 1 um/s)
//! let out = c.tick_codes(&InputCodes { y_dot: 1000, current: 0, speed: 925_600, demand: 0 });
//! // Bumpless start: u_a = K_m omega = 4.28 * 925.6 = 3961.6 V (codes of 10 mV).
//! assert!((out.voltage - 396_157).abs() <= 1);
//! // T_psi = +Ks(s) y': the lead's first sample is close to its HF gain 7.875e5 N m s/m.
//! assert!(out.yaw_torque > 0);
//! ```
//!
//! Yaw torque sign: eq. 5 of the model, `J psi'' + ... = -T_psi`; the active law is
//! `T_psi = +K y'` (or `+Ks(s) y'`): a wheelset moving right is yawed nose-left. Current
//! reference `i_ref = demand/(n K_m)`, ramped: `i_ref[n] = i_ref[n-1] + clamp(target -
//! i_ref[n-1], ±r T)`; back-EMF `K_m theta_m'`. Ranges and rounding: `docs/audit.md`;
//! rates and link budget: `docs/closed-loop.md`. Units, full scales, limits and wire LSBs:
//! [`FullScales`], [`Limits`], [`WireLsb`].
#![no_std]
#![deny(missing_docs)]

pub mod compiled;
pub mod config;
pub mod controller;
pub mod design;
pub mod lead;
pub mod monitor;
pub mod pi;
pub mod sample;
pub mod wsp;

pub use compiled::{BitsError, Compiled, CompiledBits, ScaleBits, ScheduleBits};
pub use config::{
    Config, ConfigError, FullScales, Limits, Motor, SafeRamps, WireLsb, YawMode,
    DEFAULT_BASE_RATE_HZ,
};
pub use controller::{
    Codec, Controller, Counters, F32Controller, F64Controller, FixedController, InputCodes, Inputs,
    OutputCodes, Outputs, SignalCounts, TickEvents,
};
pub use lead::{Lead, LeadDiscrete, LeadParams, LeadPu, LeadState};
pub use monitor::{Monitor, MonitorBits, MonitorEvents, MonitorParams, MonitorState, QUIET_BLOCKS};
pub use pi::{Pi, PiDiscrete, PiFlags, PiParams, PiPu, PiState};
pub use sample::{Coef, Fx, FxScale, Sample, SampleBits};
pub use wsp::{Wsp, WspBits, WspParams, WspState};
