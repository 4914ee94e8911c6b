//! The writer: postcard's bytes of every message (the rules in the parent module).

use super::{ACTUATION, COMMAND, CONFIG, SENSOR, STATUS};
use crate::message::{
    Actuation, Command, Config, Lateral, Message, Rates, Sensor, Status, YawMode,
};

/// A bounded writer; `None` once the buffer is full.
struct Out<'a> {
    buf: &'a mut [u8],
    n: usize,
}

/// A sink of raw body bytes with postcard's field forms on top: the bounded [`Out`] here
/// and the one-pass frame writer (COBS and CRC as it goes) of the host's Sensor frame,
/// so a message's layout is written once ([`write_sensor`]).
pub(crate) trait Bytes {
    /// One byte; `None` when the sink is full.
    fn byte(&mut self, b: u8) -> Option<()>;

    #[inline(always)]
    fn u16_le(&mut self, v: u16) -> Option<()> {
        let [a, b] = v.to_le_bytes();
        self.byte(a)?;
        self.byte(b)
    }

    /// postcard's varint: 7 bits a byte, low first, the top bit set on all but the last.
    #[inline(always)]
    fn varint(&mut self, mut v: u32) -> Option<()> {
        while v >= 0x80 {
            self.byte((v as u8) | 0x80)?;
            v >>= 7;
        }
        self.byte(v as u8)
    }

    /// postcard's signed varint (zigzag).
    #[inline(always)]
    fn i32(&mut self, v: i32) -> Option<()> {
        self.varint(((v << 1) ^ (v >> 31)) as u32)
    }
}

impl Bytes for Out<'_> {
    #[inline(always)]
    fn byte(&mut self, b: u8) -> Option<()> {
        *self.buf.get_mut(self.n)? = b;
        self.n += 1;
        Some(())
    }
}

impl Out<'_> {
    fn u64_le(&mut self, v: u64) -> Option<()> {
        for b in v.to_le_bytes() {
            self.byte(b)?;
        }
        Some(())
    }

    fn u32_le(&mut self, v: u32) -> Option<()> {
        for b in v.to_le_bytes() {
            self.byte(b)?;
        }
        Some(())
    }
}

/// Writes the postcard body of `msg` (type byte first) into `out`; returns its length.
/// `None`: `out` too short.
pub(crate) fn encode_body(msg: &Message, out: &mut [u8]) -> Option<usize> {
    match msg {
        Message::Sensor(s) => encode_sensor(s, out),
        Message::Actuation(a) => encode_actuation(a, out),
        Message::Config(c) => encode_config(c, out),
        Message::Command(c) => encode_command(*c, out),
        Message::Status(s) => encode_status(s, out),
    }
}

/// [`encode_body`] of a [`Sensor`].
#[inline(always)]
pub(crate) fn encode_sensor(s: &Sensor, out: &mut [u8]) -> Option<usize> {
    let mut w = Out { buf: out, n: 0 };
    write_sensor(s, &mut w)?;
    Some(w.n)
}

/// The postcard body of a [`Sensor`] (type byte first) into `w`: the one layout of the
/// Sensor message for every writer.
#[inline(always)]
pub(crate) fn write_sensor(s: &Sensor, w: &mut impl Bytes) -> Option<()> {
    let Sensor {
        seq,
        t_us,
        lateral,
        i_a_ma,
        omega_m_mrad_s,
        demand_nm,
        v_ref_mm_s,
    } = *s;
    w.byte(SENSOR)?;
    w.u16_le(seq)?;
    w.u16_le(t_us)?;
    match lateral {
        Lateral::Velocity(v) => {
            w.byte(0)?;
            w.i32(v)?;
        }
        Lateral::Acceleration(a) => {
            w.byte(1)?;
            w.i32(a)?;
        }
        Lateral::Both {
            vel_um_s,
            acc_dmm_s2,
        } => {
            w.byte(2)?;
            w.i32(vel_um_s)?;
            w.i32(acc_dmm_s2)?;
        }
    }
    w.i32(i_a_ma)?;
    w.i32(omega_m_mrad_s)?;
    w.i32(demand_nm)?;
    w.i32(v_ref_mm_s)
}

/// [`encode_body`] of an [`Actuation`].
#[inline(always)]
pub(crate) fn encode_actuation(a: &Actuation, out: &mut [u8]) -> Option<usize> {
    let mut w = Out { buf: out, n: 0 };
    let Actuation {
        seq_echo,
        tick,
        exec,
        flags,
        t_psi_dnm,
        u_a_cv,
    } = *a;
    w.byte(ACTUATION)?;
    w.u16_le(seq_echo)?;
    w.u16_le(tick)?;
    w.varint(exec)?;
    w.varint(u32::from(flags.0))?;
    w.i32(t_psi_dnm)?;
    w.i32(u_a_cv)?;
    Some(w.n)
}

/// [`encode_body`] of a [`Config`].
pub(crate) fn encode_config(c: &Config, out: &mut [u8]) -> Option<usize> {
    let mut w = Out { buf: out, n: 0 };
    let Config {
        mode,
        traction,
        enable,
        hold_ticks,
        wsp,
        monitor_safe,
        rates,
    } = *c;
    w.byte(CONFIG)?;
    w.byte(match mode {
        YawMode::Passive => 0,
        YawMode::Gain => 1,
        YawMode::Lead => 2,
    })?;
    w.byte(u8::from(traction))?;
    w.byte(u8::from(enable))?;
    w.varint(u32::from(hold_ticks))?;
    w.byte(u8::from(wsp))?;
    w.byte(u8::from(monitor_safe))?;
    match rates {
        None => w.byte(0)?,
        Some(r) => {
            let Rates {
                numeric,
                fingerprint,
                base_rate_hz,
                yaw_div,
                traction_div,
                delay_ticks,
                kappa,
                lead_k_hf,
                wsp_lead_k_hf,
                kp,
                ki,
                ki_shift,
                predict_half,
                iref_step,
                iref_safe_step,
                torque_step,
                acc_gain_q32,
                acc_leak_q32,
            } = r;
            w.byte(1)?;
            w.byte(numeric)?;
            w.u32_le(fingerprint)?;
            w.varint(base_rate_hz)?;
            w.varint(u32::from(yaw_div))?;
            w.varint(u32::from(traction_div))?;
            w.byte(delay_ticks)?;
            for v in [kappa, lead_k_hf, wsp_lead_k_hf, kp, ki] {
                w.varint(v)?;
            }
            w.byte(ki_shift)?;
            for v in [predict_half, iref_step, iref_safe_step, torque_step] {
                w.varint(v)?;
            }
            w.u64_le(acc_gain_q32)?;
            w.u64_le(acc_leak_q32)?;
        }
    }
    Some(w.n)
}

/// [`encode_body`] of a [`Command`].
pub(crate) fn encode_command(c: Command, out: &mut [u8]) -> Option<usize> {
    let mut w = Out { buf: out, n: 0 };
    w.byte(COMMAND)?;
    w.byte(match c {
        Command::ResetCounters => 0,
        Command::RequestStatus => 1,
        Command::ClearFaults => 2,
        Command::InjectStall => 3,
        Command::InjectHardFault => 4,
    })?;
    Some(w.n)
}

/// [`encode_body`] of a [`Status`].
pub(crate) fn encode_status(s: &Status, out: &mut [u8]) -> Option<usize> {
    let mut w = Out { buf: out, n: 0 };
    w.byte(STATUS)?;
    for v in status_counters(s) {
        w.varint(v)?;
    }
    w.byte(s.refuse_reason)?;
    w.byte(s.reset_cause)?;
    w.varint(u32::from(s.flags.0))?;
    Some(w.n)
}

/// The `u32` counters of a [`Status`] in declaration order (its fields but the two
/// codes and the flags, which follow them).
fn status_counters(s: &Status) -> [u32; STATUS_COUNTERS] {
    let Status {
        ticks,
        rx_ok,
        rx_crc,
        rx_cobs,
        rx_version,
        rx_length,
        rx_postcard,
        rx_unexpected,
        seq_gaps,
        held_ticks,
        safe_ticks,
        safe_entries,
        safe_exits,
        yaw_sat,
        traction_sat,
        input_clamped,
        cmd_refused,
        ticks_late,
        ticks_missed,
        rx_overrun,
        tx_dropped,
        wsp_ticks,
        wsp_events,
        hunt_alarms,
        act_alarms,
        first_alarm_tick,
        drive_alarms,
        first_drive_alarm_tick,
        boot_count,
        stack_peak,
        refuse_reason: _,
        reset_cause: _,
        flags: _,
    } = *s;
    [
        ticks,
        rx_ok,
        rx_crc,
        rx_cobs,
        rx_version,
        rx_length,
        rx_postcard,
        rx_unexpected,
        seq_gaps,
        held_ticks,
        safe_ticks,
        safe_entries,
        safe_exits,
        yaw_sat,
        traction_sat,
        input_clamped,
        cmd_refused,
        ticks_late,
        ticks_missed,
        rx_overrun,
        tx_dropped,
        wsp_ticks,
        wsp_events,
        hunt_alarms,
        act_alarms,
        first_alarm_tick,
        drive_alarms,
        first_drive_alarm_tick,
        boot_count,
        stack_peak,
    ]
}

/// The number of `u32` counters of a [`Status`] (its worst case is 5 bytes each).
pub(crate) const STATUS_COUNTERS: usize = 30;
