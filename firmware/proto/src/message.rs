//! The messages. Every physical field is an integer count of the LSB stated in
//! [`crate::units`]; the field name carries the unit.

use serde::{Deserialize, Serialize};

/// The lateral measurement of the wheelset, relative to the track (so it is zero on a
/// constant curve): velocity `y'`, acceleration `y''`, or both. Positive towards +y
/// (right, the outer rail of the left-hand `curve`). Wire index: `Velocity` 0,
/// `Acceleration` 1, `Both` 2.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Lateral {
    /// `y'` in um/s ([`crate::units::LAT_VEL_LSB_M_PER_S`]).
    Velocity(i32),
    /// `y''` in 0.1 mm/s^2 ([`crate::units::LAT_ACC_LSB_M_PER_S2`]); the device integrates.
    Acceleration(i32),
    /// Both: the device runs a complementary filter of the two (crossover at the `y''`
    /// wash-out, `wheelset_runtime` crate docs).
    Both {
        /// `y'` in um/s.
        vel_um_s: i32,
        /// `y''` in 0.1 mm/s^2.
        acc_dmm_s2: i32,
    },
}

/// Host -> device, once per base-rate tick: the sampled plant measurements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Sensor {
    /// Sequence number, +1 per frame (wrapping); the device echoes the latest one.
    #[serde(with = "postcard::fixint::le")]
    pub seq: u16,
    /// Host sampling instant in us, modulo 2^16 (wraps every 65.536 ms).
    #[serde(with = "postcard::fixint::le")]
    pub t_us: u16,
    /// Lateral velocity and/or acceleration of the wheelset, track relative.
    pub lateral: Lateral,
    /// Motor armature current `i_a` in mA, positive motoring.
    pub i_a_ma: i32,
    /// Motor speed `theta_m'` in mrad/s, positive forwards.
    pub omega_m_mrad_s: i32,
    /// Traction demand as wheel torque `n K_m i_ref` in N m (0: none).
    pub demand_nm: i32,
}

/// Status and fault flags carried in every [`Actuation`] and [`Status`] (bit set = true).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(transparent)]
pub struct Flags(pub u8);

impl Flags {
    /// Outputs enabled (a [`Config`] with `enable = true` was applied, or the default).
    pub const ENABLED: u8 = 1 << 0;
    /// This tick ran on a held sample: no new valid sensor frame since the last tick (in
    /// the safe state too; `held_ticks` counts these ticks).
    pub const HOLDING: u8 = 1 << 1;
    /// The safe state is active: yaw torque ramping to / held at zero, traction demand zero.
    pub const SAFE: u8 = 1 << 2;
    /// At least one frame was rejected (CRC, COBS, version, length, postcard) since the
    /// previous actuation frame.
    pub const RX_ERROR: u8 = 1 << 3;
    /// The yaw torque was limited this tick: by the fixed limit, or by the safe-state /
    /// recovery ramp of the limit.
    pub const YAW_SAT: u8 = 1 << 4;
    /// The traction loop (voltage) saturated this tick.
    pub const TRACTION_SAT: u8 = 1 << 5;
    /// No valid sensor frame since start or the last reset: outputs are the safe outputs.
    pub const NO_SAMPLE: u8 = 1 << 6;
    /// The latest [`Config`] or [`Command`] was refused (invalid rates, unknown request).
    pub const CMD_REFUSED: u8 = 1 << 7;

    /// Whether every bit of `mask` is set.
    #[must_use]
    pub const fn has(self, mask: u8) -> bool {
        self.0 & mask == mask
    }
    /// Sets or clears the bits of `mask`.
    pub fn set(&mut self, mask: u8, on: bool) {
        if on {
            self.0 |= mask;
        } else {
            self.0 &= !mask;
        }
    }
}

/// Device -> host, once per base-rate tick: the actuator commands and the tick's record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Actuation {
    /// The `seq` of the latest valid [`Sensor`] the device used (0 before the first).
    #[serde(with = "postcard::fixint::le")]
    pub seq_echo: u16,
    /// Device tick count modulo 2^16, from 1 (the first tick after start-up sends 1).
    #[serde(with = "postcard::fixint::le")]
    pub tick: u16,
    /// Execution time of the previous tick: cycles (board, DWT) or instructions (QEMU).
    pub exec: u32,
    /// Status and fault flags.
    pub flags: Flags,
    /// Yaw torque `T_psi` in 0.1 N m (sign as in `docs/model.md` eq. 5: `J psi'' ... = -T_psi`).
    pub t_psi_dnm: i32,
    /// Motor voltage `u_a` in 10 mV.
    pub u_a_cv: i32,
}

/// Yaw damping law selected on the device; the control core's own enum
/// (`wheelset_control::YawMode` is this type). Wire index: `Passive` 0, `Gain` 1,
/// `Lead` 2; another index is an unknown request (refused, not a decoding error).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum YawMode {
    /// 0. Passive: the device's yaw output is zero (the yaw spring is mechanical).
    Passive = 0,
    /// 1. Pure gain `T_psi = K y'`.
    Gain = 1,
    /// 2. Phase lead `Ks(s) y'` (the default).
    #[default]
    Lead = 2,
}

/// Host -> device: configuration. Applied at the next tick if valid, refused (and
/// counted, [`Flags::CMD_REFUSED`]) otherwise; the previous configuration stays.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Config {
    /// Yaw damping law.
    pub mode: YawMode,
    /// Traction on; off: the device treats the traction demand as zero.
    pub traction: bool,
    /// Outputs enabled; disabled drives the safe outputs.
    pub enable: bool,
    /// Ticks a missing sensor frame is bridged by the held sample before the safe state.
    pub hold_ticks: u16,
    /// New rates with their coefficients (the control core restarts on them); `None`
    /// keeps the rates.
    pub rates: Option<Rates>,
}

/// Rates and the rate-dependent coefficients of the control core and the runtime, as
/// exact bit patterns, computed by the host with the device's own control code
/// (`wheelset_runtime::rates_for`): the device does no discretisation, it validates and
/// applies them.
///
/// A coefficient or per-unit signal is the bit pattern of the device's sample type
/// (`numeric`): fixed point (0) Q1.31 / Q4.28 `i32` bits, `f32` (1) IEEE bits.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rates {
    /// The device's sample type: 0 fixed point, 1 `f32`; another is refused.
    pub numeric: u8,
    /// Fingerprint of the rate-independent part of the control core these coefficients
    /// were computed against (`wheelset_control::CompiledBits::fingerprint`); a
    /// mismatch is refused.
    #[serde(with = "postcard::fixint::le")]
    pub fingerprint: u32,
    /// Base (tick) rate in Hz.
    pub base_rate_hz: u32,
    /// Yaw loop runs every `yaw_div` base ticks.
    pub yaw_div: u16,
    /// Traction loop runs every `traction_div` base ticks.
    pub traction_div: u16,
    /// Lead `kappa` at the yaw period (coefficient bits).
    pub kappa: u32,
    /// PI `Ki` at the traction period (coefficient bits).
    pub ki: u32,
    /// Delay-compensation factor `alpha/2` (coefficient bits).
    pub predict_half: u32,
    /// Current-reference slew per traction step (per-unit signal bits).
    pub iref_step: u32,
    /// Safe-state current-reference ramp per traction step (per-unit signal bits).
    pub iref_safe_step: u32,
    /// Safe-state torque-limit ramp per yaw step (per-unit signal bits).
    pub torque_step: u32,
    /// `y''` integrator: `T` in Q32 (um/s per 0.1 mm/s^2 code per tick), `<= 2^32`
    /// (fixed 8 bytes: shorter than a varint's worst case, and simpler to read).
    #[serde(with = "postcard::fixint::le")]
    pub acc_gain_q32: u64,
    /// `y''` integrator wash-out `T/tau` in Q32, `<= 2^32` (0: none; fixed 8 bytes).
    #[serde(with = "postcard::fixint::le")]
    pub acc_leak_q32: u64,
}

/// Host -> device: one-shot requests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Command {
    /// Zero every counter of the [`Status`].
    ResetCounters,
    /// Send a [`Status`] frame (after the next actuation frame).
    RequestStatus,
}

/// Device -> host, on request: the counters (all wrap at 2^32).
///
/// Accounting identity (receive side): every frame the device's decoder delimits (bytes
/// between two 0x00, empty ones ignored) counts in exactly one of `rx_ok`,
/// `rx_unexpected`, `rx_crc`, `rx_cobs`, `rx_version`, `rx_length`, `rx_postcard`; so a
/// host that sent `n` frames over a clean link reads `n` as their sum. `cmd_refused`
/// counts the refused Configs and Commands among `rx_ok` (unknown requests included);
/// `held_ticks` counts the ticks flagged [`Flags::HOLDING`], `safe_ticks` those flagged
/// [`Flags::SAFE`], `yaw_sat` those flagged [`Flags::YAW_SAT`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct Status {
    /// Base-rate ticks run.
    pub ticks: u32,
    /// Valid frames of a type the device takes (Sensor, Config, Command; refused ones
    /// included).
    pub rx_ok: u32,
    /// Frames rejected: CRC mismatch.
    pub rx_crc: u32,
    /// Frames rejected: invalid COBS.
    pub rx_cobs: u32,
    /// Frames rejected: protocol version.
    pub rx_version: u32,
    /// Frames rejected: too short, too long, or trailing bytes.
    pub rx_length: u32,
    /// Frames rejected: postcard could not decode the message.
    pub rx_postcard: u32,
    /// Frames (CRC and version valid) of a type the device does not accept (an Actuation
    /// or a Status; their bodies are not decoded); not also in `rx_ok`.
    pub rx_unexpected: u32,
    /// Sensor frames whose `seq` was not the previous one + 1 (a gap or a repeat).
    pub seq_gaps: u32,
    /// Ticks run on a held sample ([`Flags::HOLDING`], in the safe state too).
    pub held_ticks: u32,
    /// Ticks in the safe state.
    pub safe_ticks: u32,
    /// Entries into the safe state.
    pub safe_entries: u32,
    /// Exits from the safe state (valid frames returned).
    pub safe_exits: u32,
    /// Ticks with the yaw torque limited: by the fixed limit or the safe/recovery ramp.
    pub yaw_sat: u32,
    /// Ticks with the motor voltage saturated.
    pub traction_sat: u32,
    /// Input values clamped while converting to the control core's sample type.
    pub input_clamped: u32,
    /// Refused configurations and commands.
    pub cmd_refused: u32,
    /// The current flags.
    pub flags: Flags,
}

/// Every message; the postcard variant index is the message type byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Message {
    /// Type 0, host -> device.
    Sensor(Sensor),
    /// Type 1, device -> host.
    Actuation(Actuation),
    /// Type 2, host -> device.
    Config(Config),
    /// Type 3, host -> device.
    Command(Command),
    /// Type 4, device -> host.
    Status(Status),
}
