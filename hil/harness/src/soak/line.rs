//! The soak's serial line, one direction at a time: the fault kinds of the simulated
//! link (`wheelset_loop::sim_link`: whole-frame drops, outages, bit errors drawn by
//! geometric skips, Poisson error bursts), switched on and off by the soak's episodes,
//! and the receiver's frame accounting kept as running counts (nothing per frame).
//!
//! The in-process exchange fits one period by the link budget (`sim_link::check_budget`:
//! a Sensor frame sent at `t_k` has arrived before tick `k`, its Actuation before
//! `t_k + T`), so each frame is carried whole within its period; byte `k` of a frame
//! sent at `t` is on the wire at `t + (k + 1) 10 / baud` (what an outage cuts and where a
//! burst starts).

use rand::Rng;
use rand_distr::{Distribution, Exp, Geometric};
use rand_pcg::Pcg64;
use wheelset_proto::FrameError;

use crate::check::frames::Direction;

/// The faults of one episode on one direction (all off: a clean line).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct LineFaults {
    /// Bit error rate per data bit.
    pub ber: f64,
    /// Probability a whole frame is lost.
    pub drop: f64,
    /// An outage: every byte on the wire in `[start, end)` ns is lost.
    pub outage: Option<(u64, u64)>,
    /// Error bursts: mean bursts per second and bytes garbled per burst.
    pub burst: Option<(f64, u32)>,
}

impl LineFaults {
    /// Any fault on?
    #[must_use]
    pub fn any(&self) -> bool {
        self.ber > 0.0 || self.drop > 0.0 || self.outage.is_some() || self.burst.is_some()
    }
}

/// Every frame sent, accounted for (`frames`: `sent = received + rejected + dropped +
/// in_flight`, as the receiving port of `sim_link` attributes them: a rejected frame
/// merged with the next by a lost delimiter takes the next's fate too), and the events.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize)]
pub struct LineCounts {
    /// The frames' fates (`sent`, `received`, ... in the JSON).
    #[serde(flatten)]
    pub frames: Direction,
    /// Valid frames the receiver's decoder closed (events).
    pub ok_events: u64,
    /// Rejects the receiver's decoder counted, by kind: CRC, COBS, version, length,
    /// postcard (events).
    pub rejects: [u64; 5],
    /// Frames the line changed or cut (a fault touched them).
    pub touched: u64,
}

/// One direction: the faults in force, their random state, the receiver's accounting.
#[derive(Debug, Clone)]
pub struct Line {
    rng: Pcg64,
    faults: LineFaults,
    byte_ns: u64,
    bits_to_error: u64,
    next_burst_ns: u64,
    burst_left: u32,
    buf: Vec<u8>,
    open: bool,
    /// The accounting.
    pub counts: LineCounts,
}

/// How the frame just carried ended at the receiver.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fate {
    /// It closed valid, alone (no bytes of an earlier frame with it).
    Valid,
    /// It closed rejected, or valid but merged with an earlier frame's bytes.
    Rejected,
    /// None of its bytes reached the decoder.
    Dropped,
    /// Its bytes wait for a delimiter.
    InFlight,
}

impl Line {
    /// A clean line at `baud` with its own random stream.
    #[must_use]
    pub fn new(rng: Pcg64, baud: u32) -> Self {
        Self {
            rng,
            faults: LineFaults::default(),
            byte_ns: (10 * 1_000_000_000) / u64::from(baud.max(1)),
            bits_to_error: u64::MAX,
            next_burst_ns: u64::MAX,
            burst_left: 0,
            buf: Vec::with_capacity(2 * wheelset_proto::MAX_FRAME),
            open: false,
            counts: LineCounts::default(),
        }
    }

    /// The faults from `now_ns` on.
    pub fn set_faults(&mut self, f: LineFaults, now_ns: u64) {
        self.faults = f;
        self.bits_to_error = geometric(&mut self.rng, f.ber);
        self.burst_left = 0;
        self.next_burst_ns = match f.burst {
            Some((rate, _)) => now_ns.saturating_add(exponential_ns(&mut self.rng, rate)),
            None => u64::MAX,
        };
    }

    /// A frame sent now arrives as sent: no fault in force, and no bytes of an unfinished
    /// frame in the receiver's decoder for it to close with.
    #[must_use]
    pub fn clean(&self) -> bool {
        !self.faults.any() && !self.open
    }

    /// Carries `frame` sent at `t_ns` and hands the bytes that survive, in pieces cut
    /// after each 0x00, to `decode`, which returns the outcome of the frame a piece
    /// closed (`None`: none closed). Returns the frame's fate.
    pub fn carry(
        &mut self,
        t_ns: u64,
        frame: &[u8],
        mut decode: impl FnMut(&[u8]) -> Option<Result<(), FrameError>>,
    ) -> Fate {
        self.counts.frames.sent += 1;
        let bytes: &[u8] = if self.faults.any() {
            self.corrupt(t_ns, frame);
            if self.buf.as_slice() != frame {
                self.counts.touched += 1;
            }
            &self.buf
        } else {
            frame
        };
        // This frame: no byte in the decoder yet (`Dropped`), waiting (`InFlight`), or
        // given its fate (a later piece of it, after a 0x00 a fault made, belongs to no
        // open frame: the next close attributes the frames then pending).
        let mut fate = Fate::Dropped;
        let c = &mut self.counts;
        for piece in bytes.split_inclusive(|&b| b == 0) {
            let closes = piece.last() == Some(&0);
            let content = piece.len() > usize::from(closes);
            if content && fate == Fate::Dropped {
                c.frames.in_flight += 1;
                fate = Fate::InFlight;
            }
            let r = decode(piece);
            if !closes {
                self.open |= content;
                continue;
            }
            let nonempty = self.open || content;
            self.open = false;
            if !nonempty {
                continue;
            }
            // Every frame with bytes in the decoder takes the outcome of the one closed.
            let n = std::mem::take(&mut c.frames.in_flight);
            match r {
                Some(Ok(())) => {
                    c.ok_events += 1;
                    c.frames.received += n;
                }
                Some(Err(e)) => {
                    c.rejects[e.index()] += 1;
                    c.frames.rejected += n;
                }
                None => c.frames.rejected += n,
            }
            if fate == Fate::InFlight {
                fate = if matches!(r, Some(Ok(()))) && n == 1 {
                    Fate::Valid
                } else {
                    Fate::Rejected
                };
            }
        }
        if fate == Fate::Dropped {
            c.frames.dropped += 1;
        }
        fate
    }

    /// The faulted copy of `frame` sent at `t_ns` into `self.buf`.
    fn corrupt(&mut self, t_ns: u64, frame: &[u8]) {
        self.buf.clear();
        let f = self.faults;
        if f.drop > 0.0 && self.rng.random::<f64>() < f.drop {
            return;
        }
        for (k, &b0) in frame.iter().enumerate() {
            let on_wire = t_ns + (k as u64 + 1) * self.byte_ns;
            if f.outage.is_some_and(|(s, e)| on_wire >= s && on_wire < e) {
                continue;
            }
            let mut b = b0;
            if f.ber > 0.0 {
                let mut bit = 0u64;
                while bit.saturating_add(self.bits_to_error) < 8 {
                    bit += self.bits_to_error;
                    b ^= 1 << bit;
                    bit += 1;
                    self.bits_to_error = geometric(&mut self.rng, f.ber);
                }
                self.bits_to_error -= 8 - bit;
            }
            if let Some((rate, len)) = f.burst {
                while on_wire >= self.next_burst_ns {
                    self.burst_left = len;
                    self.next_burst_ns = self
                        .next_burst_ns
                        .saturating_add(exponential_ns(&mut self.rng, rate).max(1));
                }
                if self.burst_left > 0 {
                    self.burst_left -= 1;
                    b ^= self.rng.random_range(1..=255u8);
                }
            }
            self.buf.push(b);
        }
    }
}

/// Bits to the next error: geometric with parameter `p` (never: `u64::MAX`).
fn geometric(rng: &mut Pcg64, p: f64) -> u64 {
    match Geometric::new(p) {
        Ok(d) if p > 0.0 => d.sample(rng),
        _ => u64::MAX,
    }
}

/// Time to the next event of a Poisson process of `rate_hz`, ns.
fn exponential_ns(rng: &mut Pcg64, rate_hz: f64) -> u64 {
    match Exp::new(rate_hz) {
        Ok(d) if rate_hz > 0.0 => {
            let t: f64 = d.sample(rng) * 1e9;
            if t.is_finite() && t < 1.8e19 {
                t as u64
            } else {
                u64::MAX
            }
        }
        _ => u64::MAX,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use wheelset_proto::{encode_vec, Command, Decoder, Message};

    fn decode(dec: &mut Decoder, piece: &[u8]) -> Option<Result<(), FrameError>> {
        dec.next_message(piece).0.map(|r| r.map(|_| ()))
    }

    #[test]
    fn every_frame_is_accounted_for_through_every_fault() {
        let frame = encode_vec(&Message::Command(Command::RequestStatus)).unwrap_or_default();
        let mut dec: Decoder = Decoder::new();
        let mut line = Line::new(Pcg64::seed_from_u64(3), 5_000_000);
        let episodes = [
            LineFaults::default(),
            LineFaults {
                ber: 1e-2,
                ..LineFaults::default()
            },
            LineFaults {
                drop: 0.3,
                ..LineFaults::default()
            },
            LineFaults {
                burst: Some((2_000.0, 3)),
                ..LineFaults::default()
            },
            LineFaults {
                outage: Some((0, u64::MAX)),
                ..LineFaults::default()
            },
        ];
        let mut t = 0;
        for f in episodes {
            line.set_faults(f, t);
            for _ in 0..2_000 {
                line.carry(t, &frame, |p| decode(&mut dec, p));
                assert!(line.counts.frames.adds_up(), "{:?}", line.counts);
                t += 200_000;
            }
        }
        let c = line.counts;
        assert_eq!(c.frames.sent, 10_000);
        assert!(
            c.frames.received >= 2_000 && c.frames.rejected > 0 && c.frames.dropped >= 2_000,
            "{c:?}"
        );
        assert_eq!(
            c.ok_events, c.frames.received,
            "one frame per valid close: {c:?}"
        );
    }
}
