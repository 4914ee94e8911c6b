//! One direction of the line with seeded faults ([`Channel`]), and both ([`Link`]).

use std::collections::VecDeque;

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;

use super::{wire_ns, Faults, LinkConfig};

/// Identifies a frame within one direction (0, 1, 2 ... in send order).
pub type FrameId = u32;

/// Counters of one direction.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ChannelCounters {
    /// Frames handed to the link.
    pub frames_sent: u64,
    /// Frames the link dropped whole (`drop=`).
    pub frames_dropped: u64,
    /// Bytes handed to the link.
    pub bytes_sent: u64,
    /// Bytes delivered (possibly corrupted).
    pub bytes_delivered: u64,
    /// Bytes lost in outages.
    pub bytes_outage: u64,
    /// Bytes lost by `byte_drop`.
    pub bytes_dropped: u64,
    /// Bits flipped by `ber`.
    pub bits_flipped: u64,
    /// Bursts started.
    pub bursts: u64,
    /// Bytes garbled by bursts.
    pub burst_bytes: u64,
}

/// The surviving bytes of one frame on their way: arrival times in `at_ns`, or (empty)
/// byte `k` at `first_ns + byte_ns[k + 1]`.
#[derive(Debug, Clone, Default)]
struct Segment {
    frame: FrameId,
    bytes: Vec<u8>,
    at_ns: Vec<u64>,
    /// Send start + latency, ns (untimed segments).
    first_ns: u64,
    /// Bytes already delivered.
    pos: usize,
}

/// The segments in flight, and spent ones whose buffers are reused (no allocation once
/// grown).
#[derive(Debug, Clone, Default)]
struct Ring {
    segs: VecDeque<Segment>,
    spare: Vec<Segment>,
}

impl Ring {
    fn pop_front(&mut self) {
        self.spare.extend(self.segs.pop_front());
    }
}

/// One direction of the link.
#[derive(Debug, Clone)]
pub struct Channel {
    baud: u32,
    latency_ns: u64,
    faults: Faults,
    active: bool,
    up: bool,
    rng: Pcg64,
    line_free_ns: u64,
    /// `wire_ns(k, baud)` for k = 0 ..= 2 MAX_FRAME (no 128-bit division per byte).
    byte_ns: Vec<u64>,
    queue: Ring,
    bits_to_error: u64,
    next_burst_ns: u64,
    burst_left: u32,
    counters: ChannelCounters,
}

impl Channel {
    /// A channel; `up` selects the host -> device direction (for `dir=` and the RNG stream).
    #[must_use]
    pub fn new(cfg: &LinkConfig, up: bool) -> Self {
        let stream = if up { 0x5eed_0001 } else { 0x5eed_0002 };
        let mut rng = Pcg64::seed_from_u64(cfg.seed ^ (stream << 32));
        let f = &cfg.faults;
        let active = f.dir.includes(up)
            && (f.ber > 0.0
                || f.frame_drop > 0.0
                || f.byte_drop > 0.0
                || f.burst.is_some()
                || f.outages.iter().any(|o| o.dir.includes(up)));
        let bits_to_error = geometric(&mut rng, if active { cfg.faults.ber } else { 0.0 });
        let next_burst_ns = match (active, cfg.faults.burst) {
            (true, Some(b)) => exponential_ns(&mut rng, b.rate_hz),
            _ => u64::MAX,
        };
        Self {
            baud: cfg.baud.max(1),
            latency_ns: cfg.latency_ns,
            faults: cfg.faults.clone(),
            active,
            up,
            rng,
            line_free_ns: 0,
            byte_ns: (0..=2 * wheelset_proto::MAX_FRAME)
                .map(|k| wire_ns(k, cfg.baud.max(1)))
                .collect(),
            queue: Ring::default(),
            bits_to_error,
            next_burst_ns,
            burst_left: 0,
            counters: ChannelCounters::default(),
        }
    }

    /// Hands a frame to the UART at `t_ns`, behind any frame still on the line; its id.
    pub fn send(&mut self, t_ns: u64, bytes: &[u8]) -> FrameId {
        let id = self.counters.frames_sent as FrameId;
        self.counters.frames_sent += 1;
        self.counters.bytes_sent += bytes.len() as u64;
        let start = t_ns.max(self.line_free_ns);
        let at = |k: usize, baud: u32, table: &[u64]| match table.get(k) {
            Some(&ns) => ns,
            None => wire_ns(k, baud),
        };
        self.line_free_ns = start + at(bytes.len(), self.baud, &self.byte_ns);
        if self.active
            && self.faults.frame_drop > 0.0
            && self.rng.random::<f64>() < self.faults.frame_drop
        {
            self.counters.frames_dropped += 1;
            return id;
        }
        let (latency_ns, baud) = (self.latency_ns, self.baud);
        let mut seg = self.queue.spare.pop().unwrap_or_default();
        seg.frame = id;
        seg.pos = 0;
        seg.bytes.clear();
        seg.at_ns.clear();
        if self.active {
            for (k, &b) in bytes.iter().enumerate() {
                let on_wire = start + at(k + 1, baud, &self.byte_ns);
                if let Some(b) = self.corrupt(on_wire, b) {
                    seg.bytes.push(b);
                    seg.at_ns.push(on_wire + latency_ns);
                }
            }
        } else {
            let first = start + latency_ns;
            seg.first_ns = first;
            seg.bytes.extend_from_slice(bytes);
            // Within the table: times implied (see `Segment`); beyond it, listed.
            if bytes.len() >= self.byte_ns.len() {
                seg.at_ns
                    .extend((1..=bytes.len()).map(|k| first + wire_ns(k, baud)));
            }
        }
        self.counters.bytes_delivered += seg.bytes.len() as u64;
        if seg.bytes.is_empty() {
            self.queue.spare.push(seg);
        } else {
            self.queue.segs.push_back(seg);
        }
        id
    }

    fn corrupt(&mut self, t_ns: u64, mut b: u8) -> Option<u8> {
        if !self.active {
            return Some(b);
        }
        let f = &self.faults;
        let up = self.up;
        if f.outages
            .iter()
            .any(|o| o.dir.includes(up) && t_ns >= o.start_ns && t_ns - o.start_ns < o.len_ns)
        {
            self.counters.bytes_outage += 1;
            return None;
        }
        if f.byte_drop > 0.0 && self.rng.random::<f64>() < f.byte_drop {
            self.counters.bytes_dropped += 1;
            return None;
        }
        if f.ber > 0.0 {
            let mut bit = 0u64;
            while bit.saturating_add(self.bits_to_error) < 8 {
                bit += self.bits_to_error;
                b ^= 1 << bit;
                self.counters.bits_flipped += 1;
                bit += 1;
                self.bits_to_error = geometric(&mut self.rng, f.ber);
            }
            self.bits_to_error -= 8 - bit;
        }
        if let Some(burst) = f.burst {
            while t_ns >= self.next_burst_ns {
                self.counters.bursts += 1;
                self.burst_left = burst.len_bytes;
                self.next_burst_ns = self
                    .next_burst_ns
                    .saturating_add(exponential_ns(&mut self.rng, burst.rate_hz).max(1));
            }
            if self.burst_left > 0 {
                self.burst_left -= 1;
                self.counters.burst_bytes += 1;
                b ^= self.rng.random_range(1..=255u8);
            }
        }
        Some(b)
    }

    /// Delivers every byte arrived by `t_ns`, in order, as runs of one frame: `f(bytes, frame)`.
    pub fn deliver(&mut self, t_ns: u64, mut f: impl FnMut(&[u8], FrameId)) {
        while let Some(seg) = self.queue.segs.front_mut() {
            let n = if seg.at_ns.is_empty() {
                // Byte k arrived iff first + byte_ns[k + 1] <= t (the table rises).
                let due = self
                    .byte_ns
                    .get(seg.pos + 1..=seg.bytes.len())
                    .unwrap_or(&[]);
                match t_ns.checked_sub(seg.first_ns) {
                    Some(dt) if due.last().is_some_and(|&ns| ns <= dt) => due.len(),
                    Some(dt) => due.partition_point(|&ns| ns <= dt),
                    None => 0,
                }
            } else {
                let rest = seg.at_ns.get(seg.pos..).unwrap_or(&[]);
                rest.partition_point(|&a| a <= t_ns)
            };
            if n > 0 {
                f(
                    seg.bytes.get(seg.pos..seg.pos + n).unwrap_or(&[]),
                    seg.frame,
                );
                seg.pos += n;
            }
            if seg.pos < seg.bytes.len() {
                break;
            }
            self.queue.pop_front();
        }
    }

    /// Frames with bytes still travelling.
    pub fn queued_frames(&self) -> impl Iterator<Item = FrameId> + '_ {
        self.queue.segs.iter().map(|s| s.frame)
    }

    /// When the line is free again, ns.
    #[must_use]
    pub fn line_free_ns(&self) -> u64 {
        self.line_free_ns
    }

    /// The counters.
    #[must_use]
    pub fn counters(&self) -> &ChannelCounters {
        &self.counters
    }
}

/// Bits until the next error: `floor(ln(1-U) / ln(1-p))`, geometric with parameter `p`.
fn geometric(rng: &mut Pcg64, p: f64) -> u64 {
    if p <= 0.0 {
        return u64::MAX;
    }
    let u: f64 = rng.random();
    let k = ((-u).ln_1p() / (-p).ln_1p()).floor();
    if k.is_finite() && k < 1e18 {
        k as u64
    } else {
        u64::MAX
    }
}

/// Time to the next event of a Poisson process of `rate_hz`, ns.
fn exponential_ns(rng: &mut Pcg64, rate_hz: f64) -> u64 {
    if rate_hz <= 0.0 {
        return u64::MAX;
    }
    let u: f64 = rng.random();
    let t = -(-u).ln_1p() / rate_hz * 1e9;
    if t.is_finite() && t < 1.8e19 {
        t as u64
    } else {
        u64::MAX
    }
}

/// Both directions.
#[derive(Debug, Clone)]
pub struct Link {
    /// Host -> device.
    pub up: Channel,
    /// Device -> host.
    pub down: Channel,
}

impl Link {
    /// A link from its configuration.
    #[must_use]
    pub fn new(cfg: &LinkConfig) -> Self {
        Self {
            up: Channel::new(cfg, true),
            down: Channel::new(cfg, false),
        }
    }
}
