//! The hostile-Config table ([`rows`]): every Config a device must refuse, with its reason,
//! and those just inside each limit, which it must apply, each the [`nominal`] Config with
//! one thing changed; the [`procedure`] tries a row on the host runtime or the firmware
//! under QEMU and judges it. `Bits` and `Unsupported` have no row (no Config reaches them).

#![deny(missing_docs)]

use core::fmt;

use wheelset_control::SampleBits;
use wheelset_proto::{
    encode, encode_raw, frame_raw, Actuation, Command, Config, Decoder, Flags, Lateral, Message,
    Rates, RefuseReason, Sensor, Status, YawMode, MAX_FRAME, MAX_RAW,
};

use wheelset_runtime::{rates_for, Runtime, RuntimeConfig, RuntimeError, DEFAULT_HOLD_TICKS};

pub mod procedure;
pub use procedure::*;

/// Sensor frames before and after the row's frame.
pub const PROBE_TICKS: usize = 16;
/// Ticks without a frame after them: past the default hold, into the safe state.
pub const GAP_TICKS: usize = DEFAULT_HOLD_TICKS as usize + 3;
/// Sensor frames after the gap (the safe state left).
pub const RECOVER_TICKS: usize = 4;
/// Ticks recorded after the row's frame.
pub const AFTER_TICKS: usize = PROBE_TICKS + GAP_TICKS + RECOVER_TICKS;

/// What a device must do with a row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Expect {
    /// Refuse it for this reason: counted once, nothing else changed.
    Refused(RefuseReason),
    /// Apply it: no refusal counted; `visible`: the frames after it differ from the nominal run's.
    Applied {
        /// The frames after it differ from the nominal run's.
        visible: bool,
    },
}

/// One row of the table: a Config and what a device must do with it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Row {
    /// The field the row is about (as [`RefuseReason::field`] spells it).
    pub field: &'static str,
    /// What was done to it.
    pub change: &'static str,
    /// The Config sent.
    pub config: Config,
    /// `Some(index)`: the Config goes out with its `mode` replaced by this undefined index.
    pub undefined_mode: Option<u8>,
    /// What the device must do.
    pub expect: Expect,
}

impl fmt::Display for Row {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} {}", self.field, self.change)?;
        if let Some(r) = &self.config.rates {
            write!(
                f,
                " [{} Hz / {} / {}, hold {}]",
                r.base_rate_hz, r.yaw_div, r.traction_div, self.config.hold_ticks
            )?;
        }
        Ok(())
    }
}

/// One frame, COBS-encoded with its 0x00 delimiter.
#[derive(Clone, Copy)]
pub struct Frame {
    buf: [u8; MAX_FRAME],
    len: usize,
}

impl Frame {
    /// The frame of `m` (every message fits [`MAX_FRAME`]: the wire crate's tests).
    pub fn of(m: &Message) -> Self {
        let mut buf = [0; MAX_FRAME];
        let len = encode(m, &mut buf).unwrap_or(0);
        Self { buf, len }
    }

    /// The bytes.
    pub fn as_bytes(&self) -> &[u8] {
        self.buf.get(..self.len).unwrap_or(&[])
    }
}

impl Row {
    /// The row's frame: its Config, with the undefined mode index if it has one.
    pub fn frame(&self) -> Frame {
        let mut raw = [0u8; MAX_RAW];
        let n = encode_raw(&Message::Config(self.config), &mut raw).unwrap_or(0);
        // The raw frame is `VERSION | type | body`; a Config's body starts with its mode index.
        if let (Some(mode), Some(b)) = (self.undefined_mode, raw.get_mut(2)) {
            *b = mode;
        }
        let mut buf = [0; MAX_FRAME];
        let len = raw.get(..n).and_then(|r| frame_raw(r, &mut buf).ok());
        Frame {
            buf,
            len: len.unwrap_or(0),
        }
    }
}

/// The nominal Config: lead, traction, outputs on, default hold and rates ([`rates_for`]).
pub fn nominal<T: SampleBits>() -> Result<Config, RuntimeError> {
    Ok(with_rates(rates_for::<T>(&RuntimeConfig::default())?))
}

fn with_rates(r: Rates) -> Config {
    Config {
        mode: YawMode::Lead,
        traction: true,
        enable: true,
        hold_ticks: DEFAULT_HOLD_TICKS,
        rates: Some(r),
        monitor_safe: false,
        wsp: false,
    }
}

/// How a value's bits read.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Bits {
    /// The sample type's 32-bit pattern: fixed point (`i32`) or `f32`.
    Sample(u8),
    /// A Q32 integer factor (`u64`).
    Q32,
}

/// A rate-dependent value of [`Rates`], in place (its bits as [`Bits`] reads them).
enum Slot<'a> {
    Sample(&'a mut u32),
    Q32(&'a mut u64),
}

/// Every rate-dependent value of [`Rates`], with the reason that refuses it.
type Rated = fn(&mut Rates) -> (RefuseReason, Slot<'_>);
const RATED: [Rated; 11] = [
    |r| (RefuseReason::Kappa, Slot::Sample(&mut r.kappa)),
    |r| (RefuseReason::LeadKhf, Slot::Sample(&mut r.lead_k_hf)),
    |r| (RefuseReason::WspLead, Slot::Sample(&mut r.wsp_lead_k_hf)),
    |r| (RefuseReason::Kp, Slot::Sample(&mut r.kp)),
    |r| (RefuseReason::Ki, Slot::Sample(&mut r.ki)),
    |r| (RefuseReason::IrefStep, Slot::Sample(&mut r.iref_step)),
    |r| {
        (
            RefuseReason::IrefSafeStep,
            Slot::Sample(&mut r.iref_safe_step),
        )
    },
    |r| (RefuseReason::TorqueStep, Slot::Sample(&mut r.torque_step)),
    |r| (RefuseReason::AccGain, Slot::Q32(&mut r.acc_gain_q32)),
    |r| (RefuseReason::AccLeak, Slot::Q32(&mut r.acc_leak_q32)),
    |r| (RefuseReason::PredictHalf, Slot::Sample(&mut r.predict_half)),
];

/// `v` (bits of kind `b`, positive) times `num/den`, rounded, saturated.
fn scaled(b: Bits, v: u64, num: u32, den: u32) -> u64 {
    match b {
        Bits::Sample(0) => {
            let x = i128::from(v as u32 as i32);
            let y = (2 * x * i128::from(num) + i128::from(den)) / (2 * i128::from(den));
            i32::try_from(y).unwrap_or(i32::MAX) as u32 as u64
        }
        Bits::Sample(_) => {
            let x = f64::from(f32::from_bits(v as u32)) * f64::from(num) / f64::from(den);
            u64::from((x as f32).to_bits())
        }
        Bits::Q32 => {
            let y = (2 * u128::from(v) * u128::from(num) + u128::from(den)) / (2 * u128::from(den));
            u64::try_from(y).unwrap_or(u64::MAX)
        }
    }
}

/// `-v` in the format of `b` (a Q32 factor has no sign: its largest value).
fn negated(b: Bits, v: u64) -> u64 {
    match b {
        Bits::Sample(0) => (v as u32 as i32).wrapping_neg() as u32 as u64,
        Bits::Sample(_) => u64::from((v as u32) | 0x8000_0000),
        Bits::Q32 => u64::MAX,
    }
}

/// Every row for `T`, in table order, handed to `each` (an error is a bug of the table).
pub fn rows<T: SampleBits>(mut each: impl FnMut(Row)) -> Result<(), RuntimeError> {
    use RefuseReason as R;
    let n = T::NUMERIC;
    let base = nominal::<T>()?;
    let good = rates_for::<T>(&RuntimeConfig::default())?;
    // The paper's gains re-discretised at this base rate: not a design unless 5 kHz.
    let at = |base_rate_hz| {
        let mut c = RuntimeConfig::default();
        c.control.base_rate_hz = base_rate_hz;
        rates_for::<T>(&c)
    };
    // The rates designed for the rate and delay (an error: not a design point).
    let design = |hz, d| rates_for::<T>(&RuntimeConfig::default().designed(hz, d)?);
    let field = R::field;
    let no = Expect::Refused;
    let yes = |visible| Expect::Applied { visible };
    for (change, mode) in [("index 3", 3u8), ("index 127", 127)] {
        each(Row {
            field: field(R::UnknownRequest),
            change,
            config: base,
            undefined_mode: Some(mode),
            expect: no(R::UnknownRequest),
        });
    }
    let mut row = |field: &'static str, change, config, expect| {
        each(Row {
            field,
            change,
            config,
            undefined_mode: None,
            expect,
        });
    };
    let wr = with_rates;
    let mut refuse = |why: R, change, edit: &dyn Fn(&mut Rates)| {
        let mut r = good;
        edit(&mut r);
        row(field(why), change, wr(r), no(why));
    };
    for (change, v) in [("the other sample type", n ^ 1), ("2", 2), ("255", 255)] {
        refuse(R::Numeric, change, &|r| r.numeric = v);
    }
    for (change, v) in [
        ("one bit flipped", good.fingerprint ^ 1),
        ("all bits flipped", !good.fingerprint),
    ] {
        refuse(R::Fingerprint, change, &|r| r.fingerprint = v);
    }
    // The base rate (the range is checked first), and rates in range without a design.
    for (change, v) in [
        ("0", 0),
        ("499 Hz", 499),
        ("20 001 Hz", 20_001),
        ("25 kHz", 25_000),
        ("u32::MAX", u32::MAX),
    ] {
        refuse(R::BaseRate, change, &|r| r.base_rate_hz = v);
    }
    for (why, change, hz) in [
        (R::BaseRate, "4 kHz (not a design point)", 4_000),
        (R::BaseRate, "20 kHz (not a design point)", 20_000),
        // A period of no whole number of microseconds, with the coefficients computed for it.
        (R::Period, "3 kHz (333.3 us)", 3_000),
        (R::Period, "7 kHz (142.9 us)", 7_000),
        (R::Period, "19 999 Hz", 19_999),
    ] {
        let k = at(hz)?;
        refuse(why, change, &|r| *r = k);
    }
    // The divisors: the designs run both loops every tick.
    for (change, v) in [
        ("2", 2),
        ("10 (a 500 Hz loop)", 10),
        ("0", 0),
        ("u16::MAX", u16::MAX),
    ] {
        refuse(R::YawDiv, change, &|r| r.yaw_div = v);
        refuse(R::TractionDiv, change, &|r| r.traction_div = v);
    }
    // The delay: only where the rate has a design for it.
    for (change, v) in [("0", 0), ("4 at 5 kHz", 4), ("255", u8::MAX)] {
        refuse(R::Delay, change, &|r| r.delay_ticks = v);
    }
    let k1 = design(1_000, 1)?;
    // An active yaw law where only the traction loop is designed: the passive law only.
    let y = field(R::YawNotDesigned);
    for (change, hz, d, mode) in [
        ("lead at 500 Hz", 500, 1, YawMode::Lead),
        ("gain at 500 Hz", 500, 1, YawMode::Gain),
        ("lead at 1 kHz with two ticks", 1_000, 2, YawMode::Lead),
        ("gain at 2.5 kHz with three ticks", 2_500, 3, YawMode::Gain),
    ] {
        let c = Config {
            mode,
            ..wr(design(hz, d)?)
        };
        row(y, change, c, no(R::YawNotDesigned));
    }
    // The hold: 20 ms at most (the probe's gap is past the default hold, so a longer one shows).
    let k10 = design(10_000, 1)?;
    for (change, hold_ticks, rates, expect) in [
        ("0", 0, None, yes(true)),
        ("100 (20 ms at 5 kHz)", 100, None, yes(true)),
        ("101", 101, None, no(R::HoldTicks)),
        ("65 535", u16::MAX, None, no(R::HoldTicks)),
        ("65 535 with rates", u16::MAX, Some(good), no(R::HoldTicks)),
        ("200 (20 ms at 10 kHz)", 200, Some(k10), yes(true)),
        ("201 at 10 kHz", 201, Some(k10), no(R::HoldTicks)),
        ("20 (20 ms at 1 kHz)", 20, Some(k1), yes(true)),
        ("21 at 1 kHz", 21, Some(k1), no(R::HoldTicks)),
    ] {
        let c = Config {
            hold_ticks,
            rates,
            ..base
        };
        row(field(R::HoldTicks), change, c, expect);
    }
    // Every coefficient, perturbed: only the design's bits are taken.
    for slot in RATED {
        // `r` with this value set to `v` (a 32-bit value takes the low 32 bits).
        let set = |v: u64| {
            let mut r = good;
            match slot(&mut r).1 {
                Slot::Sample(w) => *w = v as u32,
                Slot::Q32(q) => *q = v,
            }
            wr(r)
        };
        let mut r = good;
        let (why, (b, v)) = match slot(&mut r) {
            (why, Slot::Sample(w)) => (why, (Bits::Sample(n), u64::from(*w))),
            (why, Slot::Q32(q)) => (why, (Bits::Q32, *q)),
        };
        let f = field(why);
        row(f, "+1 LSB", set(v + 1), no(why));
        row(f, "-1 LSB", set(v.saturating_sub(1)), no(why));
        for (change, (num, den)) in [
            ("x(1 + 0.9 2^-10)", (10_249, 10_240)),
            ("x(1 - 0.9 2^-10)", (10_231, 10_240)),
            ("x1.01", (101, 100)),
            ("x2", (2, 1)),
            ("x10", (10, 1)),
            ("x0.5", (1, 2)),
        ] {
            row(f, change, set(scaled(b, v, num, den)), no(why));
        }
        row(f, "1 LSB", set(1), no(why));
        row(f, "0", set(0), no(why));
        let sign = if b == Bits::Q32 {
            "u64::MAX"
        } else {
            "negative"
        };
        row(f, sign, set(negated(b, v)), no(why));
        if b == Bits::Sample(1) {
            for (change, bits) in [
                ("the largest subnormal", 0x007F_FFFFu64),
                ("NaN", 0x7FC0_0000),
                ("infinity", 0x7F80_0000),
            ] {
                row(f, change, set(bits), no(why));
            }
        }
    }
    for (change, k) in [("+1", 1i16), ("-1", -1)] {
        let ki_shift = good.ki_shift.wrapping_add_signed(k as i8);
        row(
            field(R::Ki),
            change,
            wr(Rates { ki_shift, ..good }),
            no(R::Ki),
        );
    }
    // A rate carrying another design's gains: the first loop whose gains differ is named.
    let carrying = |hz, delay_ticks, r: Rates| {
        wr(Rates {
            base_rate_hz: hz,
            delay_ticks,
            ..r
        })
    };
    let rates = "rates";
    let (k2, k5d2, k10d3) = (design(2_000, 1)?, design(5_000, 2)?, design(10_000, 3)?);
    for (change, config, why) in [
        (
            "1 kHz with the paper's gains re-discretised (its current loop unstable)",
            wr(at(1_000)?),
            R::Kp,
        ),
        (
            "2 kHz with the paper's gains re-discretised (its current loop unstable)",
            wr(at(2_000)?),
            R::Kp,
        ),
        (
            "1 kHz with the 5 kHz coefficients",
            carrying(1_000, 1, good),
            R::Kp,
        ),
        ("5 kHz with the 2 kHz design", carrying(5_000, 1, k2), R::Kp),
        (
            "5 kHz, delay 2, with the delay-1 design",
            carrying(5_000, 2, good),
            R::Kp,
        ),
        (
            "10 kHz, delay 1, with the delay-3 design",
            carrying(10_000, 1, k10d3),
            R::Kp,
        ),
        (
            "5 kHz with the 10 kHz coefficients (same gains, other steps)",
            carrying(5_000, 1, k10),
            R::Ki,
        ),
        (
            "1 kHz with the 1 kHz traction design and the paper's lead",
            wr(Rates {
                lead_k_hf: good.lead_k_hf,
                ..k1
            }),
            R::LeadKhf,
        ),
        (
            "5 kHz, delay 2, with the paper's lead",
            wr(Rates {
                lead_k_hf: good.lead_k_hf,
                ..k5d2
            }),
            R::LeadKhf,
        ),
    ] {
        row(rates, change, config, no(why));
    }
    // The switches, all taken by every build.
    let switches: [(_, fn(&mut Config), _); 6] = [
        ("wheel-slip protection on", |c| c.wsp = true, true),
        ("monitor_safe on", |c| c.monitor_safe = true, false),
        ("mode passive", |c| c.mode = YawMode::Passive, true),
        ("mode gain", |c| c.mode = YawMode::Gain, true),
        ("traction off", |c| c.traction = false, true),
        ("outputs off", |c| c.enable = false, true),
    ];
    for (change, switch, visible) in switches {
        let mut c = base;
        switch(&mut c);
        row("switches", change, c, yes(visible));
    }
    for p in wheelset_control::design::DESIGNED {
        let (hz, d) = (p.base_rate_hz, p.delay_ticks);
        let mode = if p.yaw {
            YawMode::Lead
        } else {
            YawMode::Passive
        };
        row(
            "nominal",
            "a design point, as rates_for computes it",
            Config {
                mode,
                ..wr(design(hz, d)?)
            },
            yes((hz, d) != (5_000, 1)),
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use wheelset_control::Fx;

    #[test]
    fn scaling_rounds_in_each_format() {
        assert_eq!(scaled(Bits::Sample(0), 1_000, 3, 1), 3_000);
        assert_eq!(scaled(Bits::Sample(0), 1_000, 10_249, 10_240), 1_001);
        assert_eq!(scaled(Bits::Sample(0), 0x7000_0000, 2, 1), i32::MAX as u64);
        let f = |x: f32| u64::from(x.to_bits());
        assert_eq!(scaled(Bits::Sample(1), f(0.5), 3, 1), f(1.5));
        assert_eq!(scaled(Bits::Q32, 1 << 32, 101, 100), (101 << 32) / 100 + 1);
        assert_eq!(negated(Bits::Sample(0), 5), (-5i32) as u32 as u64);
        assert_eq!(negated(Bits::Sample(1), f(0.5)), f(-0.5));
    }

    #[test]
    fn an_undefined_mode_is_an_unknown_request_on_the_wire() {
        let mut found = 0;
        rows::<Fx>(|r| {
            if let Some(m) = r.undefined_mode {
                found += 1;
                let f = r.frame();
                let mut dec = Decoder::new();
                let (next, rest) = dec.next_request(f.as_bytes());
                assert!(rest.is_empty(), "mode {m}");
                assert_eq!(next, Some(Ok(wheelset_proto::Request::Unknown)), "mode {m}");
            }
        })
        .expect("the table");
        assert_eq!(found, 2);
    }
}
