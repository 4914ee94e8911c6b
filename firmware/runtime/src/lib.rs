//! The device runtime, `no_std`, no allocation, board independent: frame handling, the
//! fault policy and the control tick. The board binaries and the host's in-process device
//! run this same code; the board layer only moves bytes and measures time.
//!
//! ```
//! use wheelset_proto::{encode_vec, Lateral, Message, Sensor, Decoder, Flags};
//! use wheelset_runtime::{Runtime, RuntimeConfig};
//! use wheelset_control::Fx;
//!
//! let mut rt = Runtime::<Fx>::try_new(RuntimeConfig::default()).unwrap();
//! let s = Sensor { seq: 7, t_us: 0, lateral: Lateral::Velocity(1_000),
//!                  i_a_ma: 0, omega_m_mrad_s: 925_600, demand_nm: 0, v_ref_mm_s: 0 };
//! rt.receive(&encode_vec(&Message::Sensor(s)).unwrap());
//! let frame = rt.tick(0).to_vec();              // COBS frame incl. the 0x00 delimiter
//! let mut dec: Decoder = Decoder::new();
//! let (out, _) = dec.next_message(&frame);
//! let Some(Ok(Message::Actuation(a))) = out else { panic!() };
//! assert_eq!(a.seq_echo, 7);
//! assert!(a.flags.has(Flags::ENABLED) && !a.flags.has(Flags::HOLDING));
//! assert!((a.u_a_cv - 396_157).abs() <= 1);   // bumpless: u_a = K_m omega = 3961.57 V
//! ```
//!
//! [`Runtime::receive`] takes bytes in any chunking; [`Runtime::tick`], once per base
//! period, runs the core on the latest sample and returns the [`Actuation`] frame.
//!
//! # Fault policy
//!
//! 1. **Bad frames** are dropped and counted by kind ([`Status`] `rx_*`, exactly one
//!    counter per delimited frame), flagged [`Flags::RX_ERROR`]; an undefined Command or
//!    mode is refused ([`RefuseReason::UnknownRequest`]). A `seq` not the previous + 1
//!    counts a `seq_gap`.
//! 2. **A missing sensor frame**: the tick runs on the held sample ([`Flags::HOLDING`],
//!    `held_ticks`) for at most [`RuntimeConfig::hold_ticks`] consecutive ticks.
//! 3. **Safe state** after that ([`Flags::SAFE`]): the yaw torque limit ramps to zero;
//!    the current reference is zero and, the held current being stale, each tick presets
//!    the PI to the back-EMF of the held speed, so the current decays (`L_a/R_a`).
//! 4. **Recovery** on the first valid Sensor: PI from the back-EMF, reference and torque
//!    limit ramping back up (bumpless both ways).
//! 5. **Zero current, not 0 V**: outputs disabled give zero torque and the back-EMF
//!    (0 V at speed would short the motor). Before the first sample ([`Flags::NO_SAMPLE`])
//!    the outputs are [`Runtime::safe_outputs`] (zero, zero), which a host must read as
//!    "not driving".
//! 6. **After a watchdog or fault reset** ([`Runtime::set_boot`]): [`Flags::FAULT_LATCHED`]
//!    and the safe state with the torque limit at zero from the first tick, until
//!    [`Command::ClearFaults`] (a Config does not end it).
//!
//! `y''` only: an integrator with wash-out ([`RuntimeConfig::acc_washout_s`]) in Q32
//! um/s, handing the core the whole um/s below it (`floor`: on average half an LSB low).
//! `Lateral::Both`: a complementary filter, crossover `1/(2 pi tau)`, run every tick
//! (`tau = 0`: `y'` as it is):
//!
//! ```text
//! v[n] = v[n-1] + T y''[n] - (T/tau) (v[n-1] - y'[n])      (y' the latest measured)
//! V(s) = (s Y'(s) + Y'(s)/tau) / (s + 1/tau)  when  y'' = d y'/dt:  V = Y'
//! ```
//!
//! A [`Config`] applies at once or not at all: outside `wheelset_proto::plausible` it is
//! refused (counted, [`Flags::CMD_REFUSED`], [`Runtime::refuse_reason`]), the old one kept.
//! New [`Rates`] come with their coefficients ([`rates_for`] on the host); the device does
//! no float maths, validates them against its own designs and restarts the core: the
//! traction loop bumpless from the back-EMF, the yaw torque slewing from the old output
//! under the old limit and safe state. `wheelset-hostile` holds the Configs a device must
//! refuse and apply.
//!
//! [`RefuseReason::UnknownRequest`]: wheelset_proto::RefuseReason::UnknownRequest
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
pub use runtime::{Runtime, RxEvent, SafeOutputs};
pub use wheelset_proto::{Actuation, Command, Config, Flags, Message, Rates, Sensor, Status};

/// The counters: the [`Status`] message is their only definition.
pub type RuntimeCounters = Status;

/// Default ticks bridged by the held sample before the safe state: 10 (2 ms at 5 kHz).
pub const DEFAULT_HOLD_TICKS: u16 = 10;

/// Bytes [`Runtime::tick`] may return: an Actuation frame plus a Status frame.
pub const TX_CAPACITY: usize = 2 * MAX_FRAME;
