//! The messages; every physical field is an integer count of its [`crate::units`] LSB.

/// The lateral measurement relative to the track: `y'`, `y''` or both; + towards +y (right).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Lateral {
    /// `y'` in um/s ([`crate::units::LAT_VEL_LSB_M_PER_S`]).
    Velocity(i32),
    /// `y''` in 0.1 mm/s^2 ([`crate::units::LAT_ACC_LSB_M_PER_S2`]); the device integrates.
    Acceleration(i32),
    /// Both: the device runs a complementary filter of the two (`wheelset_runtime` crate docs).
    Both {
        /// `y'` in um/s.
        vel_um_s: i32,
        /// `y''` in 0.1 mm/s^2.
        acc_dmm_s2: i32,
    },
}

/// Host -> device, once per base-rate tick: the sampled plant measurements.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
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
    /// Vehicle reference speed `v` in mm/s, + forwards, from a source independent of this
    /// drive; **0 means unknown** (no slip protection), so a standing vehicle is sent as 1.
    pub v_ref_mm_s: i32,
}

impl Sensor {
    /// Every field zero, the lateral a velocity: a buffer before the first frame, a test's base.
    pub const ZERO: Self = Self {
        seq: 0,
        t_us: 0,
        lateral: Lateral::Velocity(0),
        i_a_ma: 0,
        omega_m_mrad_s: 0,
        demand_nm: 0,
        v_ref_mm_s: 0,
    };
}

/// Status and fault flags (bit set = true); 16 bits, a postcard varint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[serde(transparent)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Flags(pub u16);

impl Flags {
    /// Bit 0. Outputs enabled (a [`Config`] with `enable = true`, or the default).
    pub const ENABLED: u16 = 1 << 0;
    /// Bit 1. This tick ran on a held sample: no new valid sensor frame since the last tick.
    pub const HOLDING: u16 = 1 << 1;
    /// Bit 2. Safe state: yaw torque ramping to / held at zero, traction demand zero.
    pub const SAFE: u16 = 1 << 2;
    /// Bit 3. A frame was rejected since the previous actuation frame.
    pub const RX_ERROR: u16 = 1 << 3;
    /// Bit 4. The yaw torque was limited this tick (fixed limit or the safe-state ramp).
    pub const YAW_SAT: u16 = 1 << 4;
    /// Bit 5. The traction loop (voltage) saturated this tick.
    pub const TRACTION_SAT: u16 = 1 << 5;
    /// Bit 6. No valid sensor frame since start or reset: the outputs are the safe outputs.
    pub const NO_SAMPLE: u16 = 1 << 6;
    /// Bit 7. The latest Config or Command was refused (a `RequestStatus` leaves it).
    pub const CMD_REFUSED: u16 = 1 << 7;
    /// Bit 8. The wheel-slip protection holds the current reference below the demand's.
    pub const WHEEL_SLIP: u16 = 1 << 8;
    /// Bit 9. The monitor's hunting alarm (band-passed `y'` RMS above its threshold).
    pub const HUNTING: u16 = 1 << 9;
    /// Bit 10. The monitor's actuator alarm (the torque has no effect, or a reported fault).
    pub const ACTUATOR_FAULT: u16 = 1 << 10;
    /// Bit 11. Sticky: an alarm or a watchdog / fault reset since [`Command::ClearFaults`].
    pub const FAULT_LATCHED: u16 = 1 << 11;
    /// Bit 12. The drive check's alarm: the traction current loop oscillates.
    pub const DRIVE_OSC: u16 = 1 << 12;

    /// Whether every bit of `mask` is set.
    #[must_use]
    pub const fn has(self, mask: u16) -> bool {
        self.0 & mask == mask
    }
    /// Sets or clears the bits of `mask`.
    pub fn set(&mut self, mask: u16, on: bool) {
        if on {
            self.0 |= mask;
        } else {
            self.0 &= !mask;
        }
    }
}

/// Device -> host, once per base-rate tick: the actuator commands and the tick's record.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
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

/// Yaw damping law (the control core's own enum); another index is an unknown request.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
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

/// Host -> device: configuration, applied at the next tick if valid, else refused whole.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Config {
    /// Yaw damping law.
    pub mode: YawMode,
    /// Traction on; off: the device treats the traction demand as zero.
    pub traction: bool,
    /// Outputs enabled; disabled drives the safe outputs.
    pub enable: bool,
    /// Ticks a missing sensor frame is bridged by the held sample before the safe state.
    pub hold_ticks: u16,
    /// Wheel-slip protection on ([`Flags::WHEEL_SLIP`]; idle while `v_ref_mm_s` is 0). On at boot.
    pub wsp: bool,
    /// A stability alarm holds the safe state until [`Command::ClearFaults`]; off: only reported.
    pub monitor_safe: bool,
    /// New rates with their coefficients (the core restarts on them); `None` keeps the rates.
    pub rates: Option<Rates>,
}

/// Rates and their designed coefficients as exact bits (`wheelset_runtime::rates_for`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Rates {
    /// The device's sample type: 0 fixed point, 1 `f32`; another is refused.
    pub numeric: u8,
    /// Fingerprint of the core's rate-independent part; a mismatch is refused.
    #[serde(with = "postcard::fixint::le")]
    pub fingerprint: u32,
    /// Base (tick) rate in Hz.
    pub base_rate_hz: u32,
    /// Yaw loop runs every `yaw_div` base ticks.
    pub yaw_div: u16,
    /// Traction loop runs every `traction_div` base ticks.
    pub traction_div: u16,
    /// Ticks from sampling to actuation the gains are designed for (1: reply before the next tick).
    pub delay_ticks: u8,
    /// Lead `kappa` at the yaw period (coefficient bits).
    pub kappa: u32,
    /// Lead `K_hf` designed for the rate and delay (coefficient bits).
    pub lead_k_hf: u32,
    /// The wheel-slip protection's scheduled lead gain (coefficient bits).
    pub wsp_lead_k_hf: u32,
    /// PI `Kp` designed for the rate and delay (coefficient bits).
    pub kp: u32,
    /// PI `Ki` at the traction period times `2^ki_shift` (coefficient bits).
    pub ki: u32,
    /// The shift `Ki` is held with (fixed point; 0 for `f32`).
    pub ki_shift: u8,
    /// Delay-compensation factor `alpha/2` (coefficient bits).
    pub predict_half: u32,
    /// Current-reference slew per traction step (per-unit signal bits).
    pub iref_step: u32,
    /// Safe-state current-reference ramp per traction step (per-unit signal bits).
    pub iref_safe_step: u32,
    /// Safe-state torque-limit ramp per yaw step (per-unit signal bits).
    pub torque_step: u32,
    /// `y''` integrator: `T` in Q32 (um/s per 0.1 mm/s^2 code per tick), `<= 2^32`, fixed 8 bytes.
    #[serde(with = "postcard::fixint::le")]
    pub acc_gain_q32: u64,
    /// `y''` integrator wash-out `T/tau` in Q32, `<= 2^32` (0: none; fixed 8 bytes).
    #[serde(with = "postcard::fixint::le")]
    pub acc_leak_q32: u64,
}

/// Host -> device: one-shot requests.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Command {
    /// Zero every counter of the [`Status`].
    ResetCounters,
    /// Send a [`Status`] frame (after the next actuation frame).
    RequestStatus,
    /// Clear [`Flags::FAULT_LATCHED`] and leave a safe state held by an alarm or a fault reset.
    ClearFaults,
    /// Test only (index 3): stall the control task so the watchdog resets the board.
    InjectStall,
    /// Test only (index 4): trigger a HardFault (safe outputs, reset); `fault-inject` QEMU builds.
    InjectHardFault,
}

/// Device -> host, on request: the counters (wrapping); each delimited frame counts in
/// exactly one of `rx_ok`, `rx_unexpected` and the five `rx_*` errors.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Status {
    /// Base-rate ticks run.
    pub ticks: u32,
    /// Valid frames of a type the device takes (refused ones included).
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
    /// Valid frames of a type the device does not take (Actuation, Status); not in `rx_ok`.
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
    /// Board: ticks that started at least a quarter period late; 0 when frame-clocked.
    pub ticks_late: u32,
    /// Board: deadlines that passed without a tick (the ticker skipped them).
    pub ticks_missed: u32,
    /// Board: bytes lost on receive (no room, or one per UART receive error).
    pub rx_overrun: u32,
    /// Board: transmit frames dropped because the previous one was still being sent.
    pub tx_dropped: u32,
    /// Ticks with the wheel-slip protection acting ([`Flags::WHEEL_SLIP`]).
    pub wsp_ticks: u32,
    /// Entries into wheel-slip protection (rising edges of [`Flags::WHEEL_SLIP`]).
    pub wsp_events: u32,
    /// Hunting alarms raised (rising edges of [`Flags::HUNTING`]).
    pub hunt_alarms: u32,
    /// Actuator alarms raised (rising edges of [`Flags::ACTUATOR_FAULT`]).
    pub act_alarms: u32,
    /// `ticks` at the first alarm since the counters' reset (0: none).
    pub first_alarm_tick: u32,
    /// Drive alarms raised (rising edges of [`Flags::DRIVE_OSC`]).
    pub drive_alarms: u32,
    /// `ticks` at the first drive alarm since the counters' reset (0: none).
    pub first_drive_alarm_tick: u32,
    /// Board: boots since power-on (survives a watchdog reset and [`Command::ResetCounters`]).
    pub boot_count: u32,
    /// Board: the stack's high-water mark, bytes (0: not measured); kept by a reset of the counters.
    pub stack_peak: u32,
    /// Why the latest refused Config or Command was refused ([`crate::RefuseReason`]; 0: none).
    pub refuse_reason: u8,
    /// Why the board last started ([`crate::reset_cause`]); not zeroed by a reset.
    pub reset_cause: u8,
    /// The current flags.
    pub flags: Flags,
}

/// Every message; the postcard variant index is the message type byte.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
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
