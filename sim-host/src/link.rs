//! The simulated serial link: two byte streams (host -> device "up", device -> host
//! "down"), each a UART timed by its baud rate (10 bits per byte: start, 8 data, stop)
//! plus a fixed latency, in integer-nanosecond simulated time, with seeded fault
//! injection. Deterministic for a seed.
//!
//! Byte `k` (from 0) of a frame handed to [`Channel::send`] at `t` leaves the line at
//! `start + ceil((k+1) * 10 * 1e9 / baud)` ns, `start = max(t, line free)`, and reaches the
//! receiver `latency` ns later.
//!
//! Faults ([`Faults`], parsed from `--faults SPEC`), applied per direction in this order:
//! whole-frame drop, outage (bytes on the wire during an outage are lost), byte drop,
//! bit errors (each data bit flips with probability `ber`, drawn by geometric skips),
//! bursts (a Poisson process of `rate` bursts per second, each XOR-ing `len` consecutive
//! bytes with random non-zero values).
//!
//! Frame accounting ([`RxPort`], [`Accounting`]): every byte carries the id of the frame it
//! belongs to, and the receiving port attributes each sent frame to exactly one fate:
//! received (decoded valid), rejected (part of a frame the decoder rejected: CRC, COBS,
//! length ...), dropped by the link (none of its bytes reached the decoder), or in flight
//! at the end of the run.

use std::fmt;
use std::str::FromStr;

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use wheelset_proto::{Decoder, FrameError, Message};

/// Bits on the line per byte (8N1).
pub const BITS_PER_BYTE: u64 = wheelset_proto::link::BITS_PER_BYTE;
/// Nanoseconds per second.
pub const NS_PER_S: u64 = 1_000_000_000;

/// A link outage: every byte on the wire in `[start_ns, start_ns + len_ns)` is lost.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Outage {
    /// Start, ns of simulated time.
    pub start_ns: u64,
    /// Length, ns.
    pub len_ns: u64,
    /// Directions cut (within those the `dir` key allows).
    pub dir: FaultDir,
}

/// Error bursts: a Poisson process of `rate_hz` bursts per second; each burst garbles
/// `len_bytes` consecutive bytes.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Burst {
    /// Mean bursts per second.
    pub rate_hz: f64,
    /// Bytes garbled per burst.
    pub len_bytes: u32,
}

/// Which directions the faults apply to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum FaultDir {
    /// Host -> device and device -> host (the default).
    #[default]
    Both,
    /// Host -> device only.
    Up,
    /// Device -> host only.
    Down,
}

/// The fault injection of one link, `--faults SPEC`:
/// a comma-separated list of `key=value`:
///
/// | key | value | meaning |
/// |---|---|---|
/// | `ber` | `P` in [0, 1) | bit error rate per data bit |
/// | `drop` | `P` in [0, 1] | probability a whole frame is lost |
/// | `byte_drop` | `P` in [0, 1] | probability a byte is lost |
/// | `outage` | `START_S:LEN_S[:up\|down]` | outage from `START_S` seconds for `LEN_S` seconds (each at most [`MAX_OUTAGE_S`]), both directions or one (repeatable) |
/// | `burst` | `RATE_HZ:LEN_BYTES` | error bursts, mean rate per second (at most [`MAX_BURST_RATE_HZ`]), bytes per burst (a whole number up to 1e6) |
/// | `dir` | `both`, `up`, `down` | directions the faults apply to (default both) |
///
/// ```
/// use sim_host::link::Faults;
/// let f: Faults = "ber=1e-3,drop=0.1,outage=8.0:0.05".parse().unwrap();
/// assert_eq!(f.outages[0].len_ns, 50_000_000);
/// assert!("ber=2".parse::<Faults>().is_err());
/// ```
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Faults {
    /// Bit error rate per data bit.
    pub ber: f64,
    /// Whole-frame drop probability.
    pub frame_drop: f64,
    /// Byte drop probability.
    pub byte_drop: f64,
    /// Outages.
    pub outages: Vec<Outage>,
    /// Error bursts.
    pub burst: Option<Burst>,
    /// Directions affected.
    pub dir: FaultDir,
}

/// A `--faults` string that does not parse: names the item and the reason.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct FaultSpecError {
    /// The offending `key=value` item.
    pub item: String,
    /// Why it was refused.
    pub reason: String,
}

impl fmt::Display for FaultSpecError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "--faults: `{}`: {}", self.item, self.reason)
    }
}

impl std::error::Error for FaultSpecError {}

fn prob(item: &str, v: &str, upper_open: bool) -> Result<f64, FaultSpecError> {
    let err = |reason: String| FaultSpecError {
        item: item.to_owned(),
        reason,
    };
    let p: f64 = v
        .parse()
        .map_err(|_| err(format!("`{v}` is not a number")))?;
    let ok = p >= 0.0 && if upper_open { p < 1.0 } else { p <= 1.0 };
    if !ok {
        let range = if upper_open { "[0, 1)" } else { "[0, 1]" };
        return Err(err(format!("{p} is outside {range}")));
    }
    Ok(p)
}

fn pair(item: &str, v: &str, what: &str) -> Result<(f64, f64), FaultSpecError> {
    let err = |reason: String| FaultSpecError {
        item: item.to_owned(),
        reason,
    };
    let (a, b) = v
        .split_once(':')
        .ok_or_else(|| err(format!("expected {what}")))?;
    let a: f64 = a
        .parse()
        .map_err(|_| err(format!("`{a}` is not a number ({what})")))?;
    let b: f64 = b
        .parse()
        .map_err(|_| err(format!("`{b}` is not a number ({what})")))?;
    if !(a.is_finite() && b.is_finite() && a >= 0.0 && b > 0.0) {
        return Err(err(format!(
            "{what}: need finite values, first >= 0, second > 0"
        )));
    }
    Ok((a, b))
}

/// Largest outage start and length, s (the longest scenario is 1e5 s).
pub const MAX_OUTAGE_S: f64 = 1e5;
/// Largest burst rate, bursts per second.
pub const MAX_BURST_RATE_HZ: f64 = 1e5;

fn secs_to_ns(s: f64) -> u64 {
    (s * 1e9).round() as u64
}

impl FromStr for Faults {
    type Err = FaultSpecError;

    fn from_str(spec: &str) -> Result<Self, Self::Err> {
        let mut f = Faults::default();
        for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let err = |reason: &str| FaultSpecError {
                item: item.to_owned(),
                reason: reason.to_owned(),
            };
            let (k, v) = item
                .split_once('=')
                .ok_or_else(|| err("expected key=value"))?;
            match k.trim() {
                "ber" => f.ber = prob(item, v.trim(), true)?,
                "drop" => f.frame_drop = prob(item, v.trim(), false)?,
                "byte_drop" => f.byte_drop = prob(item, v.trim(), false)?,
                "outage" => {
                    let v = v.trim();
                    let (v, dir) = match v.rsplit_once(':') {
                        Some((head, "up")) => (head, FaultDir::Up),
                        Some((head, "down")) => (head, FaultDir::Down),
                        _ => (v, FaultDir::Both),
                    };
                    let (s, l) = pair(item, v, "START_S:LEN_S[:up|down]")?;
                    if s > MAX_OUTAGE_S || l > MAX_OUTAGE_S {
                        return Err(err(&format!(
                            "START_S and LEN_S must be at most {MAX_OUTAGE_S} s (the longest scenario)"
                        )));
                    }
                    f.outages.push(Outage {
                        start_ns: secs_to_ns(s),
                        len_ns: secs_to_ns(l),
                        dir,
                    });
                }
                "burst" => {
                    let (r, n) = pair(item, v.trim(), "RATE_HZ:LEN_BYTES")?;
                    if r > MAX_BURST_RATE_HZ {
                        return Err(err(&format!(
                            "RATE_HZ {r} is above the maximum {MAX_BURST_RATE_HZ} bursts per second \
                             (a 1 Mbaud line carries 1e5 bytes per second: more bursts than bytes)"
                        )));
                    }
                    if n.fract() != 0.0 || n > 1e6 {
                        return Err(err("LEN_BYTES must be a whole number <= 1e6"));
                    }
                    f.burst = Some(Burst {
                        rate_hz: r,
                        len_bytes: n as u32,
                    });
                }
                "dir" => {
                    f.dir = match v.trim() {
                        "both" => FaultDir::Both,
                        "up" => FaultDir::Up,
                        "down" => FaultDir::Down,
                        _ => return Err(err("expected both, up or down")),
                    }
                }
                _ => {
                    return Err(err(
                        "unknown key (known: ber, drop, byte_drop, outage, burst, dir)",
                    ))
                }
            }
        }
        Ok(f)
    }
}

/// The canonical spec of the faults, `key=value` items in a fixed order, only those
/// that act (empty for none); it parses back to the same [`Faults`] (outages to the ns).
///
/// ```
/// use sim_host::link::Faults;
/// let f: Faults = " drop=0.05 ,ber=1e-3,outage=8:0.05:up".parse().unwrap();
/// assert_eq!(f.to_string(), "ber=0.001,drop=0.05,outage=8:0.05:up");
/// assert_eq!(f.to_string().parse::<Faults>().unwrap(), f);
/// assert_eq!(Faults::none().to_string(), "");
/// ```
impl fmt::Display for Faults {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let mut items: Vec<String> = Vec::new();
        if self.ber > 0.0 {
            items.push(format!("ber={}", self.ber));
        }
        if self.frame_drop > 0.0 {
            items.push(format!("drop={}", self.frame_drop));
        }
        if self.byte_drop > 0.0 {
            items.push(format!("byte_drop={}", self.byte_drop));
        }
        for o in &self.outages {
            let dir = match o.dir {
                FaultDir::Both => "",
                FaultDir::Up => ":up",
                FaultDir::Down => ":down",
            };
            items.push(format!(
                "outage={}:{}{dir}",
                o.start_ns as f64 / 1e9,
                o.len_ns as f64 / 1e9
            ));
        }
        if let Some(b) = self.burst {
            items.push(format!("burst={}:{}", b.rate_hz, b.len_bytes));
        }
        match self.dir {
            FaultDir::Both => {}
            FaultDir::Up => items.push("dir=up".into()),
            FaultDir::Down => items.push("dir=down".into()),
        }
        f.write_str(&items.join(","))
    }
}

impl Faults {
    /// No faults.
    #[must_use]
    pub fn none() -> Self {
        Self::default()
    }

    fn applies(&self, up: bool) -> bool {
        self.dir.includes(up)
    }
}

impl FaultDir {
    /// Whether this covers the host -> device (`up`) or device -> host direction.
    #[must_use]
    pub fn includes(self, up: bool) -> bool {
        match self {
            FaultDir::Both => true,
            FaultDir::Up => up,
            FaultDir::Down => !up,
        }
    }
}

/// Timing and faults of a link.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkConfig {
    /// Baud rate (bits per second, 10 bits per byte).
    pub baud: u32,
    /// One-way latency added to every byte, ns.
    pub latency_ns: u64,
    /// Fault injection.
    pub faults: Faults,
    /// RNG seed (each direction derives its own stream).
    pub seed: u64,
}

/// Default baud: 5 Mbaud. The STM32F446's USART1/6 on the 90 MHz APB2 reach it exactly
/// (OVER8 = 1, USARTDIV = 90 MHz / (8 x 5 Mbaud) = 2.25); it carries the default 5 kHz
/// round trip of the worst-case frames (43 + 30 bytes, 146 us + 2 x 2 us of latency) within
/// the 85 % share (170 us; see [`check_budget`]). 4 Mbaud (183 us) no longer does since
/// wire version 2 (the reference speed and 16-bit flags).
pub const DEFAULT_BAUD: u32 = 5_000_000;
/// Default one-way latency: 2 us (UART FIFO + DMA hand-off).
pub const DEFAULT_LATENCY_NS: u64 = 2_000;
/// Share of the period the round trip may use; the rest is margin for the device's
/// execution time and jitter ([`wheelset_proto::link::LINK_SHARE_MAX_PERMILLE`]).
pub const BUDGET_SHARE: f64 = wheelset_proto::link::LINK_SHARE_MAX_PERMILLE as f64 / 1000.0;

impl Default for LinkConfig {
    fn default() -> Self {
        Self {
            baud: DEFAULT_BAUD,
            latency_ns: DEFAULT_LATENCY_NS,
            faults: Faults::none(),
            seed: 1,
        }
    }
}

/// A link that cannot carry the configured exchange.
#[derive(Debug, Clone, PartialEq)]
pub struct LinkBudgetError {
    /// Bytes per period, host -> device.
    pub up_bytes: usize,
    /// Bytes per period, device -> host.
    pub down_bytes: usize,
    /// Baud.
    pub baud: u32,
    /// Latency, ns.
    pub latency_ns: u64,
    /// Period, ns.
    pub period_ns: u64,
    /// Round-trip time needed, ns.
    pub needed_ns: u64,
    /// Round-trip time allowed (`BUDGET_SHARE` of the period), ns.
    pub allowed_ns: u64,
}

impl fmt::Display for LinkBudgetError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let rate = NS_PER_S as f64 / self.period_ns as f64;
        write!(
            f,
            "link budget exceeded: ({} + {}) bytes x {} bits / {} baud + 2 x {} ns latency = {:.1} us \
             per {:.0} Hz period, but only {:.0} % of the {:.1} us period = {:.1} us is allowed; \
             raise the baud to at least {:.0} or lower the rate",
            self.up_bytes,
            self.down_bytes,
            BITS_PER_BYTE,
            self.baud,
            self.latency_ns,
            self.needed_ns as f64 / 1e3,
            rate,
            BUDGET_SHARE * 100.0,
            self.period_ns as f64 / 1e3,
            self.allowed_ns as f64 / 1e3,
            wheelset_proto::link::min_baud(
                u32::try_from(NS_PER_S / self.period_ns.max(1)).unwrap_or(u32::MAX),
                u32::try_from(self.up_bytes).unwrap_or(u32::MAX),
                u32::try_from(self.down_bytes).unwrap_or(u32::MAX),
                self.latency_ns,
                wheelset_proto::link::LINK_SHARE_MAX_PERMILLE,
            )
            .map_or(f64::INFINITY, f64::from),
        )
    }
}

impl std::error::Error for LinkBudgetError {}

/// Time on the line for `n` bytes at `baud`, ns (rounded up):
/// [`wheelset_proto::link::wire_ns`].
#[must_use]
pub fn wire_ns(n: usize, baud: u32) -> u64 {
    wheelset_proto::link::wire_ns(n as u64, baud)
}

/// The link budget of a lock-step exchange: the sensor frame goes up, the device ticks,
/// the actuation frame comes down, all within one period:
/// `(up + down) bytes x 10 / baud + 2 latency <= BUDGET_SHARE x period`, evaluated by
/// the one link budget, [`wheelset_proto::link::link_fits`] (at the rate
/// `1e9 / period_ns`). Returns the round-trip time, or an error naming the numbers.
pub fn check_budget(
    up_bytes: usize,
    down_bytes: usize,
    baud: u32,
    latency_ns: u64,
    period_ns: u64,
) -> Result<u64, LinkBudgetError> {
    use wheelset_proto::link::{allowed_ns, link_fits, round_trip_ns, LINK_SHARE_MAX_PERMILLE};
    let rate_hz = u32::try_from(NS_PER_S / period_ns.max(1)).unwrap_or(u32::MAX);
    let (up, down) = (
        u32::try_from(up_bytes).unwrap_or(u32::MAX),
        u32::try_from(down_bytes).unwrap_or(u32::MAX),
    );
    link_fits(rate_hz, baud, up, down, latency_ns, LINK_SHARE_MAX_PERMILLE).map_err(|_| {
        LinkBudgetError {
            up_bytes,
            down_bytes,
            baud,
            latency_ns,
            period_ns,
            needed_ns: round_trip_ns(baud, up, down, latency_ns),
            allowed_ns: allowed_ns(rate_hz, LINK_SHARE_MAX_PERMILLE),
        }
    })
}

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

/// The surviving bytes of one frame on their way, with their arrival times: listed in
/// `at_ns` when faults may drop bytes; otherwise (`at_ns` empty) byte `k` arrives at
/// `first_ns + byte_ns[k + 1]` (the channel's table), with nothing stored per byte.
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

/// The segments in flight, a ring over reused storage: sending and delivering a frame
/// moves no `Segment` and allocates nothing once the ring has grown to the frames in
/// flight (1-2 on a clean link).
#[derive(Debug, Clone, Default)]
struct Ring {
    segs: Vec<Segment>,
    head: usize,
    len: usize,
}

impl Ring {
    /// The free slot behind the last queued segment (queued by [`Self::commit`]).
    fn tail_slot(&mut self) -> &mut Segment {
        if self.len == self.segs.len() {
            self.segs.rotate_left(self.head);
            self.head = 0;
            self.segs.push(Segment::default());
        }
        // (No `%`: a division per frame shows in the loop.)
        let mut i = self.head + self.len;
        if i >= self.segs.len() {
            i -= self.segs.len();
        }
        &mut self.segs[i]
    }

    /// Queues the segment filled in [`Self::tail_slot`].
    fn commit(&mut self) {
        self.len += 1;
    }

    fn front_mut(&mut self) -> Option<&mut Segment> {
        if self.len == 0 {
            return None;
        }
        self.segs.get_mut(self.head)
    }

    fn pop_front(&mut self) {
        if self.len > 0 {
            self.head += 1;
            if self.head == self.segs.len() {
                self.head = 0;
            }
            self.len -= 1;
        }
    }

    fn iter(&self) -> impl Iterator<Item = &Segment> + '_ {
        (0..self.len).filter_map(|k| self.segs.get((self.head + k) % self.segs.len()))
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
        let active = f.applies(up)
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

    /// Hands a frame to the UART at `t_ns`; returns its id. Bytes are queued behind any
    /// frame still on the line.
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
        let n = if self.active {
            // (The slot's buffers are taken out while `corrupt` borrows the channel.)
            let seg = self.queue.tail_slot();
            let (mut kept, mut at_ns) = (
                std::mem::take(&mut seg.bytes),
                std::mem::take(&mut seg.at_ns),
            );
            kept.clear();
            at_ns.clear();
            for (k, &b) in bytes.iter().enumerate() {
                let on_wire = start + at(k + 1, baud, &self.byte_ns);
                if let Some(b) = self.corrupt(on_wire, b) {
                    kept.push(b);
                    at_ns.push(on_wire + latency_ns);
                }
            }
            let seg = self.queue.tail_slot();
            seg.bytes = kept;
            seg.at_ns = at_ns;
            seg.frame = id;
            seg.pos = 0;
            seg.bytes.len()
        } else {
            let table = self.byte_ns.len();
            let seg = self.queue.tail_slot();
            let first = start + latency_ns;
            seg.frame = id;
            seg.pos = 0;
            seg.first_ns = first;
            seg.bytes.clear();
            seg.bytes.extend_from_slice(bytes);
            seg.at_ns.clear();
            // Within the table: times implied (see `Segment`); beyond it, listed.
            if bytes.len() >= table {
                seg.at_ns
                    .extend((1..=bytes.len()).map(|k| first + wire_ns(k, baud)));
            }
            bytes.len()
        };
        self.counters.bytes_delivered += n as u64;
        if n > 0 {
            self.queue.commit();
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

    /// Delivers every byte that has arrived by `t_ns`, in order, as runs of consecutive
    /// bytes of one frame: `f(bytes, frame)`.
    pub fn deliver(&mut self, t_ns: u64, mut f: impl FnMut(&[u8], FrameId)) {
        while let Some(seg) = self.queue.front_mut() {
            let n = if seg.at_ns.is_empty() {
                // Byte k arrived iff first + byte_ns[k + 1] <= t.
                match t_ns.checked_sub(seg.first_ns) {
                    Some(dt) => self
                        .byte_ns
                        .get(seg.pos + 1..=seg.bytes.len())
                        .unwrap_or(&[])
                        .partition_point(|&ns| ns <= dt),
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
        self.queue.iter().map(|s| s.frame)
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

/// The fate of a sent frame, as seen by the receiving port.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Fate {
    Open,
    Received,
    Rejected,
}

/// The receiving end of a channel: a frame decoder that also attributes every sent frame
/// to its fate. (The device side runs its own decoder inside the runtime; this port then
/// decodes the same bytes as a shadow, which sees exactly the same frames.)
#[derive(Debug, Clone, Default)]
pub struct RxPort {
    decoder: Decoder,
    pending: Vec<FrameId>,
    fates: Vec<Fate>,
    reached: Vec<bool>,
    /// Valid frames.
    pub received: u64,
    /// Frames that took part in a rejected frame.
    pub rejected: u64,
    /// Decoder rejections by kind: CRC, COBS, version, length, postcard.
    pub errors: [u64; 5],
    /// Rejected frames by the kind of the reject they took part in (sums to
    /// `rejected`; a burst that destroys a delimiter merges two frames into one reject).
    pub rejected_by: [u64; 5],
}

impl RxPort {
    /// An idle port.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Takes a run of delivered bytes of frame `id` and decodes it with the port's own
    /// decoder, calling `on_msg` for every valid message.
    pub fn push(&mut self, run: &[u8], id: FrameId, mut on_msg: impl FnMut(Message)) {
        let (dec, mut book) = self.split();
        book.attribute(run, id, |piece| {
            let mut out = None;
            dec.feed(piece, |r| out = Some(r.map(&mut on_msg)));
            out
        });
    }

    /// Takes a run of delivered bytes of frame `id` that another decoder (the device's
    /// runtime) decodes: `decode(piece)` gets the run split after each 0x00 and returns
    /// the outcome of the frame the piece closed (None: no frame closed, e.g. an empty
    /// one). The port attributes the outcome to every frame with bytes in it.
    pub fn push_with(
        &mut self,
        run: &[u8],
        id: FrameId,
        decode: impl FnMut(&[u8]) -> Option<Result<(), FrameError>>,
    ) {
        self.split().1.attribute(run, id, decode);
    }

    /// The decoder and the bookkeeping, borrowed apart.
    fn split(&mut self) -> (&mut Decoder, Book<'_>) {
        let RxPort {
            decoder,
            pending,
            fates,
            reached,
            received,
            rejected,
            errors,
            rejected_by,
        } = self;
        (
            decoder,
            Book {
                pending,
                fates,
                reached,
                received,
                rejected,
                errors,
                rejected_by,
            },
        )
    }

    /// The final accounting of `channel`'s frames at the end of a run.
    #[must_use]
    pub fn account(&self, channel: &Channel) -> Accounting {
        let sent = channel.counters().frames_sent;
        let mut in_flight: Vec<FrameId> = channel.queued_frames().collect();
        in_flight.extend(self.pending.iter().copied());
        in_flight.sort_unstable();
        in_flight.dedup();
        let open = |id: FrameId| self.fates.get(id as usize).is_none_or(|f| *f == Fate::Open);
        in_flight.retain(|&id| open(id));
        // Dropped by the link: no byte of the frame reached the decoder (lost whole, in an
        // outage, byte by byte, or only its delimiter survived), and none is on its way.
        let dropped = (0..sent as FrameId)
            .filter(|&id| {
                !self.reached.get(id as usize).copied().unwrap_or(false)
                    && in_flight.binary_search(&id).is_err()
            })
            .count() as u64;
        Accounting {
            sent,
            received: self.received,
            rejected: self.rejected,
            dropped,
            in_flight: in_flight.len() as u64,
            link_dropped_whole: channel.counters().frames_dropped,
            errors: self.errors,
            rejected_by: self.rejected_by,
        }
    }
}

fn error_index(e: FrameError) -> usize {
    match e {
        FrameError::Crc => 0,
        FrameError::Cobs => 1,
        FrameError::Version => 2,
        FrameError::Length => 3,
        FrameError::Postcard => 4,
    }
}

/// The attribution state of an [`RxPort`], borrowed apart from its decoder.
struct Book<'a> {
    pending: &'a mut Vec<FrameId>,
    fates: &'a mut Vec<Fate>,
    reached: &'a mut Vec<bool>,
    received: &'a mut u64,
    rejected: &'a mut u64,
    errors: &'a mut [u64; 5],
    rejected_by: &'a mut [u64; 5],
}

impl Book<'_> {
    /// See [`RxPort::push_with`].
    fn attribute(
        &mut self,
        run: &[u8],
        id: FrameId,
        mut decode: impl FnMut(&[u8]) -> Option<Result<(), FrameError>>,
    ) {
        let i = id as usize;
        if self.fates.len() <= i {
            // Grown in chunks (ids come in order); entries past the last id sent stay
            // Open / not reached, which is what `account` assumes for missing ones.
            let len = (i + 1).max(2 * self.fates.len()).max(1024);
            self.fates.resize(len, Fate::Open);
            self.reached.resize(len, false);
        }
        match run.split_last() {
            // Typical: one whole frame, its delimiter last (one word-wise scan).
            Some((&0, head)) if !head.contains(&0) => self.piece(run, id, &mut decode),
            _ => {
                for piece in run.split_inclusive(|&b| b == 0) {
                    self.piece(piece, id, &mut decode);
                }
            }
        }
    }

    /// One piece of a run: bytes up to and including a 0x00, or the run's tail.
    #[inline(always)]
    fn piece(
        &mut self,
        piece: &[u8],
        id: FrameId,
        decode: &mut impl FnMut(&[u8]) -> Option<Result<(), FrameError>>,
    ) {
        let closes = piece.last() == Some(&0);
        if piece.len() > usize::from(closes) {
            if let Some(r) = self.reached.get_mut(id as usize) {
                *r = true;
            }
            if self.pending.last() != Some(&id) {
                self.pending.push(id);
            }
        }
        let r = decode(piece);
        if !closes {
            return;
        }
        let mut cause = None;
        let (to, count) = match r {
            Some(Ok(())) => (Fate::Received, &mut *self.received),
            Some(Err(e)) => {
                self.errors[error_index(e)] += 1;
                cause = Some(error_index(e));
                (Fate::Rejected, &mut *self.rejected)
            }
            None => {
                self.pending.clear();
                return;
            }
        };
        // (Every pending id is below `fates.len()`: resized when its bytes came.)
        for &p in self.pending.iter() {
            if let Some(f) = self.fates.get_mut(p as usize) {
                if *f == Fate::Open {
                    *f = to;
                    *count += 1;
                    if let Some(c) = cause {
                        self.rejected_by[c] += 1;
                    }
                }
            }
        }
        self.pending.clear();
    }
}

/// Every frame of one direction, accounted for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Accounting {
    /// Frames sent.
    pub sent: u64,
    /// Frames received valid.
    pub received: u64,
    /// Frames rejected by the receiver (they were part of a CRC/COBS/length/... reject).
    pub rejected: u64,
    /// Frames of which no byte reached the receiver's decoder.
    pub dropped: u64,
    /// Frames still on the way at the end.
    pub in_flight: u64,
    /// Of `dropped`: frames the link dropped whole (`drop=`).
    pub link_dropped_whole: u64,
    /// Decoder rejections (events) by kind: CRC, COBS, version, length, postcard.
    pub errors: [u64; 5],
    /// Rejected frames by the kind of their reject, same order; sums to `rejected`
    /// (one reject event can take several frames when a delimiter was destroyed).
    pub rejected_by: [u64; 5],
}

impl Accounting {
    /// `sent == received + rejected + dropped + in_flight`, and the rejected frames by
    /// cause sum to `rejected`.
    #[must_use]
    pub fn adds_up(&self) -> bool {
        self.sent == self.received + self.rejected + self.dropped + self.in_flight
            && self.rejected_by.iter().sum::<u64>() == self.rejected
    }
}

impl fmt::Display for Accounting {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let [crc, cobs, ver, len, pc] = self.rejected_by;
        let events: u64 = self.errors.iter().sum();
        write!(
            f,
            "sent {} = received {} + rejected {} + dropped {} + in flight {} [{}] \
             (rejected frames: crc {crc} + cobs {cobs} + version {ver} + length {len} + postcard {pc}, \
             in {events} decoder rejects; dropped whole by the link {})",
            self.sent,
            self.received,
            self.rejected,
            self.dropped,
            self.in_flight,
            if self.adds_up() {
                "adds up"
            } else {
                "DOES NOT ADD UP"
            },
            self.link_dropped_whole
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wheelset_proto::{encode_vec, Command, Sensor};

    fn frame(seq: u16) -> Vec<u8> {
        encode_vec(&Message::Sensor(Sensor {
            seq,
            t_us: seq.wrapping_mul(200),
            lateral: wheelset_proto::Lateral::Velocity(i32::from(seq) * 7 - 3000),
            i_a_ma: 115_000,
            omega_m_mrad_s: 925_600,
            demand_nm: 2460,
            v_ref_mm_s: 0,
        }))
        .expect("fits")
        .to_vec()
    }

    #[test]
    fn fault_spec_parses_and_refuses() {
        let f: Faults =
            "ber=1e-3, drop=0.1,outage=8.0:0.05,outage=9:1:down,burst=2:5,byte_drop=0.01,dir=up"
                .parse()
                .expect("valid");
        assert_eq!(f.ber, 1e-3);
        assert_eq!(f.frame_drop, 0.1);
        assert_eq!(f.byte_drop, 0.01);
        assert_eq!(
            f.outages,
            vec![
                Outage {
                    start_ns: 8_000_000_000,
                    len_ns: 50_000_000,
                    dir: FaultDir::Both,
                },
                Outage {
                    start_ns: 9_000_000_000,
                    len_ns: 1_000_000_000,
                    dir: FaultDir::Down,
                }
            ]
        );
        assert_eq!(
            f.burst,
            Some(Burst {
                rate_hz: 2.0,
                len_bytes: 5
            })
        );
        assert_eq!(f.dir, FaultDir::Up);
        assert!("outage=1:2:sideways".parse::<Faults>().is_err());
        assert_eq!("".parse::<Faults>(), Ok(Faults::none()));
        for (bad, needle) in [
            ("ber=1", "outside [0, 1)"),
            ("ber=x", "not a number"),
            ("drop=-0.1", "outside [0, 1]"),
            ("outage=8", "START_S:LEN_S"),
            ("outage=8:0", "second > 0"),
            ("burst=1:2.5", "whole number"),
            ("nope=1", "unknown key"),
            ("ber", "key=value"),
            ("dir=left", "both, up or down"),
        ] {
            let e = bad.parse::<Faults>().expect_err(bad);
            assert!(e.to_string().contains(needle), "{bad}: {e}");
            assert!(e.to_string().contains(bad), "{bad}: {e}");
        }
    }

    #[test]
    fn bytes_arrive_at_baud_plus_latency_in_order() {
        let cfg = LinkConfig {
            baud: 1_000_000,
            latency_ns: 3_000,
            ..LinkConfig::default()
        };
        let mut link = Link::new(&cfg);
        let a = frame(1);
        let b = frame(2);
        link.up.send(1_000, &a);
        link.up.send(1_000, &b); // queued behind `a`
        let n = a.len() + b.len();
        // 10 us per byte at 1 Mbaud: the last byte arrives after n * 10 us + latency.
        let last = 1_000 + n as u64 * 10_000 + 3_000;
        let mut got = Vec::new();
        link.up
            .deliver(last - 1, |run, id| got.extend(run.iter().map(|&b| (b, id))));
        assert_eq!(got.len(), n - 1);
        link.up
            .deliver(last, |run, id| got.extend(run.iter().map(|&b| (b, id))));
        let bytes: Vec<u8> = got.iter().map(|g| g.0).collect();
        assert_eq!(bytes, [a.clone(), b.clone()].concat());
        assert_eq!(got[a.len() - 1].1, 0);
        assert_eq!(got[a.len()].1, 1);
        assert_eq!(link.up.line_free_ns(), last - 3_000);
        assert_eq!(link.down.counters().frames_sent, 0);
    }

    #[test]
    fn frames_in_flight_wrap_the_ring_in_order() {
        // 100 kbaud: 100 us per byte, so frames pile up behind each other; deliveries in
        // between take the front off while sends add at the back (the ring wraps and grows).
        let cfg = LinkConfig {
            baud: 100_000,
            latency_ns: 0,
            ..LinkConfig::default()
        };
        for faults in ["", "dir=up,ber=1e-12"] {
            let cfg = LinkConfig {
                faults: faults.parse().expect("valid"),
                ..cfg.clone()
            };
            let mut link = Link::new(&cfg);
            let mut sent: Vec<Vec<u8>> = Vec::new();
            let mut got: Vec<(u8, FrameId)> = Vec::new();
            let mut t = 0;
            for round in 0..6u16 {
                for k in 0..(1 + round % 4) {
                    let f = frame(round * 10 + k);
                    assert_eq!(link.up.send(t, &f) as usize, sent.len());
                    sent.push(f);
                }
                t += 3_000_000; // 30 bytes' time: less than the frames sent
                link.up
                    .deliver(t, |run, id| got.extend(run.iter().map(|&b| (b, id))));
                // What is still queued is exactly the frames not yet complete, in order.
                let done = sent
                    .iter()
                    .enumerate()
                    .filter(|(id, f)| got.iter().filter(|g| g.1 as usize == *id).count() == f.len())
                    .count();
                let queued: Vec<FrameId> = link.up.queued_frames().collect();
                let expect: Vec<FrameId> = (done as FrameId..sent.len() as FrameId).collect();
                assert_eq!(queued, expect, "{faults:?} round {round}");
            }
            link.up
                .deliver(u64::MAX, |run, id| got.extend(run.iter().map(|&b| (b, id))));
            assert_eq!(link.up.queued_frames().count(), 0);
            let bytes: Vec<u8> = got.iter().map(|g| g.0).collect();
            assert_eq!(bytes, sent.concat(), "{faults:?}");
            let ids: Vec<FrameId> = got.iter().map(|g| g.1).collect();
            let expect: Vec<FrameId> = sent
                .iter()
                .enumerate()
                .flat_map(|(id, f)| std::iter::repeat_n(id as FrameId, f.len()))
                .collect();
            assert_eq!(ids, expect, "{faults:?}");
        }
    }

    fn run(cfg: &LinkConfig, frames: u16) -> (Vec<u8>, Accounting, ChannelCounters) {
        let mut link = Link::new(cfg);
        let mut rx = RxPort::new();
        let mut out = Vec::new();
        let period = 200_000;
        for k in 0..frames {
            let t = u64::from(k) * period;
            link.up.send(t, &frame(k));
            link.up.deliver(t + period - 1, |run, id| {
                out.extend_from_slice(run);
                rx.push(run, id, |_| {});
            });
        }
        (out, rx.account(&link.up), *link.up.counters())
    }

    #[test]
    fn deterministic_for_a_seed() {
        let faults: Faults = "ber=1e-3,drop=0.1,byte_drop=0.01,burst=20:4"
            .parse()
            .expect("valid");
        let cfg = LinkConfig {
            faults,
            seed: 7,
            ..LinkConfig::default()
        };
        let (a, acc_a, _) = run(&cfg, 2000);
        let (b, acc_b, _) = run(&cfg, 2000);
        assert_eq!(a, b);
        assert_eq!(acc_a, acc_b);
        let (c, _, _) = run(&LinkConfig { seed: 8, ..cfg }, 2000);
        assert_ne!(a, c);
    }

    #[test]
    fn bit_error_rate_matches() {
        let cfg = LinkConfig {
            faults: "ber=1e-2".parse().expect("valid"),
            ..LinkConfig::default()
        };
        let (_, _, c) = run(&cfg, 5000);
        let bits = (c.bytes_delivered * 8) as f64;
        let expect = bits * 1e-2;
        // Binomial: 5 sigma.
        let sigma = (bits * 1e-2 * 0.99).sqrt();
        assert!(
            (c.bits_flipped as f64 - expect).abs() < 5.0 * sigma,
            "{} flips, expected {expect}",
            c.bits_flipped
        );
    }

    #[test]
    fn outage_loses_exactly_its_window() {
        let cfg = LinkConfig {
            faults: "outage=0.1:0.05".parse().expect("valid"),
            ..LinkConfig::default()
        };
        let (_, acc, c) = run(&cfg, 1000);
        // 0.05 s at 200 us per frame: 250 frames lost whole, the two at the edges damaged.
        assert!((249..=251).contains(&acc.dropped), "{acc}");
        assert!(acc.rejected <= 2, "{acc}");
        assert!(c.bytes_outage > 0);
        assert!(acc.adds_up(), "{acc}");
        assert_eq!(acc.received + acc.rejected + acc.dropped, 1000);
    }

    #[test]
    fn every_frame_accounted_under_every_fault() {
        let faults: Faults = "ber=1e-3,drop=0.1,byte_drop=0.005,burst=50:6,outage=0.2:0.05"
            .parse()
            .expect("valid");
        let cfg = LinkConfig {
            faults,
            seed: 3,
            ..LinkConfig::default()
        };
        let (_, acc, c) = run(&cfg, 5000);
        assert!(acc.adds_up(), "{acc}");
        assert!(acc.dropped >= acc.link_dropped_whole);
        assert_eq!(acc.link_dropped_whole, c.frames_dropped);
        // 10 % whole-frame drops, within 5 sigma.
        assert!(
            (c.frames_dropped as f64 - 500.0).abs() < 5.0 * (450.0f64).sqrt(),
            "{acc}"
        );
        assert!(acc.rejected > 0 && acc.received > 2500, "{acc}");
        // Without faults, every frame arrives valid.
        let (_, clean, _) = run(&LinkConfig::default(), 500);
        assert_eq!((clean.received, clean.rejected, clean.dropped), (500, 0, 0));
        let _ = Command::ResetCounters;
    }

    #[test]
    fn budget_fits_or_names_the_numbers() {
        // 5 kHz, the worst-case frames 43 + 30 bytes at 5 Mbaud, 2 us latency:
        // 730 bits / 5 Mbaud = 146 us, + 4 us, of the 170 us share of 200 us.
        let (up, down) = (
            wheelset_proto::SENSOR_MAX_FRAME,
            wheelset_proto::ACTUATION_MAX_FRAME,
        );
        let rt = check_budget(up, down, DEFAULT_BAUD, DEFAULT_LATENCY_NS, 200_000).expect("fits");
        assert_eq!(
            rt,
            ((up + down) as u64 * 10 * 1_000_000_000).div_ceil(5_000_000) + 4_000
        );
        assert!(check_budget(up, down, 4_000_000, DEFAULT_LATENCY_NS, 200_000).is_err());
        let e = check_budget(33, 28, 1_000_000, 2_000, 200_000).expect_err("too slow");
        let msg = e.to_string();
        for needle in [
            "33 + 28",
            "1000000 baud",
            "614.0 us",
            "5000 Hz",
            "170.0 us",
            "3674699",
        ] {
            assert!(msg.contains(needle), "missing {needle}: {msg}");
        }
        assert!(check_budget(33, 28, 0, 0, 200_000).is_err());
    }
}
