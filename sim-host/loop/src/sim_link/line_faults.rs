//! The fault specification: what `--faults SPEC` parses into ([`Faults`]) and prints back.

use std::fmt;
use std::str::FromStr;

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

/// Error bursts: Poisson, `rate_hz` per second, each garbling `len_bytes` bytes.
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

/// The fault injection of one link, `--faults SPEC`, comma-separated `key=value`:
///
/// | key | value | meaning |
/// |---|---|---|
/// | `ber` | `P` in [0, 1) | bit error rate per data bit |
/// | `drop` | `P` in [0, 1] | probability a whole frame is lost |
/// | `byte_drop` | `P` in [0, 1] | probability a byte is lost |
/// | `outage` | `START_S:LEN_S[:up\|down]` | outage from `START_S` seconds for `LEN_S` seconds (each at most [`MAX_OUTAGE_S`]), both directions or one (repeatable) |
/// | `burst` | `RATE_HZ:LEN_BYTES` | error bursts, mean rate per second (at most [`MAX_BURST_RATE_HZ`]), bytes per burst (a whole number up to 1e6) |
/// | `dir` | `both`, `up`, `down` | directions the faults apply to (default both) |
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

fn prob(v: &str, upper_open: bool) -> Result<f64, String> {
    let p: f64 = v.parse().map_err(|_| format!("`{v}` is not a number"))?;
    let ok = p >= 0.0 && if upper_open { p < 1.0 } else { p <= 1.0 };
    if !ok {
        let range = if upper_open { "[0, 1)" } else { "[0, 1]" };
        return Err(format!("{p} is outside {range}"));
    }
    Ok(p)
}

fn pair(v: &str, what: &str) -> Result<(f64, f64), String> {
    let (a, b) = v
        .split_once(':')
        .ok_or_else(|| format!("expected {what}"))?;
    let num = |x: &str| {
        x.parse::<f64>()
            .map_err(|_| format!("`{x}` is not a number ({what})"))
    };
    let (a, b) = (num(a)?, num(b)?);
    if !(a.is_finite() && b.is_finite() && a >= 0.0 && b > 0.0) {
        return Err(format!(
            "{what}: need finite values, first >= 0, second > 0"
        ));
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
        // A repeated key (but `outage`) is refused rather than silently overriding.
        let mut seen: Vec<&str> = Vec::new();
        for item in spec.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let err = |reason: &str| FaultSpecError {
                item: item.to_owned(),
                reason: reason.to_owned(),
            };
            let (k, v) = item
                .split_once('=')
                .ok_or_else(|| err("expected key=value"))?;
            let k = k.trim();
            if k != "outage" {
                if seen.contains(&k) {
                    return Err(err(&format!(
                        "`{k}` is given twice (each key once; only outage may repeat)"
                    )));
                }
                seen.push(k);
            }
            match k {
                "ber" => f.ber = prob(v.trim(), true).map_err(|r| err(&r))?,
                "drop" => f.frame_drop = prob(v.trim(), false).map_err(|r| err(&r))?,
                "byte_drop" => f.byte_drop = prob(v.trim(), false).map_err(|r| err(&r))?,
                "outage" => {
                    let v = v.trim();
                    let (v, dir) = match v.rsplit_once(':') {
                        Some((head, "up")) => (head, FaultDir::Up),
                        Some((head, "down")) => (head, FaultDir::Down),
                        _ => (v, FaultDir::Both),
                    };
                    let (s, l) = pair(v, "START_S:LEN_S[:up|down]").map_err(|r| err(&r))?;
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
                    let (r, n) = pair(v.trim(), "RATE_HZ:LEN_BYTES").map_err(|r| err(&r))?;
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

/// The canonical spec: the acting items in a fixed order; parses back to the same [`Faults`].
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
