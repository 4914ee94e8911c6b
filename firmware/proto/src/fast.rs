//! Hand-written postcard for every message: the same bytes as `postcard` (serde) writes
//! and the same accept/reject decisions as it makes when reading, without serde's
//! per-field call chain. Equivalence is tested against postcard in `tests/roundtrip.rs`
//! (every message; arbitrary and mutated bodies).
//!
//! Why: in the host's closed loop (one Sensor and one Actuation frame each way per
//! 200 us tick) postcard's serialize took ~240 and its deserialize ~200 instructions per
//! frame (callgrind), more than the CRC and COBS together; on the device, postcard and
//! serde's code for [`Config`] and [`Command`] cost ~1.2 KiB of flash.
//! Each message has its own function, so the device links only the ones it uses.
//!
//! One file of ~600 lines on purpose: the writer ([`Out`]) and the reader ([`In`]) of each
//! message stand side by side, so a field's two directions are read and changed
//! together against the one list of postcard's rules below.
//!
//! postcard's rules used here: an enum variant index is a varint `u32`; `bool` is one
//! byte, 0 or 1; `Option` a byte 0 (None) or 1 (Some) before the value; `u16`, `u32`,
//! are varints (at most 3 and 5 bytes, the last at most 0x03 and 0x0F; longer
//! zero-padded forms accepted); `i32` is zig-zag then varint `u32`; `u8` is one raw byte;
//! `fixint::le` is raw little-endian; struct fields follow in declaration order with no
//! framing.

use crate::message::{
    Actuation, Command, Config, Flags, Lateral, Message, Rates, Sensor, Status, YawMode,
};

/// Message variant indices (declaration order in [`Message`]).
pub(crate) const SENSOR: u8 = 0;
pub(crate) const ACTUATION: u8 = 1;
pub(crate) const CONFIG: u8 = 2;
pub(crate) const COMMAND: u8 = 3;
pub(crate) const STATUS: u8 = 4;
/// [`Command`] variants this version defines (indices `0..COMMANDS`).
pub(crate) const COMMANDS: u32 = 5;
/// [`YawMode`] variants (the first field of a [`Config`]), indices `0..YAW_MODES`.
pub(crate) const YAW_MODES: u32 = 3;

/// The variant index a body starts with (a Command's variant, a Config's mode): its
/// varint as [`In::varint`] reads it, any of its forms (a longer one than the encoder's
/// too); `None` if it is malformed (the message's decoder then refuses it).
pub(crate) fn leading_index(body: &[u8]) -> Option<u32> {
    match varint_of(body) {
        (_, 0) => None,
        (v, _) => Some(v),
    }
}

/// A bounded writer; `None` once the buffer is full.
struct Out<'a> {
    buf: &'a mut [u8],
    n: usize,
}

impl Out<'_> {
    #[inline(always)]
    fn byte(&mut self, b: u8) -> Option<()> {
        *self.buf.get_mut(self.n)? = b;
        self.n += 1;
        Some(())
    }

    #[inline(always)]
    fn u16_le(&mut self, v: u16) -> Option<()> {
        let [a, b] = v.to_le_bytes();
        self.byte(a)?;
        self.byte(b)
    }

    #[inline(always)]
    fn varint(&mut self, mut v: u32) -> Option<()> {
        while v >= 0x80 {
            self.byte((v as u8) | 0x80)?;
            v >>= 7;
        }
        self.byte(v as u8)
    }

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

    #[inline(always)]
    fn i32(&mut self, v: i32) -> Option<()> {
        self.varint(((v << 1) ^ (v >> 31)) as u32)
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
    w.i32(v_ref_mm_s)?;
    Some(w.n)
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
                kappa,
                ki,
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
            for v in [
                kappa,
                ki,
                predict_half,
                iref_step,
                iref_safe_step,
                torque_step,
            ] {
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
        boot_count,
        stack_peak,
    ]
}

/// The number of `u32` counters of a [`Status`] (its worst case is 5 bytes each).
pub(crate) const STATUS_COUNTERS: usize = 28;

/// [`In::varint`]'s decoding: the value and the bytes it takes from the start of `r`,
/// `(_, 0)` where postcard fails. The slice in and the pair out travel in registers (the
/// reader's state is not stored for the call, as it was with `&mut In`).
#[inline(never)]
fn varint_of(r: &[u8]) -> (u32, usize) {
    let Some(&b) = r.first() else {
        return (0, 0);
    };
    let mut v = u32::from(b & 0x7F);
    if b < 0x80 {
        return (v, 1);
    }
    let Some(&b) = r.get(1) else {
        return (0, 0);
    };
    v |= u32::from(b & 0x7F) << 7;
    if b < 0x80 {
        return (v, 2);
    }
    let Some(&b) = r.get(2) else {
        return (0, 0);
    };
    v |= u32::from(b & 0x7F) << 14;
    if b < 0x80 {
        return (v, 3);
    }
    let Some(&b) = r.get(3) else {
        return (0, 0);
    };
    v |= u32::from(b & 0x7F) << 21;
    if b < 0x80 {
        return (v, 4);
    }
    match r.get(4) {
        Some(&b) if b <= 0x0F => (v | u32::from(b) << 28, 5),
        _ => (0, 0),
    }
}

/// Why a body did not decode.
pub(crate) enum BodyError {
    /// postcard would fail (end of input, bad varint, unknown variant).
    Postcard,
    /// It decoded, with bytes left over.
    Trailing,
}

/// A reader; `None` where postcard reports an error.
pub(crate) struct In<'a> {
    rest: &'a [u8],
}

impl In<'_> {
    #[inline(always)]
    fn byte(&mut self) -> Option<u8> {
        let (&b, rest) = self.rest.split_first()?;
        self.rest = rest;
        Some(b)
    }

    #[inline(always)]
    fn u16_le(&mut self) -> Option<u16> {
        Some(u16::from_le_bytes([self.byte()?, self.byte()?]))
    }

    /// postcard's `try_take_varint_u32`: up to 5 bytes, the fifth at most 0x0F.
    ///
    /// The decoding is one out-of-line function ([`varint_of`]), unrolled byte by byte
    /// (no loop, no variable shift): the Sensor frame's physical fields are 2- and 3-byte
    /// varints, and a shared call site per field is smaller than an inlined one-byte fast
    /// path at each (the device's decoder reads about twenty varints). `cargo xtask
    /// fw-bench`, M4 fixed point: the whole tick 2 029 -> 1 906 instructions mean; `cargo
    /// fw`: Nucleo flash 24 872 -> 24 540 B. Each byte tested as it is read, the value
    /// accumulated in one register (rather than all five bytes matched at once: fewer
    /// registers to save): the whole tick 1 454 -> 1 451, Nucleo flash
    /// 21 940 -> 21 888 B. The call takes the slice and returns the value and length in
    /// registers, this wrapper inlined: with `&mut self` passed to it the reader lived in
    /// memory across every field of a message (the whole tick 1 392 -> 1 342, Nucleo
    /// flash 22 452 -> 22 528 B). (The device's per-tick Sensor decoder also reads the
    /// short forms inline: [`Self::varint_short`].)
    #[inline(always)]
    fn varint(&mut self) -> Option<u32> {
        let (v, n) = varint_of(self.rest);
        if n == 0 {
            return None;
        }
        self.rest = self.rest.get(n..)?;
        Some(v)
    }

    /// [`Self::varint`] with its one- to three-byte forms (the Sensor's physical fields
    /// are mostly three bytes) read inline from a 3-byte window, the others (longer, or
    /// fewer than three bytes left) by the call. Measured alternatives (`cargo xtask
    /// fw-bench`, M4 fixed point, whole tick mean; `cargo fw`, Nucleo flash): all of
    /// [`Self::varint`] inlined 1 378 and 22 748 B; this 1 392 and 22 452 B; the same
    /// three forms tested byte by byte (a bound per byte) 1 403 and 22 400 B; one- and
    /// two-byte forms only 1 442 (slower than the call alone, 1 434, 21 872 B). (Measured
    /// with the call taking `&mut In`; with [`varint_of`], this 1 342 and 22 528 B, the
    /// call alone 1 428 and 22 016 B.)
    #[inline(always)]
    fn varint_short(&mut self) -> Option<u32> {
        let r = self.rest;
        if let Some(&[b0, b1, b2]) = r.first_chunk::<3>() {
            let (v, n) = if b0 < 0x80 {
                (u32::from(b0), 1)
            } else if b1 < 0x80 {
                (u32::from(b0 & 0x7F) | u32::from(b1) << 7, 2)
            } else if b2 < 0x80 {
                (
                    u32::from(b0 & 0x7F) | u32::from(b1 & 0x7F) << 7 | u32::from(b2) << 14,
                    3,
                )
            } else {
                return self.varint();
            };
            self.rest = r.get(n..)?;
            return Some(v);
        }
        self.varint()
    }

    /// [`Self::varint`] with its one-byte form (below 0x80, the encoder's form of a
    /// variant index) read inline: the Sensor's `lateral` variant (`cargo xtask fw-bench`,
    /// M4 fixed point, the whole tick 1 451 -> 1 443 mean; Nucleo flash +12 B).
    #[inline(always)]
    fn index(&mut self) -> Option<u32> {
        if let Some((&b, rest)) = self.rest.split_first() {
            if b < 0x80 {
                self.rest = rest;
                return Some(u32::from(b));
            }
        }
        self.varint()
    }

    /// postcard's `try_take_varint_u16`: up to 3 bytes, the third at most 0x03.
    fn varint16(&mut self) -> Option<u16> {
        let mut out = 0u16;
        for i in 0..3 {
            let b = self.byte()?;
            out |= u16::from(b & 0x7F) << (7 * i);
            if b & 0x80 == 0 {
                return (i < 2 || b <= 0x03).then_some(out);
            }
        }
        None
    }

    fn u64_le(&mut self) -> Option<u64> {
        let lo = self.u32_le()?;
        let hi = self.u32_le()?;
        Some(u64::from(lo) | (u64::from(hi) << 32))
    }

    fn u32_le(&mut self) -> Option<u32> {
        Some(u32::from_le_bytes([
            self.byte()?,
            self.byte()?,
            self.byte()?,
            self.byte()?,
        ]))
    }

    /// postcard's `bool`: 0 or 1.
    fn bool(&mut self) -> Option<bool> {
        match self.byte()? {
            0 => Some(false),
            1 => Some(true),
            _ => None,
        }
    }

    #[inline(always)]
    fn i32(&mut self) -> Option<i32> {
        self.i32_g::<false>()
    }

    /// [`Self::i32`], its varint's short forms inlined if `INLINE`
    /// ([`Self::varint_short`]).
    #[inline(always)]
    fn i32_g<const INLINE: bool>(&mut self) -> Option<i32> {
        let n = if INLINE {
            self.varint_short()?
        } else {
            self.varint()?
        };
        Some(((n >> 1) as i32) ^ (-((n & 1) as i32)))
    }
}

/// Decodes a message body (type first: postcard's enum variant index, a varint; the
/// bytes after the version byte).
pub(crate) fn decode_body(body: &[u8]) -> Result<Message, BodyError> {
    let (ty, rest) = message_type(body).ok_or(BodyError::Postcard)?;
    match ty {
        SENSOR => finish(rest, sensor).map(Message::Sensor),
        ACTUATION => finish(rest, actuation).map(Message::Actuation),
        CONFIG => finish(rest, config).map(Message::Config),
        COMMAND => finish(rest, command).map(Message::Command),
        STATUS => finish(rest, status).map(Message::Status),
        _ => Err(BodyError::Postcard),
    }
}

/// The message type (variant index; `u8::MAX` for any index above 254) and the bytes
/// after it; `None`: no valid varint.
#[inline(always)]
pub(crate) fn message_type(body: &[u8]) -> Option<(u8, &[u8])> {
    // One byte below 0x80 is the encoder's form; longer zero-padded forms are accepted.
    if let Some((&t, rest)) = body.split_first() {
        if t < 0x80 {
            return Some((t, rest));
        }
    }
    let mut r = In { rest: body };
    let t = r.varint()?;
    Some((u8::try_from(t).unwrap_or(u8::MAX), r.rest))
}

/// One message from the whole of `rest` (the body after its type byte): postcard's
/// `take_from_bytes` with nothing left over.
#[inline(always)]
pub(crate) fn finish<M>(
    rest: &[u8],
    f: impl FnOnce(&mut In<'_>) -> Option<M>,
) -> Result<M, BodyError> {
    let mut r = In { rest };
    match f(&mut r) {
        Some(m) if r.rest.is_empty() => Ok(m),
        Some(_) => Err(BodyError::Trailing),
        None => Err(BodyError::Postcard),
    }
}

#[inline(always)]
pub(crate) fn sensor(r: &mut In<'_>) -> Option<Sensor> {
    sensor_g::<false>(r)
}

/// [`sensor`] with its varints inlined: the device's per-tick decoder
/// ([`crate::Decoder::next_sensor_or_request`]; the same decisions, one body for both,
/// tested against each other through the decoders, `tests/stream.rs`). `cargo xtask
/// fw-bench`, M4 fixed point, the whole tick 1 434 -> 1 392 mean; `cargo fw`: Nucleo
/// flash 21 872 -> 22 452 B (see [`In::varint_short`]).
#[inline(always)]
pub(crate) fn sensor_inline(r: &mut In<'_>) -> Option<Sensor> {
    sensor_g::<true>(r)
}

#[inline(always)]
fn sensor_g<const INLINE: bool>(r: &mut In<'_>) -> Option<Sensor> {
    let seq = r.u16_le()?;
    let t_us = r.u16_le()?;
    let lateral = match r.index()? {
        0 => Lateral::Velocity(r.i32_g::<INLINE>()?),
        1 => Lateral::Acceleration(r.i32_g::<INLINE>()?),
        2 => Lateral::Both {
            vel_um_s: r.i32_g::<INLINE>()?,
            acc_dmm_s2: r.i32_g::<INLINE>()?,
        },
        _ => return None,
    };
    Some(Sensor {
        seq,
        t_us,
        lateral,
        i_a_ma: r.i32_g::<INLINE>()?,
        omega_m_mrad_s: r.i32_g::<INLINE>()?,
        demand_nm: r.i32_g::<INLINE>()?,
        v_ref_mm_s: r.i32_g::<INLINE>()?,
    })
}

#[inline(always)]
pub(crate) fn actuation(r: &mut In<'_>) -> Option<Actuation> {
    Some(Actuation {
        seq_echo: r.u16_le()?,
        tick: r.u16_le()?,
        exec: r.varint()?,
        flags: Flags(r.varint16()?),
        t_psi_dnm: r.i32()?,
        u_a_cv: r.i32()?,
    })
}

pub(crate) fn config(r: &mut In<'_>) -> Option<Config> {
    let mode = match r.varint()? {
        0 => YawMode::Passive,
        1 => YawMode::Gain,
        2 => YawMode::Lead,
        _ => return None,
    };
    let traction = r.bool()?;
    let enable = r.bool()?;
    let hold_ticks = r.varint16()?;
    let wsp = r.bool()?;
    let monitor_safe = r.bool()?;
    let rates = match r.byte()? {
        0 => None,
        1 => Some(Rates {
            numeric: r.byte()?,
            fingerprint: r.u32_le()?,
            base_rate_hz: r.varint()?,
            yaw_div: r.varint16()?,
            traction_div: r.varint16()?,
            kappa: r.varint()?,
            ki: r.varint()?,
            predict_half: r.varint()?,
            iref_step: r.varint()?,
            iref_safe_step: r.varint()?,
            torque_step: r.varint()?,
            acc_gain_q32: r.u64_le()?,
            acc_leak_q32: r.u64_le()?,
        }),
        _ => return None,
    };
    Some(Config {
        mode,
        traction,
        enable,
        hold_ticks,
        wsp,
        monitor_safe,
        rates,
    })
}

pub(crate) fn command(r: &mut In<'_>) -> Option<Command> {
    match r.varint()? {
        0 => Some(Command::ResetCounters),
        1 => Some(Command::RequestStatus),
        2 => Some(Command::ClearFaults),
        3 => Some(Command::InjectStall),
        4 => Some(Command::InjectHardFault),
        _ => None,
    }
}

fn status(r: &mut In<'_>) -> Option<Status> {
    Some(Status {
        ticks: r.varint()?,
        rx_ok: r.varint()?,
        rx_crc: r.varint()?,
        rx_cobs: r.varint()?,
        rx_version: r.varint()?,
        rx_length: r.varint()?,
        rx_postcard: r.varint()?,
        rx_unexpected: r.varint()?,
        seq_gaps: r.varint()?,
        held_ticks: r.varint()?,
        safe_ticks: r.varint()?,
        safe_entries: r.varint()?,
        safe_exits: r.varint()?,
        yaw_sat: r.varint()?,
        traction_sat: r.varint()?,
        input_clamped: r.varint()?,
        cmd_refused: r.varint()?,
        ticks_late: r.varint()?,
        ticks_missed: r.varint()?,
        rx_overrun: r.varint()?,
        tx_dropped: r.varint()?,
        wsp_ticks: r.varint()?,
        wsp_events: r.varint()?,
        hunt_alarms: r.varint()?,
        act_alarms: r.varint()?,
        first_alarm_tick: r.varint()?,
        boot_count: r.varint()?,
        stack_peak: r.varint()?,
        refuse_reason: r.byte()?,
        reset_cause: r.byte()?,
        flags: Flags(r.varint16()?),
    })
}
