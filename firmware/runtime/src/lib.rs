//! The device runtime, `no_std`, board independent: frame handling, the fault policy and
//! the control tick, run by the board binaries and the host's in-process device alike.
//!
//! # Fault policy
//!
//! 1. Bad frames are dropped and counted by kind ([`Status`] `rx_*`), [`Flags::RX_ERROR`].
//! 2. A missing sensor frame: the held sample for at most [`RuntimeConfig::hold_ticks`].
//! 3. Then the safe state: torque limit ramped to zero, current reference zero, the PI
//!    preset each tick to the back-EMF of the held speed (the stale current not integrated).
//! 4. The first valid Sensor frame leaves it, bumpless.
//! 5. Zero current, not 0 V (a short circuit at speed); before any sample
//!    [`SAFE_ACTUATION`] (zero, zero).
//! 6. After a watchdog or fault reset ([`Runtime::set_boot`]): the safe state at zero
//!    torque until [`Command::ClearFaults`].
//!
//! `Lateral::Both` runs a complementary filter every tick (`tau = 0`: `y'` as it is):
//!
//! ```text
//! v[n] = v[n-1] + T y''[n] - (T/tau) (v[n-1] - y'[n])      (y' the latest measured)
//! V(s) = (s Y'(s) + Y'(s)/tau) / (s + 1/tau)  when  y'' = d y'/dt:  V = Y'
//! ```
//!
//! A [`Config`] applies whole or is refused ([`Runtime::refuse_reason`]); new [`Rates`]
//! must be one of the device's designs ([`rates_for`] on the host).
#![no_std]
#![deny(missing_docs)]

use wheelset_proto::MAX_FRAME;

mod acc;
mod bits;
mod hold;
mod runtime;
mod validate;

pub(crate) use acc::acc_factors;
pub use acc::AccBits;
pub use bits::{
    rates_for, Designs, RuntimeBits, RuntimeConfig, RuntimeError, DEFAULT_ACC_WASHOUT_S,
};
pub use hold::{HoldPolicy, HoldStep, SafeChange};
pub use runtime::{Runtime, RxEvent, SAFE_ACTUATION};
pub use wheelset_proto::{Actuation, Command, Config, Flags, Message, Rates, Sensor, Status};

/// Default ticks bridged by the held sample before the safe state: 10 (2 ms at 5 kHz).
pub const DEFAULT_HOLD_TICKS: u16 = 10;

/// Bytes [`Runtime::tick`] may return: an Actuation frame plus a Status frame.
pub const TX_CAPACITY: usize = 2 * MAX_FRAME;
