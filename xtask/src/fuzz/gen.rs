//! The hostile frames: a seeded generator ([`Gen`], `rand_pcg`'s PCG) and the frame kinds of
//! the module docs' table ([`KINDS`]), valid bodies (Sensor, Config with rates, Command)
//! and their mutations.

use wheelset_control::SampleBits;
use wheelset_proto::{
    encode_vec, frame_raw, Command, Config, Lateral, Message, Rates, Sensor, YawMode, MAX_FRAME,
    VERSION,
};
use wheelset_runtime::{rates_for, RuntimeConfig};

/// The fuzz stream: PCG (`rand_pcg::Pcg64`) seeded from the run's seed, so a seed
/// reproduces a run exactly.
#[derive(Debug, Clone)]
pub struct Gen(rand_pcg::Pcg64);

impl Gen {
    /// A generator from `seed`.
    pub fn new(seed: u64) -> Self {
        use rand::SeedableRng as _;
        Self(rand_pcg::Pcg64::seed_from_u64(seed))
    }

    /// The next 64 random bits.
    pub fn u64(&mut self) -> u64 {
        use rand::RngCore as _;
        self.0.next_u64()
    }

    /// Uniform in `0..n` (`n > 0`).
    pub fn below(&mut self, n: u64) -> u64 {
        self.u64() % n.max(1)
    }

    fn chance(&mut self, per_mille: u64) -> bool {
        self.below(1000) < per_mille
    }

    fn byte(&mut self) -> u8 {
        self.u64() as u8
    }

    /// An `i32` that is an extreme, a small value or anything, with equal odds.
    fn i32(&mut self) -> i32 {
        const EDGES: [i32; 7] = [i32::MIN, i32::MIN + 1, -1, 0, 1, i32::MAX - 1, i32::MAX];
        match self.below(3) {
            0 => EDGES[self.below(EDGES.len() as u64) as usize],
            1 => (self.below(2_000_001) as i64 - 1_000_000) as i32,
            _ => self.u64() as i32,
        }
    }

    /// A `u32` that is an extreme, small, or anything.
    fn u32(&mut self) -> u32 {
        match self.below(3) {
            0 => [0, 1, 2, u32::MAX - 1, u32::MAX][self.below(5) as usize],
            1 => self.below(100_000) as u32,
            _ => self.u64() as u32,
        }
    }
}

/// The frame kinds (the table of the module docs), in report order.
pub const KINDS: [&str; 8] = [
    "sensor",
    "config",
    "command",
    "bitflip",
    "truncated",
    "random",
    "crc_valid",
    "oversize",
];

/// The device's own design for `base_rate_hz` with one tick of delay (the paper's gains
/// re-discretised where the rate has no design), if the host-side compilation takes it.
pub(super) fn own_rates<T: SampleBits>(base_rate_hz: u32) -> Option<Rates> {
    let cfg = RuntimeConfig::default();
    let cfg = cfg.designed(base_rate_hz, 1).unwrap_or_else(|_| {
        let mut c = cfg;
        c.control.base_rate_hz = base_rate_hz;
        c
    });
    rates_for::<T>(&cfg).ok()
}

/// A field of `r` scaled hostilely (see the module docs).
pub(super) fn mutate_rates(g: &mut Gen, r: &mut Rates) {
    let scale = |g: &mut Gen, v: u32| -> u32 {
        match g.below(7) {
            0 => 0,
            1 => 1,
            2 => v / 2,
            3 => v.saturating_mul(2),
            4 => v.saturating_mul(4),
            5 => v.saturating_mul(100),
            _ => u32::MAX,
        }
    };
    match g.below(14) {
        11 => r.kp = scale(g, r.kp),
        12 => r.lead_k_hf = scale(g, r.lead_k_hf),
        13 => r.delay_ticks = g.byte(),
        0 => r.kappa = scale(g, r.kappa),
        1 => r.ki = scale(g, r.ki),
        2 => r.predict_half = scale(g, r.predict_half),
        3 => r.iref_step = scale(g, r.iref_step),
        4 => r.iref_safe_step = scale(g, r.iref_safe_step),
        5 => r.torque_step = scale(g, r.torque_step),
        6 => r.acc_gain_q32 = u64::from(scale(g, r.acc_gain_q32 as u32)),
        7 => r.acc_leak_q32 = g.u64() >> g.below(64),
        8 => r.base_rate_hz = scale(g, r.base_rate_hz),
        9 => r.yaw_div = g.below(u64::from(u16::MAX) + 1) as u16,
        _ => r.traction_div = g.below(u64::from(u16::MAX) + 1) as u16,
    }
}

pub(super) fn config<T: SampleBits>(g: &mut Gen) -> Config {
    let mode = [YawMode::Passive, YawMode::Gain, YawMode::Lead][g.below(3) as usize];
    let rates = match g.below(4) {
        0 => None,
        1 => Some(Rates {
            numeric: g.byte() % 4,
            fingerprint: g.u32(),
            base_rate_hz: g.u32(),
            yaw_div: g.u64() as u16,
            traction_div: g.u64() as u16,
            delay_ticks: g.byte(),
            kappa: g.u32(),
            lead_k_hf: g.u32(),
            wsp_lead_k_hf: g.u32(),
            kp: g.u32(),
            ki: g.u32(),
            ki_shift: g.byte(),
            predict_half: g.u32(),
            iref_step: g.u32(),
            iref_safe_step: g.u32(),
            torque_step: g.u32(),
            acc_gain_q32: g.u64() >> g.below(64),
            acc_leak_q32: g.u64() >> g.below(64),
        }),
        k => {
            const RATES: [u32; 8] = [1000, 2000, 2500, 4000, 5000, 8000, 10_000, 20_000];
            let mut r = own_rates::<T>(RATES[g.below(RATES.len() as u64) as usize]);
            if let (Some(r), true) = (r.as_mut(), k == 2) {
                mutate_rates(g, r);
            }
            r
        }
    };
    Config {
        mode,
        traction: g.chance(500),
        enable: g.chance(900),
        hold_ticks: match g.below(3) {
            0 => g.below(20) as u16,
            1 => u16::MAX,
            _ => g.u64() as u16,
        },
        wsp: g.below(2) == 0,
        monitor_safe: g.below(4) == 0,
        rates,
    }
}

pub(super) fn sensor(g: &mut Gen, seq: &mut u16) -> Sensor {
    *seq = if g.chance(950) {
        seq.wrapping_add(1)
    } else {
        g.u64() as u16
    };
    let lateral = match g.below(3) {
        0 => Lateral::Velocity(g.i32()),
        1 => Lateral::Acceleration(g.i32()),
        _ => Lateral::Both {
            vel_um_s: g.i32(),
            acc_dmm_s2: g.i32(),
        },
    };
    Sensor {
        seq: *seq,
        t_us: g.u64() as u16,
        lateral,
        i_a_ma: g.i32(),
        omega_m_mrad_s: g.i32(),
        demand_nm: g.i32(),
        v_ref_mm_s: g.i32(),
    }
}

pub(super) fn command(g: &mut Gen) -> Command {
    match g.below(10) {
        0 => Command::ResetCounters,
        1 => Command::ClearFaults,
        _ => Command::RequestStatus,
    }
}

/// A valid message's frame, without its delimiter.
pub(super) fn valid_body<T: SampleBits>(g: &mut Gen, seq: &mut u16) -> (usize, Vec<u8>) {
    let (kind, m) = match g.below(10) {
        0..=5 => (0, Message::Sensor(sensor(g, seq))),
        6..=7 => (1, Message::Config(config::<T>(g))),
        _ => (2, Message::Command(command(g))),
    };
    let mut f = encode_vec(&m).map(|v| v.to_vec()).unwrap_or_default();
    f.pop(); // the delimiter
    (kind, f)
}

/// One generated frame (without the final delimiter; may contain 0x00 after a flip).
pub(super) fn frame<T: SampleBits>(g: &mut Gen, seq: &mut u16) -> (usize, Vec<u8>) {
    match g.below(100) {
        0..=44 => valid_body::<T>(g, seq),
        45..=64 => {
            let (_, mut f) = valid_body::<T>(g, seq);
            for _ in 0..=g.below(3) {
                if !f.is_empty() {
                    let i = g.below(f.len() as u64) as usize;
                    f[i] ^= 1 << g.below(8);
                }
            }
            (3, f)
        }
        65..=74 => {
            let (_, mut f) = valid_body::<T>(g, seq);
            let n = g.below(f.len() as u64) as usize;
            f.truncate(n);
            (4, f)
        }
        75..=84 => {
            let n = 1 + g.below(120) as usize;
            (5, (0..n).map(|_| g.byte()).collect())
        }
        85..=96 => {
            let n = g.below(100) as usize;
            let mut raw = vec![if g.chance(900) { VERSION } else { g.byte() }];
            raw.push(g.byte() % 6); // the type byte, mostly in range
            raw.extend((0..n).map(|_| g.byte()));
            let mut out = vec![0u8; raw.len() + raw.len() / 254 + 7];
            let k = frame_raw(&raw, &mut out).unwrap_or(1);
            // Without the delimiter, as the other kinds.
            out.truncate(k - 1);
            (6, out)
        }
        _ => {
            let n = MAX_FRAME + 1 + g.below(200) as usize;
            (7, (0..n).map(|_| g.byte() | 1).collect())
        }
    }
}
