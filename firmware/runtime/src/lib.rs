//! The device runtime, `no_std`, no allocation, board independent: frame handling, the
//! fault policy and the control tick. The board binaries (from embassy tasks) and the
//! host's in-process device (`sim-host run --loop device`) run this same code; the board
//! layer only moves bytes and measures time.
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
//! # One tick
//!
//! [`Runtime::receive`] takes bytes in any chunking (UART RX, DMA, the simulated link):
//! valid [`Sensor`] frames become the latest sample, [`Config`] and [`Command`] frames
//! are applied, everything else is counted. [`Runtime::tick`], once per base period, runs
//! the control core on the latest sample and returns the [`Actuation`] frame (COBS,
//! delimiter included), echoing the sample's `seq`, carrying the tick count, the
//! previous tick's execution time and the [`Flags`].
//!
//! # Fault policy
//!
//! 1. **Bad frames** (CRC, COBS, version, length, postcard) are dropped and counted by
//!    kind ([`Status`] `rx_*`); the next actuation frame carries [`Flags::RX_ERROR`].
//!    Frames (CRC and version valid) of a type the device does not take (Actuation,
//!    Status) count as `rx_unexpected` only (not also as `rx_ok`); their bodies are not
//!    decoded. Every delimited frame counts in exactly one of `rx_ok`, `rx_unexpected`
//!    and the five `rx_*` errors. A Command variant or a Config mode this version does
//!    not define is a valid frame (`rx_ok`) and an unknown request: refused
//!    ([`Flags::CMD_REFUSED`], `cmd_refused`, [`RefuseReason::UnknownRequest`]).
//!    Sensor frames with `y'` use it; frames with only `y''` feed an integrator with
//!    wash-out ([`RuntimeConfig::acc_washout_s`]) that runs every tick (re-seeded by the
//!    next frame that carries only `y'`); frames with both feed the complementary filter
//!    below. The integrator holds `y'` in Q32 um/s and hands the control core the whole
//!    um/s below it (an arithmetic shift: `floor`, not a rounding), as a Sensor's `y'`
//!    code: on average half an LSB low, -0.5 um/s, which the lead turns into 0.05 N m
//!    at DC (`K a w1/w2` = 1.06e5 N m per m/s), half the torque's wire LSB; a `y''` of
//!    -1 code (-0.1 mm/s^2) gives `y'` = -1 um/s on its first tick, +1 code 0 until
//!    the sum reaches 1 um/s (about 50 ticks at 5 kHz). A Sensor `seq` that is not the
//!    previous + 1 counts a `seq_gap`.
//! 2. **A missing sensor frame** (no new valid Sensor since the last tick): the tick runs
//!    on the held last sample, flag [`Flags::HOLDING`], `held_ticks` counted (every such
//!    tick, in the safe state too: the flag and the counter are the same event), for at
//!    most `hold_ticks` consecutive ticks ([`RuntimeConfig::hold_ticks`], default
//!    [`DEFAULT_HOLD_TICKS`] = 2 ms at 5 kHz) before the safe state.
//! 3. **Safe state** after `hold_ticks + 1` consecutive ticks without one: flag
//!    [`Flags::SAFE`], `safe_entries` / `safe_ticks` counted. The yaw torque limit ramps
//!    to zero (the control core's safe ramp, 0.1 s by default) on the held `y'`; a torque
//!    the ramp limits is a saturation ([`Flags::YAW_SAT`], `yaw_sat`). The
//!    traction current reference is zero and, because the held current is stale, the
//!    traction loop does not integrate it: each safe tick presets the PI to the back-EMF
//!    of the held speed (`u_a = K_m omega_m`), the voltage at which the armature current
//!    decays to zero (time constant `L_a/R_a` = 10 ms) instead of winding up on old data.
//! 4. **Recovery**: the first valid Sensor frame leaves the safe state (`safe_exits`):
//!    the PI restarts from the back-EMF with the current reference ramping up from zero at
//!    its normal slew rate, the torque limit ramps back up (bumpless both ways).
//! 5. **Zero current, not 0 V**: with outputs disabled by a [`Config`] (no
//!    [`Flags::ENABLED`]) the torque is zero and the voltage the back-EMF of the latest
//!    speed, as with traction off (the control core) and in the safe state: 0 V at
//!    3 961 V of back-EMF would short the motor. **Before the first sample**
//!    ([`Flags::NO_SAMPLE`]) no speed is known: the outputs are
//!    [`Runtime::safe_outputs`] (zero torque, zero voltage), also what a panic handler
//!    drives; a host must read `NO_SAMPLE` as "not driving".
//! 6. **After a watchdog or fault reset** (the board's boot record,
//!    [`Runtime::set_boot`]): [`Flags::FAULT_LATCHED`] and the safe state from the first
//!    tick, its torque limit at zero (zero yaw torque at once, not a ramp from the full
//!    limit), until [`Command::ClearFaults`]; a Config does not end it. The device that
//!    has just crashed drives nothing until the host has acknowledged the crash.
//!
//! **`Lateral::Both`**: a complementary filter of `y'` and `y''` (the wash-out's time
//! constant `tau` is the crossover, `1/(2 pi tau)` = 0.08 Hz by default), run every tick:
//!
//! ```text
//! v[n] = v[n-1] + T y''[n] - (T/tau) (v[n-1] - y'[n])      (y' the latest measured)
//! V(s) = (s Y'(s) + Y'(s)/tau) / (s + 1/tau)  when  y'' = d y'/dt:  V = Y'
//! ```
//!
//! `y''` carries the high frequencies, `y'` the low ones: on the `tests/accounting.rs`
//! signal (2 Hz, 20 mm/s, +-2 mm/s alternating noise on `y'` only) the error RMS is
//! 2.0e-5 m/s against 2.0e-3 m/s with `y'` alone. With the wash-out off (`tau = 0`)
//! there is no crossover and `Both` uses `y'` as it is.
//!
//! A [`Config`] applies mode, traction, enable and `hold_ticks` at once, or nothing: the
//! device refuses anything outside the plausible ranges of `wheelset_proto::plausible`
//! (counted in `cmd_refused`, flagged [`Flags::CMD_REFUSED`] until the next accepted
//! Config or Command other than `RequestStatus`, the reason in
//! [`Runtime::refuse_reason`] and the Status until the next refusal), the old
//! configuration kept. New
//! rates come with their coefficients ([`Rates`], computed by the host with this same
//! code: [`rates_for`]); the device does no discretisation (no float maths at all: it
//! starts from [`RuntimeBits`] constants, [`Runtime::from_bits`]), it validates them
//! (sample type, the fingerprint of the rate-independent part, a base period of whole
//! microseconds the board's ticker can honour, the plausible rates, and every
//! coefficient against what its own start-up core yields at the requested rates within
//! `2^-10`) and restarts the control core on them. A restarted core restarts its filter
//! states; the traction loop restarts bumpless from the back-EMF, the yaw torque slews
//! from the old core's output, under the old core's torque limit and safe state (a
//! safe state goes on). A change of the yaw law slews likewise (at most
//! `torque_step` per yaw step, 40 N m per tick by default, until the new law's output is
//! reached: bumpless).
//!
//! The table of Configs a device must refuse (each with its reason) and apply, with the
//! procedure that tries them on the host runtime and on the firmware alike, is the
//! test-support crate `wheelset-hostile`.
//!
//! Counters ([`RuntimeCounters`] = the [`Status`] message) go out in a Status frame after
//! the next actuation frame when a [`Command::RequestStatus`] arrives;
//! [`Command::ResetCounters`] zeroes them.
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
