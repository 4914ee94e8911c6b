//! The reader: postcard's decisions on every message body (the rules in the parent
//! module), with the fast forms the device's per-tick Sensor decoder uses.

use super::{ACTUATION, COMMAND, CONFIG, SENSOR, STATUS};
use crate::message::{
    Actuation, Command, Config, Flags, Lateral, Message, Rates, Sensor, Status, YawMode,
};

/// [`In::varint`]'s decoding: the value and the bytes it takes from the start of `r`,
/// `(_, 0)` where postcard fails. The slice in and the pair out travel in registers (the
/// reader's state is not stored for the call, as it was with `&mut In`).
#[inline(never)]
pub(super) fn varint_of(r: &[u8]) -> (u32, usize) {
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
    /// (no loop, no variable shift), each byte tested as it is read and the value
    /// accumulated in one register: one shared call per field is smaller than a fast
    /// path inlined at each of the twenty-odd varints the device reads. The call takes
    /// the slice and returns the value and the length in registers, and this wrapper is
    /// inlined, so the reader stays in registers across the fields of a message rather
    /// than in memory behind a `&mut self`. (The device's per-tick Sensor decoder also
    /// reads the short forms inline: [`Self::varint_short`].) Instruction counts and
    /// sizes: `cargo xtask fw-bench`, `cargo fw`.
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
    /// are mostly three bytes) read inline from one 3-byte window (one bound check for
    /// the three), the others (longer, or fewer than three bytes left) by the call. A
    /// trade of flash for the device's per-tick decoding: close to the speed of the whole
    /// varint inlined at each field, for less flash.
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
    /// variant index) read inline: the Sensor's `lateral` variant.
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

    /// [`Self::varint16`] with its one-byte form read inline.
    #[inline(always)]
    fn varint16_short(&mut self) -> Option<u16> {
        if let Some((&b, rest)) = self.rest.split_first() {
            if b < 0x80 {
                self.rest = rest;
                return Some(u16::from(b));
            }
        }
        self.varint16()
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

    /// postcard's `i32` (zig-zag, then the varint), its varint's short forms inlined if `INLINE`
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
#[cfg_attr(feature = "std", inline(always))]
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

/// [`sensor`] with its varints' short forms inlined ([`In::varint_short`]): the
/// device's per-tick decoder ([`crate::Decoder::next_sensor_or_request`]). The same
/// decisions, one body for both (tested against each other through the decoders,
/// `tests/stream.rs`).
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

/// The host's decoder of the device's per-tick frame: the short forms of its varints
/// read inline ([`In::varint_short`], [`In::varint16_short`]), as the device's Sensor
/// decoder reads them (the device never decodes an Actuation: no flash).
#[inline(always)]
pub(crate) fn actuation(r: &mut In<'_>) -> Option<Actuation> {
    Some(Actuation {
        seq_echo: r.u16_le()?,
        tick: r.u16_le()?,
        exec: r.varint_short()?,
        flags: Flags(r.varint16_short()?),
        t_psi_dnm: r.i32_g::<true>()?,
        u_a_cv: r.i32_g::<true>()?,
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
            delay_ticks: r.byte()?,
            kappa: r.varint()?,
            lead_k_hf: r.varint()?,
            wsp_lead_k_hf: r.varint()?,
            kp: r.varint()?,
            ki: r.varint()?,
            ki_shift: r.byte()?,
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

pub(crate) fn status(r: &mut In<'_>) -> Option<Status> {
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
        drive_alarms: r.varint()?,
        first_drive_alarm_tick: r.varint()?,
        boot_count: r.varint()?,
        stack_peak: r.varint()?,
        refuse_reason: r.byte()?,
        reset_cause: r.byte()?,
        flags: Flags(r.varint16()?),
    })
}
