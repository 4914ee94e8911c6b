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
//! let mut out = None;
//! dec.feed(&frame, |r| out = r.ok());
//! let Some(Message::Actuation(a)) = out else { panic!() };
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
//!    below. A Sensor `seq` that is not the previous + 1 counts a `seq_gap`.
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
//! Config, the field in [`Runtime::refuse_reason`]), the old configuration kept. New
//! rates come with their coefficients ([`Rates`], computed by the host with this same
//! code: [`rates_for`]); the device does no discretisation (no float maths at all: it
//! starts from [`RuntimeBits`] constants, [`Runtime::from_bits`]), it validates them
//! (sample type, the fingerprint of the rate-independent part, a base period of whole
//! microseconds the board's ticker can honour, the plausible rates, and every
//! coefficient against what its own start-up core yields at the requested rates within
//! `2^-10`) and restarts the control core on them. A restarted core restarts its filter
//! states; the traction loop restarts bumpless from the back-EMF, the yaw torque slews
//! from the old core's output. A change of the yaw law slews likewise (at most
//! `torque_step` per yaw step, 40 N m per tick by default, until the new law's output is
//! reached: bumpless).
//!
//! Counters ([`RuntimeCounters`] = the [`Status`] message) go out in a Status frame after
//! the next actuation frame when a [`Command::RequestStatus`] arrives;
//! [`Command::ResetCounters`] zeroes them.
#![no_std]
#![deny(missing_docs)]

use wheelset_control::{
    BitsError, Compiled, CompiledBits, Config as ControlConfig, ConfigError, Controller,
    InputCodes, Monitor, MonitorBits, MonitorParams, MonitorState, Sample, SampleBits,
    ScheduleBits, WireLsb,
};
use wheelset_proto::units::{
    CURRENT_LSB_A, DEMAND_LSB_NM, LAT_VEL_LSB_M_PER_S, SPEED_LSB_RAD_PER_S, TORQUE_LSB_NM,
    VOLTAGE_LSB_V,
};
use wheelset_proto::{
    encode_actuation, encode_status, Decoder, FrameError, Lateral, RefuseReason, Request, MAX_FRAME,
};

mod plausible;
pub use wheelset_proto::{Actuation, Command, Config, Flags, Message, Rates, Sensor, Status};

/// The counters: the [`Status`] message is their only definition.
pub type RuntimeCounters = Status;

/// Default ticks bridged by the held sample before the safe state: 10 (2 ms at 5 kHz).
pub const DEFAULT_HOLD_TICKS: u16 = 10;

/// Bytes [`Runtime::tick`] may return: an Actuation frame plus a Status frame.
pub const TX_CAPACITY: usize = 2 * MAX_FRAME;

/// The runtime configuration: the control core's configuration and the fault policy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RuntimeConfig {
    /// The control core's configuration. Its `wire` LSBs are overwritten with the
    /// protocol's ([`protocol_wire_lsb`]): the format has one definition.
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
}

/// Default wash-out of the `y''` integrator: 2 s (corner 0.08 Hz, below the 3 s curve
/// transitions' content and far below the ~10 Hz kinematic mode).
pub const DEFAULT_ACC_WASHOUT_S: f64 = 2.0;

impl Default for RuntimeConfig {
    fn default() -> Self {
        Self {
            control: ControlConfig::default(),
            hold_ticks: DEFAULT_HOLD_TICKS,
            enable: true,
            acc_washout_s: DEFAULT_ACC_WASHOUT_S,
            monitor: Some(MonitorParams::default()),
        }
    }
}

/// The wire LSBs of `wheelset-proto` in the control core's terms.
#[must_use]
pub fn protocol_wire_lsb() -> WireLsb {
    WireLsb {
        y_dot: LAT_VEL_LSB_M_PER_S,
        current: CURRENT_LSB_A,
        speed: SPEED_LSB_RAD_PER_S,
        demand: DEMAND_LSB_NM,
        torque: TORQUE_LSB_NM,
        voltage: VOLTAGE_LSB_V,
    }
}

/// Why a runtime could not be built.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RuntimeError {
    /// The control configuration is invalid.
    Control(ConfigError),
    /// The wash-out time constant is negative, not finite, or shorter than one tick.
    Washout,
    /// Exact bits ([`RuntimeBits`], [`Rates`]) are invalid: the field named.
    Bits(BitsError),
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

/// The `y''` integrator's factors in Q32: `T` (um/s per 0.1 mm/s^2 code per tick) and
/// `T/tau`. Computed once here (f64), so the tick has no division.
fn acc_factors(cfg: &RuntimeConfig) -> Result<AccBits, RuntimeError> {
    let t = 1.0 / f64::from(cfg.control.base_rate_hz.max(1));
    let q32 = 4_294_967_296.0;
    // 1 code = 1e-4 m/s^2 = 100 um/s^2.
    let gain = 100.0 * t * q32;
    let tau = cfg.acc_washout_s;
    let leak = if tau == 0.0 {
        0.0
    } else if tau.is_finite() && tau >= t {
        t / tau * q32
    } else {
        return Err(RuntimeError::Washout);
    };
    Ok(AccBits {
        gain_q32: round_q(gain),
        leak_q32: round_q(leak),
    })
}

fn round_q(x: f64) -> u64 {
    // x >= 0 here; no libm in no_std: round half up by hand.
    (x + 0.5) as u64
}

/// The `y''` integrator's factors in Q32 (see [`RuntimeConfig::acc_washout_s`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct AccBits {
    /// `T` in Q32: um/s per 0.1 mm/s^2 code per tick, in `[1, 2^32]`.
    pub gain_q32: u64,
    /// Wash-out `T/tau` in Q32, in `[0, 2^32]` (0: a pure integrator).
    pub leak_q32: u64,
}

impl AccBits {
    /// Validated (positive gain, both at most `2^32`, i.e. `T <= 1 s` per 100 um/s^2 and
    /// `tau >= T`) as signed Q32 factors.
    fn check(&self) -> Result<(i64, i64), RuntimeError> {
        const ONE: u64 = 1 << 32;
        if !(1..=ONE).contains(&self.gain_q32) {
            return Err(BitsError {
                field: "acc_gain_q32",
            }
            .into());
        }
        if self.leak_q32 > ONE {
            return Err(BitsError {
                field: "acc_leak_q32",
            }
            .into());
        }
        Ok((self.gain_q32 as i64, self.leak_q32 as i64))
    }
}

/// A whole runtime configuration as exact bits: the compiled control core, the `y''`
/// integrator's factors, the fault policy. The firmware's build script writes the
/// default one as a constant ([`RuntimeBits::try_new`] on the host); the device starts
/// from it with [`Runtime::from_bits`], without float maths.
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
}

impl RuntimeBits {
    /// Compile `cfg` for sample type `T` (f64 discretisation, then quantisation; the
    /// protocol's wire LSBs replace `cfg.control.wire`). Host and build-script use.
    pub fn try_new<T: SampleBits>(cfg: &RuntimeConfig) -> Result<Self, RuntimeError> {
        let mut control = cfg.control;
        control.wire = protocol_wire_lsb();
        let monitor = match &cfg.monitor {
            Some(p) => Monitor::<T>::try_new(p, control.base_rate_hz)?.to_bits(),
            None => Monitor::<T>::off().to_bits(),
        };
        Ok(Self {
            control: Compiled::<T>::try_new(&control)?.to_bits(),
            acc: acc_factors(cfg)?,
            hold_ticks: cfg.hold_ticks,
            enable: cfg.enable,
            monitor,
        })
    }
}

/// The [`Rates`] that switch a device running `T` with the rate-independent part of
/// `cfg` to the rates of `cfg` (its base rate and divisors): the coefficients computed
/// here, with the device's control code. Host use.
///
/// Errors: `cfg` is invalid, or `T` has no 32-bit wire form (`f64`).
pub fn rates_for<T: SampleBits>(cfg: &RuntimeConfig) -> Result<Rates, RuntimeError> {
    let b = RuntimeBits::try_new::<T>(cfg)?;
    let s = b.control.schedule;
    let w = |field, v: u64| u32::try_from(v).map_err(|_| RuntimeError::Bits(BitsError { field }));
    Ok(Rates {
        numeric: T::NUMERIC,
        fingerprint: b.control.fingerprint(),
        base_rate_hz: s.base_rate_hz,
        yaw_div: s.yaw_divisor,
        traction_div: s.traction_divisor,
        kappa: w("kappa", s.kappa)?,
        ki: w("ki", s.ki)?,
        predict_half: w("predict_half", s.predict_half)?,
        iref_step: w("iref_step", s.iref_step)?,
        iref_safe_step: w("iref_safe_step", s.iref_safe_step)?,
        torque_step: w("torque_step", s.torque_step)?,
        acc_gain_q32: b.acc.gain_q32,
        acc_leak_q32: b.acc.leak_q32,
    })
}

/// The outputs the device drives when it has nothing valid to say.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SafeOutputs {
    /// Yaw torque, 0.1 N m: 0.
    pub t_psi_dnm: i32,
    /// Motor voltage, 10 mV: 0.
    pub u_a_cv: i32,
}

/// Control core + frame decoder + fault policy + counters. See the crate docs.
#[derive(Debug, Clone)]
pub struct Runtime<T: Sample> {
    core: Controller<T>,
    /// [`CompiledBits::fingerprint`] of the core's rate-independent part.
    fingerprint: u32,
    /// The start-up core's rates: what a received [`Rates`] is checked against.
    reference: plausible::Reference,
    hold_ticks: u16,
    decoder: Decoder,
    sample: Option<InputCodes>,
    /// The latest sample carried only `y''` (codes of 0.1 mm/s^2): integrate it.
    acc: Option<i32>,
    /// `y'` estimate from `y''`, um/s in Q32.
    vel_q32: i64,
    /// What the estimate washes out towards, um/s in Q32: 0 (`y''` only) or the measured
    /// `y'` (`Lateral::Both`, the complementary filter).
    acc_ref_q32: i64,
    /// `T` in the integrator: um/s per (0.1 mm/s^2 code) per tick, Q32.
    acc_gain_q32: i64,
    /// Wash-out shift-free factor `T/tau` in Q32 (0: none).
    leak_q32: i64,
    seq: u16,
    fresh: bool,
    missing: u32,
    safe: bool,
    enabled: bool,
    rx_error: bool,
    refused: bool,
    refuse_reason: RefuseReason,
    /// The stability monitor and its state.
    #[cfg_attr(not(feature = "monitor"), allow(dead_code))]
    monitor: Monitor<T>,
    mon: MonitorState<T>,
    /// A stability alarm holds the safe state (`Config.monitor_safe`) until
    /// `Command::ClearFaults`.
    monitor_safe: bool,
    alarm_safe: bool,
    /// Sticky [`Flags::FAULT_LATCHED`].
    fault_latched: bool,
    status_requested: bool,
    ticks: u32,
    /// The board's link limit: the highest base rate a Config may set, Hz.
    max_rate_hz: u32,
    counters: RuntimeCounters,
    tx: [u8; TX_CAPACITY],
}

impl<T: SampleBits> Runtime<T> {
    /// Builds the control core (validated, discretised in f64, quantised) and an idle
    /// runtime: [`RuntimeBits::try_new`] then [`Self::from_bits`], the device's path.
    /// Host use.
    pub fn try_new(cfg: RuntimeConfig) -> Result<Self, RuntimeError> {
        Self::from_bits(&RuntimeBits::try_new::<T>(&cfg)?)
    }

    /// An idle runtime running exactly `bits` (validated; integer work only): how the
    /// device starts.
    pub fn from_bits(bits: &RuntimeBits) -> Result<Self, RuntimeError> {
        let base = bits.control.schedule.base_rate_hz;
        Self::with_core(
            &Compiled::from_bits(&bits.control)?,
            bits.control.fingerprint(),
            bits.acc,
            bits.hold_ticks,
            bits.enable,
            Monitor::from_bits(&bits.monitor, base)?,
        )
    }

    /// An idle runtime on an already validated core `law` whose bits have the
    /// fingerprint `fingerprint` ([`CompiledBits::fingerprint`]), with the other fields of
    /// [`RuntimeBits`]: the device's start from build-time constants
    /// (`Compiled::from_valid_bits` and the fingerprint evaluated at compile time), with
    /// no conversion code. [`Self::from_bits`] is this after validating the bits.
    pub fn with_core(
        law: &Compiled<T>,
        fingerprint: u32,
        acc: AccBits,
        hold_ticks: u16,
        enable: bool,
        monitor: Monitor<T>,
    ) -> Result<Self, RuntimeError> {
        let core = Controller::new(law);
        let (acc_gain_q32, leak_q32) = acc.check()?;
        // The device's CRC table is built in RAM by the first checksum (about 10 000
        // instructions): here, at start-up, not in the first tick.
        let _ = wheelset_proto::CRC.checksum(&[]);
        Ok(Self {
            core,
            fingerprint,
            reference: plausible::Reference {
                schedule: law.schedule(),
                acc,
            },
            hold_ticks,
            decoder: Decoder::new(),
            sample: None,
            acc: None,
            vel_q32: 0,
            acc_ref_q32: 0,
            acc_gain_q32,
            leak_q32,
            seq: 0,
            fresh: false,
            missing: 0,
            safe: false,
            enabled: enable,
            rx_error: false,
            refused: false,
            refuse_reason: RefuseReason::None,
            monitor,
            mon: MonitorState::default(),
            monitor_safe: false,
            alarm_safe: false,
            fault_latched: false,
            status_requested: false,
            ticks: 0,
            max_rate_hz: u32::MAX,
            counters: RuntimeCounters::default(),
            tx: [0; TX_CAPACITY],
        })
    }

    /// The board's link limit: from now on a Config whose base rate is above
    /// `max_rate_hz` is refused (counted, [`Flags::CMD_REFUSED`]), because the board's
    /// link cannot carry one exchange per period at it. A board computes it at build time
    /// from its baud and the worst-case frames (`wheelset_proto::link::max_rate_hz`);
    /// `u32::MAX` (the default) is no limit (a frame-clocked device in lock-step).
    pub fn set_link_limit(&mut self, max_rate_hz: u32) {
        self.max_rate_hz = max_rate_hz;
    }

    /// What a panic handler drives: zero torque, zero voltage.
    #[must_use]
    pub const fn safe_outputs() -> SafeOutputs {
        SafeOutputs {
            t_psi_dnm: 0,
            u_a_cv: 0,
        }
    }

    /// Takes received bytes in any chunking; decodes frames, applies commands, counts bad
    /// frames. Never panics.
    pub fn receive(&mut self, bytes: &[u8]) {
        // Frame by frame (not a callback into `self` with the decoder moved out and back:
        // two copies of its buffer per call).
        let mut rest = bytes;
        while !rest.is_empty() {
            let (r, more) = self.decoder.next_request(rest);
            rest = more;
            if let Some(r) = r {
                self.on_frame(r);
            }
        }
    }

    fn on_frame(&mut self, r: Result<Request, FrameError>) {
        let c = &mut self.counters;
        let m = match r {
            Ok(m) => m,
            Err(e) => {
                let n = match e {
                    FrameError::Crc => &mut c.rx_crc,
                    FrameError::Cobs => &mut c.rx_cobs,
                    FrameError::Version => &mut c.rx_version,
                    FrameError::Length => &mut c.rx_length,
                    FrameError::Postcard => &mut c.rx_postcard,
                };
                *n = n.wrapping_add(1);
                self.rx_error = true;
                return;
            }
        };
        if matches!(m, Request::Unexpected) {
            // A valid frame of a device -> host type: counted here only (the accounting
            // identity of the Status docs).
            c.rx_unexpected = c.rx_unexpected.wrapping_add(1);
            return;
        }
        c.rx_ok = c.rx_ok.wrapping_add(1);
        match m {
            Request::Sensor(s) => self.on_sensor(&s),
            Request::Config(cfg) => self.on_config(&cfg),
            Request::Command(Command::ResetCounters) => {
                // The board's boot record and stack measurement are not counters.
                let keep = (c.boot_count, c.reset_cause, c.stack_peak);
                *c = RuntimeCounters::default();
                (c.boot_count, c.reset_cause, c.stack_peak) = keep;
                self.core.reset_counters();
                self.refused = false;
            }
            Request::Command(Command::RequestStatus) => self.status_requested = true,
            Request::Command(Command::ClearFaults) => {
                self.fault_latched = false;
                self.alarm_safe = false;
            }
            Request::Unknown => self.refuse(RefuseReason::UnknownRequest),
            Request::Unexpected => {}
        }
    }

    fn on_sensor(&mut self, s: &Sensor) {
        let y_dot = match s.lateral {
            Lateral::Both {
                vel_um_s: v,
                acc_dmm_s2: a,
            } if self.leak_q32 != 0 => {
                // The complementary filter (crate docs): y' pulls the estimate at the
                // wash-out rate, y'' is integrated.
                if self.acc.is_none() {
                    self.vel_q32 = i64::from(v) << 32;
                }
                self.acc = Some(a);
                self.acc_ref_q32 = i64::from(v) << 32;
                (self.vel_q32 >> 32) as i32
            }
            Lateral::Velocity(v) | Lateral::Both { vel_um_s: v, .. } => {
                // A measured velocity also re-seeds the integrator (bumpless switch).
                self.acc = None;
                self.vel_q32 = i64::from(v) << 32;
                v
            }
            Lateral::Acceleration(a) => {
                self.acc = Some(a);
                self.acc_ref_q32 = 0;
                (self.vel_q32 >> 32) as i32
            }
        };
        if self.sample.is_some() && s.seq != self.seq.wrapping_add(1) {
            self.counters.seq_gaps = self.counters.seq_gaps.wrapping_add(1);
        }
        self.seq = s.seq;
        #[cfg(feature = "wsp")]
        self.core.set_v_ref_code(s.v_ref_mm_s);
        self.sample = Some(InputCodes {
            y_dot,
            current: s.i_a_ma,
            speed: s.omega_m_mrad_s,
            demand: s.demand_nm,
        });
        self.fresh = true;
    }

    #[inline(never)]
    fn on_config(&mut self, c: &Config) {
        let unsupported =
            (c.wsp && !cfg!(feature = "wsp")) || (c.monitor_safe && !cfg!(feature = "monitor"));
        let checked = if unsupported {
            Err(RefuseReason::Unsupported)
        } else {
            match &c.rates {
                Some(r) => self.apply_rates(r, c.hold_ticks),
                None => plausible::check_hold(c.hold_ticks, self.base_rate_hz()),
            }
        };
        if let Err(why) = checked {
            self.refuse(why);
            return;
        }
        if c.enable && !self.enabled {
            // Re-enabled: the torque slews up from 0, the PI restarts from the back-EMF.
            self.core.continue_from(T::ZERO);
            self.core.set_traction(false);
        }
        self.core.set_mode(c.mode);
        self.core.set_traction(c.traction);
        #[cfg(feature = "wsp")]
        self.core.set_wsp(c.wsp);
        self.monitor_safe = c.monitor_safe;
        self.enabled = c.enable;
        self.hold_ticks = c.hold_ticks;
        self.refused = false;
    }

    /// A refused Config or Command: counted, flagged until the next accepted one, the
    /// reason kept for the Status; nothing else changes.
    fn refuse(&mut self, why: RefuseReason) {
        self.refused = true;
        self.counters.cmd_refused = self.counters.cmd_refused.wrapping_add(1);
        self.refuse_reason = why;
        self.counters.refuse_reason = why as u8;
    }

    /// Validates `r` against this core (sample type, fingerprint, the plausible ranges of
    /// `wheelset_proto::plausible`, the coefficients against the start-up core's at the
    /// requested rates, `hold_ticks` at the new rate, the formats) and, if valid,
    /// restarts the core on it. Nothing changes when it is refused.
    #[inline(never)]
    fn apply_rates(&mut self, r: &Rates, hold_ticks: u16) -> Result<(), RefuseReason> {
        if r.numeric != T::NUMERIC {
            return Err(RefuseReason::Numeric);
        }
        if r.fingerprint != self.fingerprint {
            return Err(RefuseReason::Fingerprint);
        }
        // The board's link cannot carry one exchange per period above its limit: out of
        // this board's range of base rates.
        if r.base_rate_hz > self.max_rate_hz {
            return Err(RefuseReason::BaseRate);
        }
        plausible::check_rates::<T>(r, &self.reference)?;
        plausible::check_hold(hold_ticks, r.base_rate_hz)?;
        let bits = RefuseReason::Bits;
        let (g, l) = AccBits {
            gain_q32: r.acc_gain_q32,
            leak_q32: r.acc_leak_q32,
        }
        .check()
        .map_err(|_| bits)?;
        let law = self
            .core
            .compiled()
            .with_schedule(&ScheduleBits {
                base_rate_hz: r.base_rate_hz,
                yaw_divisor: r.yaw_div,
                traction_divisor: r.traction_div,
                kappa: u64::from(r.kappa),
                ki: u64::from(r.ki),
                predict_half: u64::from(r.predict_half),
                iref_step: u64::from(r.iref_step),
                iref_safe_step: u64::from(r.iref_safe_step),
                torque_step: u64::from(r.torque_step),
            })
            .map_err(|_| bits)?;
        // A fresh core (filter states zero, integrator to be preset from the back-EMF);
        // the Config sets its mode and traction right after.
        let t_psi = self.core.outputs().yaw_torque;
        let wsp = self.core.wsp_enabled();
        self.core = Controller::new(&law);
        self.core.continue_from(t_psi);
        if wsp {
            self.core.set_wsp(true);
        }
        #[cfg(feature = "monitor")]
        {
            self.monitor.retime(r.base_rate_hz);
            self.mon = MonitorState::default();
        }
        self.acc_gain_q32 = g;
        self.leak_q32 = l;
        if self.safe {
            self.core.set_safe(true);
        }
        Ok(())
    }

    /// One base-rate tick (see the crate docs for the policy). Returns the Actuation frame
    /// (COBS, 0x00 delimiter included), followed by a Status frame if one was requested.
    /// `last_exec`: the measured execution time of the previous tick (cycles or
    /// instructions), reported in the frame. Never panics.
    pub fn tick(&mut self, last_exec: u32) -> &[u8] {
        self.ticks = self.ticks.wrapping_add(1);
        let hold = u32::from(self.hold_ticks);
        let fresh = core::mem::replace(&mut self.fresh, false);
        let mut flags = Flags::default();
        let c = &mut self.counters;
        c.ticks = c.ticks.wrapping_add(1);
        if fresh {
            self.missing = 0;
        } else if self.sample.is_some() {
            self.missing = self.missing.saturating_add(1);
            // Held, in the safe state or not: HOLDING and `held_ticks` alike.
            c.held_ticks = c.held_ticks.wrapping_add(1);
            flags.set(Flags::HOLDING, true);
        }
        // The safe state: too many ticks without a frame, or a stability alarm held by
        // `Config.monitor_safe` (until `Command::ClearFaults`).
        let want_safe = (self.sample.is_some() && self.missing > hold) || self.alarm_safe;
        if want_safe != self.safe {
            self.safe = want_safe;
            self.core.set_safe(want_safe);
            if want_safe {
                c.safe_entries = c.safe_entries.wrapping_add(1);
            } else {
                c.safe_exits = c.safe_exits.wrapping_add(1);
                if let Some(s) = self.sample {
                    // Bumpless restart of the traction loop from the back-EMF, reference
                    // ramping up from zero.
                    let speed = self.core.codec().decode(&s).speed;
                    self.core.preset_back_emf(speed);
                }
            }
        }
        if self.safe {
            c.safe_ticks = c.safe_ticks.wrapping_add(1);
            flags.set(Flags::SAFE, true);
        }
        // The counters this tick can move (not a copy of all of them: a 68-byte memcpy).
        let inputs = |k: &wheelset_control::Counters| {
            [k.y_dot, k.current, k.speed, k.demand]
                .iter()
                .fold(0u32, |a, s| {
                    a.wrapping_add(s.clamped).wrapping_add(s.invalid)
                })
        };
        let before = {
            let k = self.core.counters();
            (
                k.yaw_torque.clamped,
                k.voltage.clamped,
                inputs(k),
                k.wsp_ticks,
                k.wsp_events,
            )
        };
        if let (Some(a), Some(s)) = (self.acc, self.sample.as_mut()) {
            // Integrate on every tick with the latest y'' (held when frames are missing).
            let v = {
                let err = self.vel_q32.saturating_sub(self.acc_ref_q32);
                let leak = ((i128::from(err) * i128::from(self.leak_q32)) >> 32) as i64;
                let step = i64::from(a).saturating_mul(self.acc_gain_q32);
                let lim = i64::from(i32::MAX) << 32;
                self.vel_q32 = self
                    .vel_q32
                    .saturating_sub(leak)
                    .saturating_add(step)
                    .clamp(-lim, lim);
                (self.vel_q32 >> 32) as i32
            };
            s.y_dot = v;
        }
        #[cfg(feature = "monitor")]
        if let Some(s) = &self.sample {
            let commanding = self.enabled
                && !self.safe
                && self.core.mode() != wheelset_control::YawMode::Passive;
            // The stability monitor on the received (or integrated) `y'`, at its own
            // sub-rate inside `Monitor::tick`.
            let y_dot = self.core.codec().decode(s).y_dot;
            let ev = self.monitor.tick(&mut self.mon, y_dot, commanding);
            if ev.hunting_rose | ev.actuator_rose {
                self.on_alarm(ev.hunting_rose, ev.actuator_rose);
            }
            flags.set(Flags::HUNTING, ev.hunting);
            flags.set(Flags::ACTUATOR_FAULT, ev.actuator);
        }
        let (t_psi, u_a) = match (self.sample, self.enabled) {
            (Some(s), true) => {
                let mut inp = self.core.codec().decode(&s);
                if self.safe {
                    // Stale current: do not integrate it (policy item 3).
                    self.core.preset_back_emf(inp.speed);
                    inp.current = T::ZERO;
                }
                let out = self.core.tick(&inp);
                let o = self.core.codec().encode(&out);
                (o.yaw_torque, o.voltage)
            }
            (Some(s), false) => {
                // Outputs disabled: zero torque and zero current, i.e. the back-EMF of
                // the latest speed (0 V would short the motor at speed).
                let speed = self.core.codec().decode(&s).speed;
                let o = self.core.codec().encode(&wheelset_control::Outputs {
                    yaw_torque: T::ZERO,
                    voltage: self.core.back_emf(speed),
                });
                (o.yaw_torque, o.voltage)
            }
            (None, _) => {
                let s = Self::safe_outputs();
                (s.t_psi_dnm, s.u_a_cv)
            }
        };
        let after = self.core.counters();
        let yaw_sat = after.yaw_torque.clamped != before.0;
        let tr_sat = after.voltage.clamped != before.1;
        let clamped = inputs(after).wrapping_sub(before.2);
        #[cfg(feature = "wsp")]
        let wsp = (
            after.wsp_ticks.wrapping_sub(before.3),
            after.wsp_events.wrapping_sub(before.4),
        );
        let c = &mut self.counters;
        #[cfg(feature = "wsp")]
        {
            c.wsp_ticks = c.wsp_ticks.wrapping_add(wsp.0);
            c.wsp_events = c.wsp_events.wrapping_add(wsp.1);
        }
        c.yaw_sat = c.yaw_sat.wrapping_add(u32::from(yaw_sat));
        c.traction_sat = c.traction_sat.wrapping_add(u32::from(tr_sat));
        c.input_clamped = c.input_clamped.wrapping_add(clamped);
        flags.set(Flags::ENABLED, self.enabled);
        flags.set(Flags::YAW_SAT, yaw_sat);
        flags.set(Flags::TRACTION_SAT, tr_sat);
        flags.set(Flags::NO_SAMPLE, self.sample.is_none());
        flags.set(
            Flags::RX_ERROR,
            core::mem::replace(&mut self.rx_error, false),
        );
        flags.set(Flags::CMD_REFUSED, self.refused);
        #[cfg(feature = "wsp")]
        flags.set(Flags::WHEEL_SLIP, self.core.wheel_slip());
        flags.set(Flags::FAULT_LATCHED, self.fault_latched);
        c.flags = flags;
        let act = Actuation {
            seq_echo: self.seq,
            tick: self.ticks as u16,
            exec: last_exec,
            flags,
            t_psi_dnm: t_psi,
            u_a_cv: u_a,
        };
        // MAX_FRAME always fits (the proto tests prove every message encodes within it).
        let mut n = encode_actuation(&act, &mut self.tx).unwrap_or(0);
        if core::mem::replace(&mut self.status_requested, false) {
            if let Some(rest) = self.tx.get_mut(n..) {
                n += encode_status(&self.counters, rest).unwrap_or(0);
            }
        }
        self.tx.get(..n).unwrap_or(&[])
    }

    /// A stability alarm rose: counted, the fault latched, and with `monitor_safe` the
    /// safe state held from the next tick until [`Command::ClearFaults`].
    #[cfg(feature = "monitor")]
    #[inline(never)]
    fn on_alarm(&mut self, hunting: bool, actuator: bool) {
        let c = &mut self.counters;
        c.hunt_alarms = c.hunt_alarms.wrapping_add(u32::from(hunting));
        c.act_alarms = c.act_alarms.wrapping_add(u32::from(actuator));
        if c.first_alarm_tick == 0 {
            c.first_alarm_tick = c.ticks;
        }
        self.fault_latched = true;
        if self.monitor_safe {
            self.alarm_safe = true;
        }
    }

    /// The counters.
    pub fn counters(&self) -> &RuntimeCounters {
        &self.counters
    }

    /// The board's own counters since its previous call (added, wrapping): ticks that
    /// started late, deadlines skipped, bytes lost to a receive overrun, transmit frames
    /// dropped. Reported in the [`Status`].
    pub fn note_board(&mut self, late: u32, missed: u32, rx_overrun: u32, tx_dropped: u32) {
        let c = &mut self.counters;
        c.ticks_late = c.ticks_late.wrapping_add(late);
        c.ticks_missed = c.ticks_missed.wrapping_add(missed);
        c.rx_overrun = c.rx_overrun.wrapping_add(rx_overrun);
        c.tx_dropped = c.tx_dropped.wrapping_add(tx_dropped);
    }

    /// The board's boot record: boots since power-on and the reset cause
    /// (`wheelset_proto::reset_cause`). A reset by the watchdog or after a fault latches
    /// [`Flags::FAULT_LATCHED`] (until [`Command::ClearFaults`]).
    pub fn set_boot(&mut self, boot_count: u32, reset_cause: u8) {
        self.counters.boot_count = boot_count;
        self.counters.reset_cause = reset_cause;
        if matches!(
            reset_cause,
            wheelset_proto::reset_cause::WATCHDOG | wheelset_proto::reset_cause::FAULT
        ) {
            self.fault_latched = true;
        }
    }

    /// The stack's high-water mark in bytes, as the board measured it.
    pub fn set_stack_peak(&mut self, bytes: u32) {
        self.counters.stack_peak = bytes;
    }

    /// The sticky fault flag ([`Flags::FAULT_LATCHED`]).
    pub fn fault_latched(&self) -> bool {
        self.fault_latched
    }

    /// The stability monitor's state (its filters and alarms).
    pub fn monitor_state(&self) -> &MonitorState<T> {
        &self.mon
    }

    /// The control core (read only: coefficients, states, its own counters).
    pub fn core(&self) -> &Controller<T> {
        &self.core
    }

    /// The base (tick) rate in force, Hz.
    pub fn base_rate_hz(&self) -> u32 {
        self.core.compiled().base_rate_hz()
    }

    /// Ticks bridged by the held sample before the safe state, in force.
    pub fn hold_ticks(&self) -> u16 {
        self.hold_ticks
    }

    /// Outputs enabled?
    pub fn is_enabled(&self) -> bool {
        self.enabled
    }

    /// In the safe state?
    pub fn is_safe(&self) -> bool {
        self.safe
    }

    /// Why the latest refused Config or Command was refused.
    pub fn refuse_reason(&self) -> RefuseReason {
        self.refuse_reason
    }
}
