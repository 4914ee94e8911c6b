//! Hand-written postcard for the two per-tick messages, [`Sensor`] and [`Actuation`]:
//! the same bytes as `postcard` (serde) writes and the same accept/reject decisions as it
//! makes when reading, without serde's per-field call chain. Every other message goes
//! through postcard itself. Equivalence is tested against postcard in
//! `tests/roundtrip.rs` (every message; arbitrary and mutated bodies).
//!
//! Why: in the host's closed loop (one Sensor and one Actuation frame each way per
//! 200 us tick) postcard's serialize took ~240 and its deserialize ~200 instructions per
//! frame (callgrind), more than the CRC and COBS together.
//!
//! postcard's rules used here: the enum variant index is a varint `u32`; `i32` is
//! zig-zag then varint `u32`; `u32` is varint (at most 5 bytes, the fifth < 0x10, longer
//! zero-padded forms accepted); `u8` is one raw byte; `fixint::le` `u16` is 2 raw bytes
//! little-endian; struct fields follow in declaration order with no framing.

use crate::message::{Actuation, Flags, Lateral, Message, Sensor};

/// Message variant indices (declaration order in [`Message`]).
const SENSOR: u8 = 0;
const ACTUATION: u8 = 1;

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

    #[inline(always)]
    fn i32(&mut self, v: i32) -> Option<()> {
        self.varint(((v << 1) ^ (v >> 31)) as u32)
    }
}

/// Writes the postcard body of a Sensor or Actuation message into `out`; returns its
/// length. `None`: another message (use postcard), or `out` too short.
pub(crate) fn encode_body(msg: &Message, out: &mut [u8]) -> Option<usize> {
    let mut w = Out { buf: out, n: 0 };
    match msg {
        Message::Sensor(s) => {
            let Sensor {
                seq,
                t_us,
                lateral,
                i_a_ma,
                omega_m_mrad_s,
                demand_nm,
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
        }
        Message::Actuation(a) => {
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
            w.byte(flags.0)?;
            w.i32(t_psi_dnm)?;
            w.i32(u_a_cv)?;
        }
        Message::Config(_) | Message::Command(_) | Message::Status(_) => return None,
    }
    Some(w.n)
}

/// Why a body did not decode.
pub(crate) enum BodyError {
    /// postcard would fail (end of input, bad varint, unknown variant).
    Postcard,
    /// It decoded, with bytes left over.
    Trailing,
}

/// A reader; `None` where postcard reports an error.
struct In<'a> {
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
    #[inline(always)]
    fn varint(&mut self) -> Option<u32> {
        let mut out = 0u32;
        for i in 0..5 {
            let b = self.byte()?;
            out |= u32::from(b & 0x7F) << (7 * i);
            if b & 0x80 == 0 {
                return (i < 4 || b <= 0x0F).then_some(out);
            }
        }
        None
    }

    #[inline(always)]
    fn i32(&mut self) -> Option<i32> {
        let n = self.varint()?;
        Some(((n >> 1) as i32) ^ (-((n & 1) as i32)))
    }
}

/// Decodes a Sensor or Actuation body (the bytes after the version byte). `None`:
/// another message type (or a non-minimal variant index): use postcard.
pub(crate) fn decode_body(body: &[u8]) -> Option<Result<Message, BodyError>> {
    let (&ty, rest) = body.split_first()?;
    let mut r = In { rest };
    let msg = match ty {
        SENSOR => sensor(&mut r).map(Message::Sensor),
        ACTUATION => actuation(&mut r).map(Message::Actuation),
        _ => return None,
    };
    Some(match msg {
        Some(m) if r.rest.is_empty() => Ok(m),
        Some(_) => Err(BodyError::Trailing),
        None => Err(BodyError::Postcard),
    })
}

#[inline(always)]
fn sensor(r: &mut In<'_>) -> Option<Sensor> {
    let seq = r.u16_le()?;
    let t_us = r.u16_le()?;
    let lateral = match r.varint()? {
        0 => Lateral::Velocity(r.i32()?),
        1 => Lateral::Acceleration(r.i32()?),
        2 => Lateral::Both {
            vel_um_s: r.i32()?,
            acc_dmm_s2: r.i32()?,
        },
        _ => return None,
    };
    Some(Sensor {
        seq,
        t_us,
        lateral,
        i_a_ma: r.i32()?,
        omega_m_mrad_s: r.i32()?,
        demand_nm: r.i32()?,
    })
}

#[inline(always)]
fn actuation(r: &mut In<'_>) -> Option<Actuation> {
    Some(Actuation {
        seq_echo: r.u16_le()?,
        tick: r.u16_le()?,
        exec: r.varint()?,
        flags: Flags(r.byte()?),
        t_psi_dnm: r.i32()?,
        u_a_cv: r.i32()?,
    })
}
