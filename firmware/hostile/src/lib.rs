//! The hostile-Config table: every Config a device must refuse, with the reason it must
//! give, beside those just inside each limit and the nominal ones at every plausible
//! rate, which it must apply ([`rows`]); and the procedure that tries one row on any
//! device that takes frames ([`Device`], [`probe`]) and judges it by what the device
//! says and does ([`judge`]). The host runtime runs it
//! (`firmware/runtime/tests/hostile.rs`, both sample types), and so does the firmware
//! under QEMU over its UART (`hil/harness/tests/qemu_hostile.rs`): one table, the same
//! judgement. Test support on the host (the rows are computed with [`rates_for`]): those
//! tests depend on this crate, no firmware does.
//!
//! This file holds one long idea, the table: [`rows`] writes each row beside the limit
//! it tests and the reason the device must give, in the order of the table below, so a
//! row is read where its limit is. The procedure that tries a row is [`procedure`].
//!
//! # The rows
//!
//! From the plausibility table of `wheelset_proto::plausible`, for sample type `T`, each
//! row the nominal Config ([`nominal`]: the lead, traction on, outputs enabled, the
//! default hold, the default rates as [`rates_for`] computes them) with one thing
//! changed:
//!
//! | field | applied (just inside) | refused (the reason: the field) |
//! |---|---|---|
//! | the mode | | an index this version does not define (3, 127): `UnknownRequest` |
//! | `rates.numeric`, `rates.fingerprint` | | the other sample type, 2, 255; one bit flipped, all flipped |
//! | `rates.base_rate_hz` | 500 Hz, 20 kHz (the nominal rows) | 0, 499 Hz, 20 001 Hz, 25 kHz, `u32::MAX` |
//! | the period | every rate with a whole number of us (the nominal rows) | 3 kHz, 7 kHz, 19 999 Hz (rates computed for them): `Period` |
//! | `rates.yaw_div`, `rates.traction_div` | 10 at 5 kHz (a 500 Hz loop) | 11, 0, `u16::MAX` |
//! | `hold_ticks` | 0, 100 at 5 kHz (20 ms); 400 at 20 kHz; 10 at 500 Hz | 101, 65 535 at 5 kHz; 401 at 20 kHz; 11 at 500 Hz |
//! | `rates.predict_half` | 0.75 - 1 LSB (the nominal is 0.75), 0 (predictor off) | 0.75 + 1 LSB, x10, negative |
//! | each rate-dependent coefficient | x(1 +- 0.9 2^-10), +-1 LSB | x(1 +- 1.1 2^-10), x1.01, x2, x3, x4, x10, x0.5, 1 LSB, 0, negative (the Q32 factors: `u64::MAX`); `f32`: the largest subnormal, NaN, infinity |
//! | the rates together | | 4 kHz with the 5 kHz coefficients and the reverse, 5 kHz with 10 kHz's and the reverse, 20 kHz with 16 kHz's, 500 Hz with 625 Hz's (`Kappa`), 10 kHz / 2 / 1 with 5 kHz's (`Ki`), 10 kHz / 2 / 2 with 5 kHz's (`AccGain`) |
//! | the switches | the protection, the monitor's safe state, another mode, traction off, outputs off | |
//! | nominal | every base rate from 500 Hz to 20 kHz with a whole number of us, divisors 1 / 1; and 5 kHz / 10 / 1, 5 kHz / 1 / 10, 8 kHz / 2 / 1, 10 kHz / 2 / 1, 10 kHz / 4 / 2, 20 kHz / 10 / 4, 20 kHz / 40 / 40 | |
//!
//! (`f32` 1 LSB is the smallest subnormal.) `Bits` (a bit pattern the control core
//! refuses after every range check passed) has no row: the ranges leave none that
//! reaches it. `Unsupported` is not about a Config (a fault injection on a build without
//! it).
//!
//! # One row
//!
//! Every row starts from the nominal state and runs the frames of the nominal run with
//! one frame replaced by the row's ([`probe`]):
//!
//! 1. restore: a Sensor frame, the nominal Config with the outputs off, a Sensor frame,
//!    the nominal Config (each restarts the core: its filters from zero; the re-enabled
//!    outputs slew the yaw torque from zero and restart the PI from the back-EMF),
//!    `ClearFaults`, `ResetCounters`;
//! 2. a Status (`s0`);
//! 3. [`PROBE_TICKS`] Sensor frames ([`probe_sensor`]): `before`;
//! 4. the row's frame (in the nominal run `ClearFaults`, which changes nothing): `at`;
//! 5. the Sensor frames again, [`GAP_TICKS`] ticks without a frame (longer than the
//!    default hold: the safe state), [`RECOVER_TICKS`] Sensor frames: `after`;
//! 6. a Status (`s1`).
//!
//! [`judge`]: the restore is proven by `s0` and `before` equal to the nominal run's (the
//! counters from zero, the same outputs on the same frames). A refusal is proven by
//! `s1`: `cmd_refused` 1 and `refuse_reason` the row's reason (the counters were reset
//! in step 1, so the count is this row's own), with `at`, `after` and every other
//! counter equal to the nominal run's: the Config changed nothing. The flag
//! `CMD_REFUSED` is not compared (whether it persists after the refused frame is not the
//! table's matter). An applied row counts no refusal, and where it must show
//! ([`Expect::Applied`] `visible`) its frames differ from the nominal run's.

#![deny(missing_docs)]

use core::fmt;

use wheelset_control::SampleBits;
use wheelset_proto::{
    cobs_decode_in_place, cobs_encode, crc32c, encode_vec, Actuation, Command, Config, Decoder,
    Flags, Lateral, Message, Rates, RefuseReason, Sensor, Status, YawMode, CRC_LEN, MAX_FRAME,
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
    /// Apply it: no refusal counted; `visible`: the frames after it differ from the
    /// nominal run's (a new rate, law, hold or switch that the probe's frames show).
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
    /// `Some(index)`: the Config goes out with its `mode` replaced by this index, which
    /// the protocol does not define (an unknown request).
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
        let frame = encode_vec(m).unwrap_or_default();
        let len = match buf.get_mut(..frame.len()) {
            Some(b) => {
                b.copy_from_slice(&frame);
                frame.len()
            }
            None => 0,
        };
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
        let f = Frame::of(&Message::Config(self.config));
        let Some(mode) = self.undefined_mode else {
            return f;
        };
        // The raw frame is `VERSION | type | body | CRC`; a Config's body starts with its
        // mode's variant index (one byte below 0x80).
        let mut raw = f.buf;
        let encoded = f.len.saturating_sub(1);
        let Some(n) = raw.get_mut(..encoded).and_then(cobs_decode_in_place) else {
            return f;
        };
        let body = n.saturating_sub(CRC_LEN);
        if let Some(b) = raw.get_mut(2) {
            *b = mode;
        }
        let crc = crc32c(raw.get(..body).unwrap_or(&[]));
        if let Some(c) = raw.get_mut(body..n) {
            c.copy_from_slice(&crc.to_le_bytes());
        }
        let mut out = Frame {
            buf: [0; MAX_FRAME],
            len: 0,
        };
        let len = raw
            .get(..n)
            .and_then(|r| cobs_encode(r, &mut out.buf[..MAX_FRAME - 1]))
            .unwrap_or(0);
        out.len = len + 1; // the delimiter: the buffer's 0 after the encoding
        out
    }
}

/// The runtime configuration at these rates (the default otherwise), with the matched
/// delay compensation of the rate table (`1 + yaw_div/2` ticks).
pub fn at_rates(base_rate_hz: u32, yaw_div: u16, traction_div: u16) -> RuntimeConfig {
    let mut c = RuntimeConfig::default();
    c.control.base_rate_hz = base_rate_hz;
    c.control.yaw_divisor = yaw_div;
    c.control.traction_divisor = traction_div;
    c.control.yaw_predict_ticks = 1.0 + f64::from(yaw_div) / 2.0;
    c
}

/// The nominal Config: the lead, traction on, outputs enabled, the default hold, the
/// default rates as [`rates_for`] computes them for `T`.
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

/// The base rates and divisors of the nominal rows: every base rate from
/// `BASE_RATE_MIN_HZ` to `BASE_RATE_MAX_HZ` whose period is a whole number of the
/// ticker's microseconds, both loops at it; and loops below the base rate, down to the
/// slowest plausible loop.
pub fn nominal_rates() -> impl Iterator<Item = (u32, u16, u16)> {
    use wheelset_proto::plausible::{BASE_RATE_MAX_HZ, BASE_RATE_MIN_HZ, TICKER_HZ};
    (BASE_RATE_MIN_HZ..=BASE_RATE_MAX_HZ)
        .filter(|hz| TICKER_HZ.is_multiple_of(*hz))
        .map(|hz| (hz, 1, 1))
        .chain([
            (5_000, 10, 1),
            (5_000, 1, 10),
            (8_000, 2, 1),
            (10_000, 2, 1),
            (10_000, 4, 2),
            (20_000, 10, 4),
            (20_000, 40, 40),
        ])
}

/// A rate-dependent value of [`Rates`].
#[derive(Clone, Copy)]
enum Coef {
    Kappa,
    Ki,
    IrefStep,
    IrefSafeStep,
    TorqueStep,
    AccGain,
    AccLeak,
    PredictHalf,
}

/// How a value's bits read.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Bits {
    /// The sample type's 32-bit pattern: fixed point (`i32`) or `f32`.
    Sample(u8),
    /// A Q32 integer factor (`u64`).
    Q32,
}

impl Coef {
    const RATED: [Self; 7] = [
        Self::Kappa,
        Self::Ki,
        Self::IrefStep,
        Self::IrefSafeStep,
        Self::TorqueStep,
        Self::AccGain,
        Self::AccLeak,
    ];

    fn reason(self) -> RefuseReason {
        match self {
            Self::Kappa => RefuseReason::Kappa,
            Self::Ki => RefuseReason::Ki,
            Self::IrefStep => RefuseReason::IrefStep,
            Self::IrefSafeStep => RefuseReason::IrefSafeStep,
            Self::TorqueStep => RefuseReason::TorqueStep,
            Self::AccGain => RefuseReason::AccGain,
            Self::AccLeak => RefuseReason::AccLeak,
            Self::PredictHalf => RefuseReason::PredictHalf,
        }
    }

    fn bits(self, numeric: u8) -> Bits {
        match self {
            Self::AccGain | Self::AccLeak => Bits::Q32,
            _ => Bits::Sample(numeric),
        }
    }

    fn get(self, r: &Rates) -> u64 {
        match self {
            Self::Kappa => u64::from(r.kappa),
            Self::Ki => u64::from(r.ki),
            Self::IrefStep => u64::from(r.iref_step),
            Self::IrefSafeStep => u64::from(r.iref_safe_step),
            Self::TorqueStep => u64::from(r.torque_step),
            Self::AccGain => r.acc_gain_q32,
            Self::AccLeak => r.acc_leak_q32,
            Self::PredictHalf => u64::from(r.predict_half),
        }
    }

    /// `r` with this value set to `v` (a 32-bit field takes the low 32 bits).
    fn set(self, r: Rates, v: u64) -> Rates {
        let w = v as u32;
        match self {
            Self::Kappa => Rates { kappa: w, ..r },
            Self::Ki => Rates { ki: w, ..r },
            Self::IrefStep => Rates { iref_step: w, ..r },
            Self::IrefSafeStep => Rates {
                iref_safe_step: w,
                ..r
            },
            Self::TorqueStep => Rates {
                torque_step: w,
                ..r
            },
            Self::AccGain => Rates {
                acc_gain_q32: v,
                ..r
            },
            Self::AccLeak => Rates {
                acc_leak_q32: v,
                ..r
            },
            Self::PredictHalf => Rates {
                predict_half: w,
                ..r
            },
        }
    }
}

/// `v` (bits of kind `b`, a positive value) times `num/den`, rounded (saturated at the
/// format's largest value).
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

/// `1 + k 2^-10` as `num / den` with `den = 10 240` (`k` in tenths).
const fn tolerance(k_tenths: i32) -> (u32, u32) {
    ((10_240 + k_tenths) as u32, 10_240)
}

/// Every row for sample type `T`, in table order, handed to `each` (no allocation).
/// Errors: the host cannot compute a row's rates (a bug of the table).
pub fn rows<T: SampleBits>(mut each: impl FnMut(Row)) -> Result<(), RuntimeError> {
    use RefuseReason as R;
    let n = T::NUMERIC;
    let base = nominal::<T>()?;
    let good = rates_for::<T>(&RuntimeConfig::default())?;
    let at = |hz, yd, td| rates_for::<T>(&at_rates(hz, yd, td));
    let field = R::field;
    let no = Expect::Refused;
    let yes = |visible| Expect::Applied { visible };
    // The mode: an index the protocol does not define.
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
    // The core's identity.
    let wr = with_rates;
    for (change, numeric) in [("the other sample type", n ^ 1), ("2", 2), ("255", 255)] {
        row(
            field(R::Numeric),
            change,
            wr(Rates { numeric, ..good }),
            no(R::Numeric),
        );
    }
    for (change, fingerprint) in [
        ("one bit flipped", good.fingerprint ^ 1),
        ("all bits flipped", !good.fingerprint),
    ] {
        row(
            field(R::Fingerprint),
            change,
            wr(Rates {
                fingerprint,
                ..good
            }),
            no(R::Fingerprint),
        );
    }
    // The base rate (the nominal coefficients: the range is checked first).
    for (change, base_rate_hz) in [
        ("0", 0),
        ("499 Hz", 499),
        ("20 001 Hz", 20_001),
        ("25 kHz", 25_000),
        ("u32::MAX", u32::MAX),
    ] {
        row(
            field(R::BaseRate),
            change,
            wr(Rates {
                base_rate_hz,
                ..good
            }),
            no(R::BaseRate),
        );
    }
    // A period of no whole number of microseconds, with the coefficients computed for it.
    for (change, hz) in [
        ("3 kHz (333.3 us)", 3_000),
        ("7 kHz (142.9 us)", 7_000),
        ("19 999 Hz", 19_999),
    ] {
        row(field(R::Period), change, wr(at(hz, 1, 1)?), no(R::Period));
    }
    // The loops: the slowest plausible (500 Hz at 5 kHz) is a nominal row below.
    for (change, div) in [("11 (454.5 Hz)", 11), ("0", 0), ("u16::MAX", u16::MAX)] {
        row(
            field(R::YawDiv),
            change,
            wr(Rates {
                yaw_div: div,
                ..good
            }),
            no(R::YawDiv),
        );
        row(
            field(R::TractionDiv),
            change,
            wr(Rates {
                traction_div: div,
                ..good
            }),
            no(R::TractionDiv),
        );
    }
    // The hold: 20 ms at most (the gap of the probe is past the default hold, so a
    // longer one shows; 0 enters the safe state at the first tick without a frame).
    let hold = |hold_ticks, rates| Config {
        hold_ticks,
        rates,
        ..base
    };
    let h = field(R::HoldTicks);
    row(h, "0", hold(0, None), yes(true));
    row(h, "100 (20 ms at 5 kHz)", hold(100, None), yes(true));
    row(h, "101", hold(101, None), no(R::HoldTicks));
    row(h, "65 535", hold(u16::MAX, None), no(R::HoldTicks));
    row(
        h,
        "65 535 with rates",
        hold(u16::MAX, Some(good)),
        no(R::HoldTicks),
    );
    let (r20k, r500) = (at(20_000, 1, 1)?, at(500, 1, 1)?);
    row(h, "400 (20 ms at 20 kHz)", hold(400, Some(r20k)), yes(true));
    row(h, "401 at 20 kHz", hold(401, Some(r20k)), no(R::HoldTicks));
    row(h, "10 (20 ms at 500 Hz)", hold(10, Some(r500)), yes(true));
    row(h, "11 at 500 Hz", hold(11, Some(r500)), no(R::HoldTicks));
    // The predictor's alpha/2: at most 0.75 (the nominal's), 0 = off.
    let p = Coef::PredictHalf;
    let pb = p.bits(n);
    let set = |c: Coef, v: u64| wr(c.set(good, v));
    let v0 = p.get(&good);
    row(
        field(R::PredictHalf),
        "0 (predictor off)",
        set(p, 0),
        yes(false),
    );
    row(field(R::PredictHalf), "-1 LSB", set(p, v0 - 1), yes(false));
    row(
        field(R::PredictHalf),
        "+1 LSB",
        set(p, v0 + 1),
        no(R::PredictHalf),
    );
    row(
        field(R::PredictHalf),
        "x10",
        set(p, scaled(pb, v0, 10, 1)),
        no(R::PredictHalf),
    );
    row(
        field(R::PredictHalf),
        "negative",
        set(p, negated(pb, v0)),
        no(R::PredictHalf),
    );
    // Every rate-dependent coefficient, perturbed.
    for c in Coef::RATED {
        let (why, b, v) = (c.reason(), c.bits(n), c.get(&good));
        let f = field(why);
        for (change, (num, den)) in [
            ("x(1 + 0.9 2^-10)", tolerance(9)),
            ("x(1 - 0.9 2^-10)", tolerance(-9)),
        ] {
            row(f, change, set(c, scaled(b, v, num, den)), yes(false));
        }
        row(f, "+1 LSB", set(c, v + 1), yes(false));
        row(f, "-1 LSB", set(c, v.saturating_sub(1)), yes(false));
        for (change, (num, den)) in [
            ("x(1 + 1.1 2^-10)", tolerance(11)),
            ("x(1 - 1.1 2^-10)", tolerance(-11)),
            ("x1.01", (101, 100)),
            ("x2", (2, 1)),
            ("x3", (3, 1)),
            ("x4", (4, 1)),
            ("x10", (10, 1)),
            ("x0.5", (1, 2)),
        ] {
            row(f, change, set(c, scaled(b, v, num, den)), no(why));
        }
        row(f, "1 LSB", set(c, 1), no(why));
        row(f, "0", set(c, 0), no(why));
        let sign = if b == Bits::Q32 {
            "u64::MAX"
        } else {
            "negative"
        };
        row(f, sign, set(c, negated(b, v)), no(why));
        if b == Bits::Sample(1) {
            for (change, bits) in [
                ("the largest subnormal", 0x007F_FFFFu64),
                ("NaN", 0x7FC0_0000),
                ("infinity", 0x7F80_0000),
            ] {
                row(f, change, set(c, bits), no(why));
            }
        }
    }
    // A base rate carrying another rate's coefficients.
    let carrying = |hz, yd, td, r: Rates| {
        wr(Rates {
            base_rate_hz: hz,
            yaw_div: yd,
            traction_div: td,
            ..r
        })
    };
    let rates = "rates";
    let (r4k, r10k, r16k, r625) = (
        at(4_000, 1, 1)?,
        at(10_000, 1, 1)?,
        at(16_000, 1, 1)?,
        at(625, 1, 1)?,
    );
    for (change, config, why) in [
        (
            "4 kHz with the 5 kHz coefficients",
            carrying(4_000, 1, 1, good),
            R::Kappa,
        ),
        (
            "5 kHz with the 4 kHz coefficients",
            carrying(5_000, 1, 1, r4k),
            R::Kappa,
        ),
        (
            "5 kHz with the 10 kHz coefficients",
            carrying(5_000, 1, 1, r10k),
            R::Kappa,
        ),
        (
            "10 kHz with the 5 kHz coefficients",
            carrying(10_000, 1, 1, good),
            R::Kappa,
        ),
        (
            "20 kHz with the 16 kHz coefficients",
            carrying(20_000, 1, 1, r16k),
            R::Kappa,
        ),
        (
            "500 Hz with the 625 Hz coefficients",
            carrying(500, 1, 1, r625),
            R::Kappa,
        ),
        (
            "10 kHz / 2 / 1 with the 5 kHz coefficients (the yaw loop's match)",
            carrying(10_000, 2, 1, good),
            R::Ki,
        ),
        (
            "10 kHz / 2 / 2 with the 5 kHz coefficients (both loops' match)",
            carrying(10_000, 2, 2, good),
            R::AccGain,
        ),
    ] {
        row(rates, change, config, no(why));
    }
    // The switches, all taken by every build.
    let sw = "switches";
    row(
        sw,
        "wheel-slip protection on",
        Config { wsp: true, ..base },
        yes(true),
    );
    row(
        sw,
        "monitor_safe on",
        Config {
            monitor_safe: true,
            ..base
        },
        yes(false),
    );
    row(
        sw,
        "mode passive",
        Config {
            mode: YawMode::Passive,
            ..base
        },
        yes(true),
    );
    row(
        sw,
        "mode gain",
        Config {
            mode: YawMode::Gain,
            ..base
        },
        yes(true),
    );
    row(
        sw,
        "traction off",
        Config {
            traction: false,
            ..base
        },
        yes(true),
    );
    row(
        sw,
        "outputs off",
        Config {
            enable: false,
            ..base
        },
        yes(true),
    );
    // Nominal Configs at every plausible rate, as the host computes them.
    for (hz, yd, td) in nominal_rates() {
        let visible = (hz, yd, td) != (5_000, 1, 1);
        row(
            "nominal",
            "as rates_for computes them",
            wr(at(hz, yd, td)?),
            yes(visible),
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use wheelset_control::Fx;
    use wheelset_proto::FrameError;

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
                let mut dec: Decoder = Decoder::new();
                let (mut sensor, mut frame) = (Sensor::ZERO, Err(FrameError::Length));
                let (next, rest) =
                    dec.next_sensor_or_request(f.as_bytes(), &mut sensor, &mut frame);
                assert!(rest.is_empty(), "mode {m}");
                assert_eq!(next, wheelset_proto::NextFrame::Frame, "mode {m}");
                assert_eq!(frame, Ok(wheelset_proto::Request::Unknown), "mode {m}");
            }
        })
        .expect("the table");
        assert_eq!(found, 2);
    }
}
