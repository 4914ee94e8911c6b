//! A fixed-point sample type whose Q formats are chosen at run time, for the audit's
//! "what if" runs (a narrower or wider format) and its saturation counting.
//!
//! [`QDyn`] holds a signal as an integer `raw` with value `raw 2^-F` in a word of `W =
//! I + F` bits (`I` integer bits including the sign: range `[-2^(I-1), 2^(I-1))`);
//! [`QCoef`] a coefficient likewise in its own format. The arithmetic is the
//! production [`wheelset_control::Fx`]'s, generalised:
//!
//! ```text
//! a + b, a - b      saturated to the signal word           (counted)
//! x c               (x c + 2^(Fc-1)) >> Fc, saturated        (counted)
//! quantise(c)       round-to-nearest-even(c 2^Fc); refused outside (-2^(Ic-1), 2^(Ic-1))
//! from_f64(x)       round-to-nearest-even(x 2^F), saturated (counted)
//! ```
//!
//! With [`Formats::PRODUCTION`] (signals Q4.28, coefficients Q1.31) this is bit-identical
//! to [`wheelset_control::Fx`] (a test checks it on random sequences), so the audit can
//! count the saturations that the production type performs silently.
//!
//! The formats live in a thread-local, set for the duration of a closure by
//! [`with_formats`]: construct *and* run the filters inside the same call. Word lengths
//! are limited to 32 bits (signal and coefficient), so every product fits an `i64`.

use std::cell::Cell;

use serde::Serialize;
use wheelset_control::Sample;

/// A Q format `Qi.f`: `int_bits` (including the sign) and `frac_bits`; word `i + f`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct QFormat {
    /// Integer bits including the sign bit.
    pub int_bits: u32,
    /// Fractional bits.
    pub frac_bits: u32,
}

impl QFormat {
    /// `Qi.f`.
    pub const fn new(int_bits: u32, frac_bits: u32) -> Self {
        Self {
            int_bits,
            frac_bits,
        }
    }
    /// Word length `i + f`, bits.
    pub fn word(&self) -> u32 {
        self.int_bits + self.frac_bits
    }
    /// One LSB, `2^-f`.
    pub fn lsb(&self) -> f64 {
        (-(self.frac_bits as f64)).exp2()
    }
    /// Largest magnitude representable, `2^(i-1)` (the positive end is one LSB less).
    pub fn range(&self) -> f64 {
        ((self.int_bits as f64) - 1.0).exp2()
    }
    fn raw_max(&self) -> i64 {
        (1i64 << (self.word() - 1)) - 1
    }
    fn raw_min(&self) -> i64 {
        -(1i64 << (self.word() - 1))
    }
    /// Parse `"4.28"` or `"Q4.28"`: word 2..=32 bits, at least one integer (sign) bit.
    pub fn parse(s: &str) -> Result<Self, String> {
        let t = s.trim().trim_start_matches(['Q', 'q']);
        let (i, f) = t
            .split_once('.')
            .ok_or_else(|| format!("`{s}`: expected a Q format `I.F`, e.g. `4.28`"))?;
        let i: u32 = i
            .parse()
            .map_err(|_| format!("`{s}`: integer bits `{i}` is not a number"))?;
        let f: u32 = f
            .parse()
            .map_err(|_| format!("`{s}`: fraction bits `{f}` is not a number"))?;
        if i == 0 || i + f > 32 || i + f < 2 {
            return Err(format!(
                "`{s}`: need at least 1 integer (sign) bit and a word of 2..=32 bits"
            ));
        }
        Ok(Self::new(i, f))
    }
}

impl core::fmt::Display for QFormat {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "Q{}.{}", self.int_bits, self.frac_bits)
    }
}

/// The signal and coefficient formats of one fixed-point build.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
pub struct Formats {
    /// Every signal and state (per unit).
    pub signal: QFormat,
    /// Every coefficient.
    pub coef: QFormat,
}

impl Formats {
    /// The production build ([`wheelset_control::Fx`], [`wheelset_control::Coef`]).
    pub const PRODUCTION: Formats = Formats {
        signal: QFormat::new(4, 28),
        coef: QFormat::new(1, 31),
    };
}

thread_local! {
    static FORMATS: Cell<Formats> = const { Cell::new(Formats::PRODUCTION) };
    static SATURATIONS: Cell<u64> = const { Cell::new(0) };
}

/// Run `body` with `f` as the [`QDyn`]/[`QCoef`] formats of this thread (restored after).
pub fn with_formats<R>(f: Formats, body: impl FnOnce() -> R) -> R {
    let old = FORMATS.with(|c| c.replace(f));
    let r = body();
    FORMATS.with(|c| c.set(old));
    r
}

/// The formats in force on this thread.
pub fn formats() -> Formats {
    FORMATS.with(|c| c.get())
}

/// Saturations performed by [`QDyn`] arithmetic on this thread since the last call
/// (the counter is reset).
pub fn take_saturations() -> u64 {
    SATURATIONS.with(|c| c.replace(0))
}

fn sat(raw: i64, f: &QFormat) -> i64 {
    let (lo, hi) = (f.raw_min(), f.raw_max());
    if raw > hi || raw < lo {
        SATURATIONS.with(|c| c.set(c.get() + 1));
        raw.clamp(lo, hi)
    } else {
        raw
    }
}

/// Scale by `2^e` exactly (a power of two, no rounding for these ranges).
fn pow2(e: i32) -> f64 {
    (e as f64).exp2()
}

/// A signal in the run-time signal format (see the module docs).
#[derive(Clone, Copy, Debug, Default, PartialEq, PartialOrd)]
pub struct QDyn(pub i64);

/// A coefficient in the run-time coefficient format.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct QCoef(pub i64);

impl Sample for QDyn {
    type Coeff = QCoef;
    type Scale = f64;
    type Residue = i64;
    const ZERO: Self = QDyn(0);
    const NAME: &'static str = "QDyn";

    fn from_f64(x: f64) -> Self {
        if !x.is_finite() {
            return if x.is_nan() {
                QDyn(0)
            } else {
                let f = formats().signal;
                QDyn(sat(if x > 0.0 { i64::MAX } else { i64::MIN }, &f))
            };
        }
        let f = formats().signal;
        let r = (x * pow2(f.frac_bits as i32)).round_ties_even();
        let r = r.clamp(-9.0e18, 9.0e18) as i64;
        QDyn(sat(r, &f))
    }
    fn to_f64(self) -> f64 {
        self.0 as f64 * pow2(-(formats().signal.frac_bits as i32))
    }
    fn quantise(c: f64) -> Option<QCoef> {
        let f = formats().coef;
        if !c.is_finite() {
            return None;
        }
        let r = (c * pow2(f.frac_bits as i32)).round_ties_even();
        // Strictly inside (-2^(i-1), 2^(i-1)), like the production `Coef`.
        if r > f.raw_max() as f64 || r <= f.raw_min() as f64 {
            return None;
        }
        Some(QCoef(r as i64))
    }
    fn coeff_to_f64(c: QCoef) -> f64 {
        c.0 as f64 * pow2(-(formats().coef.frac_bits as i32))
    }
    fn sat_add(self, rhs: Self) -> Self {
        QDyn(sat(self.0 + rhs.0, &formats().signal))
    }
    fn sat_sub(self, rhs: Self) -> Self {
        QDyn(sat(self.0 - rhs.0, &formats().signal))
    }
    fn mul_c(self, c: QCoef) -> Self {
        let fm = formats();
        let cf = fm.coef.frac_bits;
        let half = if cf == 0 { 0 } else { 1i64 << (cf - 1) };
        QDyn(sat((self.0 * c.0 + half) >> cf, &fm.signal))
    }
    /// Mirrors `Fx::to_coeff_sat`: the signal in the coefficient format, saturated to
    /// its range strictly (as `quantise`).
    fn to_coeff_sat(self) -> QCoef {
        let fm = formats();
        let (sf, cf) = (fm.signal.frac_bits, fm.coef.frac_bits);
        let raw = if cf >= sf {
            self.0.saturating_mul(1i64 << (cf - sf).min(62))
        } else {
            self.0 >> (sf - cf)
        };
        QCoef(raw.clamp(fm.coef.raw_min() + 1, fm.coef.raw_max()))
    }
    /// Mirrors `Fx::mul_c_acc`: floor with the remainder carried (error feedback).
    fn mul_c_acc(self, c: QCoef, r: &mut i64) -> Self {
        self.mul_c_acc_shr(c, 0, r)
    }
    const ACC_SHIFT_MAX: u32 = 30;
    /// Mirrors `Fx::acc_shift`: the largest `s` in `1..=30` with `c_max 2^s` still a
    /// coefficient of the run-time format.
    fn acc_shift(c_max: f64) -> Option<u32> {
        if !(c_max.is_finite() && c_max > 0.0) {
            return None;
        }
        let fits = |s: &u32| Self::quantise(c_max * pow2(*s as i32)).is_some();
        (1..=Self::ACC_SHIFT_MAX).take_while(fits).last()
    }
    fn acc_shift_ok(s: u32) -> bool {
        (1..=Self::ACC_SHIFT_MAX).contains(&s)
    }
    /// Mirrors `Fx::mul_c_acc_shr`: `floor((x c + r) / 2^(Fc+s))` with the remainder
    /// carried (`mul_c_acc` at `s = 0`).
    fn mul_c_acc_shr(self, c: QCoef, s: u32, r: &mut i64) -> Self {
        let fm = formats();
        let k = fm.coef.frac_bits + s;
        let p = self.0 as i128 * c.0 as i128 + *r as i128;
        *r = (p & ((1i128 << k) - 1)) as i64;
        let q = (p >> k).clamp(i64::MIN as i128, i64::MAX as i128) as i64;
        QDyn(sat(q, &fm.signal))
    }
    fn sanitize(self) -> (Self, bool) {
        (self, false)
    }
    fn scale_in(factor: f64) -> Option<f64> {
        (factor.is_finite() && factor > 0.0).then_some(factor)
    }
    fn scale_out(factor: f64) -> Option<f64> {
        Self::scale_in(factor)
    }
    /// Wire codes through f64 (the audit feeds per-unit samples, not codes).
    fn from_code(code: i32, scale: &f64) -> Self {
        Self::from_f64(code as f64 * scale)
    }
    fn to_code(self, scale: &f64) -> i32 {
        (self.to_f64() * scale).round() as i32
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_and_ranges() {
        let q = QFormat::parse("Q4.28").expect("valid");
        assert_eq!(q, QFormat::new(4, 28));
        assert_eq!(q.range(), 8.0);
        assert_eq!(q.lsb(), 2f64.powi(-28));
        assert!(QFormat::parse("0.8").is_err());
        assert!(QFormat::parse("20.20").is_err());
        assert!(QFormat::parse("x").is_err());
    }

    #[test]
    fn saturation_is_counted() {
        with_formats(
            Formats {
                signal: QFormat::new(2, 6),
                coef: QFormat::new(1, 7),
            },
            || {
                take_saturations();
                let a = QDyn::from_f64(1.5);
                let b = a.sat_add(a);
                assert_eq!(b.to_f64(), 2.0 - 1.0 / 64.0);
                assert_eq!(take_saturations(), 1);
                assert!(QDyn::quantise(1.0).is_none());
                assert!(QDyn::quantise(-1.0).is_none());
                assert_eq!(QDyn::coeff_to_f64(QDyn::quantise(0.5).expect("fits")), 0.5);
            },
        );
    }
}
