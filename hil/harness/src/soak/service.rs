//! The soak's day of service, drawn as it goes from the seed (nothing stored ahead): the
//! track (straights, transitions, canted curves), the traction demand, and the episodes
//! one after another with quiet stretches between (a link fault, an adhesion patch, an
//! actuator fault, a Config change).

use rand::Rng;
use rand_pcg::Pcg64;

use super::line::LineFaults;

const NS: f64 = 1e9;

fn ns(s: f64) -> u64 {
    (s * NS) as u64
}

/// Curvature (1/m) and cant (rad) along the track, linear in time between knots:
/// straight, transition, curve, transition, repeated with random lengths, radii (left and
/// right) and cants; the default starts straight at t = 0.
#[derive(Debug, Clone, Default)]
pub struct Track {
    from: (f64, f64),
    to: (f64, f64),
    t0: u64,
    t1: u64,
    /// What the next segment is: 0 straight, 1 entry, 2 curve, 3 exit.
    next: u8,
    curve: (f64, f64),
}

impl Track {
    /// Curvature and cant at `t_ns` (non-decreasing calls).
    pub fn at(&mut self, rng: &mut Pcg64, t_ns: u64) -> (f64, f64) {
        while t_ns >= self.t1 {
            self.advance(rng);
        }
        let f = (t_ns - self.t0) as f64 / (self.t1 - self.t0).max(1) as f64;
        (
            self.from.0 + f * (self.to.0 - self.from.0),
            self.from.1 + f * (self.to.1 - self.from.1),
        )
    }

    fn advance(&mut self, rng: &mut Pcg64) {
        self.from = self.to;
        self.t0 = self.t1;
        let (len_s, to) = match self.next {
            0 => (rng.random_range(10.0..90.0), (0.0, 0.0)),
            1 => {
                let r: f64 = rng.random_range(1_500.0..6_000.0);
                let side = if rng.random::<bool>() { 1.0 } else { -1.0 };
                let cant = rng.random_range(0.0..6.0f64).to_radians();
                self.curve = (side / r, side * cant);
                (rng.random_range(3.0..8.0), self.curve)
            }
            2 => (rng.random_range(10.0..60.0), self.curve),
            _ => (rng.random_range(3.0..8.0), (0.0, 0.0)),
        };
        self.next = (self.next + 1) % 4;
        self.to = to;
        self.t1 = self.t0 + ns(len_s);
    }
}

/// What the service may do beyond its default day (each off by default): the two
/// conditions under which the device's actuator check alarms with nothing failed, and
/// the pure gain law, with which the wheelset hunts on a wet patch (the book's soak section).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, clap::Args)]
pub struct ServiceOptions {
    /// Adhesion patches may be low (leaves on the rail), not only wet.
    #[arg(long)]
    pub low_adhesion: bool,
    /// The traction demand steps to its new levels instead of ramping over 2-6 s.
    #[arg(long)]
    pub demand_steps: bool,
    /// Configs may choose the pure gain law, not only the phase lead.
    #[arg(long)]
    pub gain_law: bool,
}

/// The traction demand at the wheel (N m): at random times a new level, ramped to over
/// 2-6 s (a driver's notches under the traction controller's jerk limit), or stepped to.
#[derive(Debug, Clone)]
pub struct Demand {
    steps: bool,
    from: f64,
    to: f64,
    t0: u64,
    t1: u64,
    until: u64,
}

impl Demand {
    /// No demand until the first change; `steps`: stepped, not ramped.
    #[must_use]
    pub fn new(steps: bool) -> Self {
        Self {
            steps,
            from: 0.0,
            to: 0.0,
            t0: 0,
            t1: 1,
            until: ns(5.0),
        }
    }

    /// The demand at `t_ns`, N m (non-decreasing calls).
    pub fn at(&mut self, rng: &mut Pcg64, t_ns: u64) -> f64 {
        while t_ns >= self.until {
            self.from = self.level(self.until);
            self.to = if rng.random_range(0..5) == 0 {
                0.0
            } else {
                rng.random_range(500.0..4_000.0)
            };
            self.t0 = self.until;
            let ramp = ns(rng.random_range(2.0..6.0));
            self.t1 = self.t0 + if self.steps { 1 } else { ramp };
            self.until += ns(rng.random_range(20.0..120.0));
        }
        self.level(t_ns)
    }

    fn level(&self, t_ns: u64) -> f64 {
        if t_ns >= self.t1 {
            return self.to;
        }
        let f = t_ns.saturating_sub(self.t0) as f64 / (self.t1 - self.t0).max(1) as f64;
        self.from + f * (self.to - self.from)
    }
}

/// One episode of the service.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Episode {
    /// Link faults on both directions for `len_ns`.
    Link {
        /// The faults.
        faults: LineFaults,
        /// How long, ns.
        len_ns: u64,
        /// The kind, for the report: 0 bit errors, 1 drops, 2 outage, 3 bursts.
        kind: usize,
    },
    /// Low (`low`) or wet adhesion for `len_ns`.
    Adhesion {
        /// Low (leaves) rather than wet.
        low: bool,
        /// How long, ns.
        len_ns: u64,
    },
    /// The yaw actuator stops acting until the host has seen the alarm.
    Actuator,
    /// A Config to the design point `rate_hz` (one tick of delay) with the law.
    Config {
        /// Base rate, Hz.
        rate_hz: u32,
        /// Phase lead (else pure gain).
        lead: bool,
    },
}

/// The accepted base rates the soak moves between (designed with one tick of delay, the
/// exchange's, and the yaw loop held: `wheelset_control::design::DESIGNED`), each as
/// often as the number of times it is listed; 10 kHz does not fit the default link.
pub const RATES_HZ: [u32; 6] = [1_000, 2_000, 2_500, 5_000, 5_000, 5_000];

/// The next quiet stretch (ns) and the episode after it.
pub fn next_episode(rng: &mut Pcg64, now_ns: u64, opt: ServiceOptions) -> (u64, Episode) {
    let quiet = ns(rng.random_range(5.0..40.0));
    let start = now_ns + quiet;
    let e = match rng.random_range(0..100) {
        0..=39 => {
            let kind = rng.random_range(0..4);
            let len_s = rng.random_range(2.0..30.0);
            let faults = match kind {
                0 => LineFaults {
                    ber: 10f64.powf(rng.random_range(-5.0..-3.0)),
                    ..LineFaults::default()
                },
                1 => LineFaults {
                    drop: rng.random_range(0.001..0.05),
                    ..LineFaults::default()
                },
                2 => {
                    // From a few periods (held) to 0.3 s (the safe state and back).
                    let len = ns(10f64.powf(rng.random_range(-3.7..-0.5)));
                    LineFaults {
                        outage: Some((start, start + len)),
                        ..LineFaults::default()
                    }
                }
                _ => LineFaults {
                    burst: Some((rng.random_range(1.0..50.0), rng.random_range(1..20))),
                    ..LineFaults::default()
                },
            };
            let len_ns = match faults.outage {
                Some((s, e)) => e - s + ns(0.01),
                None => ns(len_s),
            };
            Episode::Link {
                faults,
                len_ns,
                kind,
            }
        }
        40..=59 => Episode::Adhesion {
            low: rng.random::<bool>() && opt.low_adhesion,
            len_ns: ns(rng.random_range(2.0..10.0)),
        },
        60..=69 => Episode::Actuator,
        _ => {
            let rate_hz = RATES_HZ[rng.random_range(0..RATES_HZ.len())];
            let gain = rng.random_range(0..4) == 0;
            Episode::Config {
                rate_hz,
                lead: !(gain && opt.gain_law),
            }
        }
    };
    (start, e)
}
