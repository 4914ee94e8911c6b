//! The sample trait: the operations a filter needs, for `f64` (reference), `f32` and
//! [`Fx`] (Q4.28); signals per unit (`x_SI / FS`). Fixed point: coefficients Q1.31 in
//! `(-1, 1)`, sums saturating, products `(x c + 2^30) >> 31` ([`mul_q31`]), no overflow.

use fixed::types::{I1F31, I4F28};

mod fx;
#[cfg(test)]
mod tests;

pub use fx::{mul_q31, smmulr, FxScale};

/// The production fixed-point signal type: Q4.28 per unit (`[-8, 8)`, LSB `2^-28`).
pub type Fx = I4F28;
/// The production coefficient type: Q1.31 in `(-1, 1)`, so a product cannot overflow.
pub type Coef = I1F31;

/// Number of fractional bits of [`Fx`] signals.
pub const FX_FRAC: u32 = 28;
/// Number of fractional bits of [`Coef`] coefficients.
pub const COEF_FRAC: u32 = 31;

/// A per-unit sample: the operations the filters use (no allocation, division or panic).
pub trait Sample: Copy + Default + PartialEq + PartialOrd + core::fmt::Debug {
    /// Quantised coefficient (`Self` for floats, [`Coef`] Q1.31 for [`Fx`]).
    type Coeff: Copy + Default + core::fmt::Debug + PartialEq;
    /// An integrator's sub-LSB remainder (`()` for floats, `u64` for [`Fx`]).
    type Residue: Copy + Default + core::fmt::Debug + PartialEq;
    /// Precomputed wire-code scale (`Self` for floats, [`FxScale`] for [`Fx`]).
    type Scale: Copy + core::fmt::Debug + PartialEq;
    /// Zero.
    const ZERO: Self;
    /// Short type name for reports (`"f64"`, `"f32"`, `"Q4.28"`).
    const NAME: &'static str;
    /// Nearest representable value, saturating (construction time and host use).
    fn from_f64(x: f64) -> Self;
    /// The exact value as `f64`.
    fn to_f64(self) -> f64;
    /// Quantise a coefficient; `None` if it is not finite or out of the coefficient range.
    fn quantise(c: f64) -> Option<Self::Coeff>;
    /// A quantised coefficient's exact value.
    fn coeff_to_f64(c: Self::Coeff) -> f64;
    /// `self + rhs`, saturating.
    fn sat_add(self, rhs: Self) -> Self;
    /// `self - rhs`, saturating.
    fn sat_sub(self, rhs: Self) -> Self;
    /// `self * c`, rounded to nearest and saturating.
    fn mul_c(self, c: Self::Coeff) -> Self;
    /// The signal as a coefficient, saturated to the coefficient range (`Fx`: a shift).
    fn to_coeff_sat(self) -> Self::Coeff;
    /// `self^2`, pu^2, rounded and saturating.
    #[inline]
    fn square(self) -> Self {
        let x = self.to_f64();
        Self::from_f64(x * x)
    }
    /// `self * c` for an integrator's increment with error feedback: fixed point floors and
    /// carries the remainder in `r`, so the running sum is exact to one LSB; floats multiply.
    fn mul_c_acc(self, c: Self::Coeff, r: &mut Self::Residue) -> Self;
    /// The largest shift `s` holding every coefficient up to `c_max` as `c 2^s` (the PI's `Ki`),
    /// if any: floats 0, fixed point `1..=`[`Sample::ACC_SHIFT_MAX`].
    fn acc_shift(c_max: f64) -> Option<u32> {
        (c_max.is_finite() && c_max > 0.0).then_some(0)
    }
    /// The largest shift [`Sample::acc_shift`] gives (0: the type has no shift).
    const ACC_SHIFT_MAX: u32 = 0;
    /// Whether `s` is a shift [`Sample::acc_shift`] can give (floats: only 0).
    fn acc_shift_ok(s: u32) -> bool {
        s == 0
    }
    /// `self * c 2^-s` with [`Sample::mul_c_acc`]'s error feedback, `c` held as `c 2^s`:
    /// fixed point floors `(x c + r) / 2^(31+s)` and carries `31 + s` bits in `r`.
    #[inline(always)]
    fn mul_c_acc_shr(self, c: Self::Coeff, s: u32, r: &mut Self::Residue) -> Self {
        let _ = s;
        self.mul_c_acc(c, r)
    }
    /// `clamp(self, lo, hi)` and whether it clamped (`lo <= hi` assumed).
    #[inline(always)]
    fn limit(self, lo: Self, hi: Self) -> (Self, bool) {
        let y = if self < lo {
            lo
        } else if self > hi {
            hi
        } else {
            self
        };
        (y, y != self)
    }
    /// Replace NaN by zero (floats); reports whether it did. Identity for fixed point.
    fn sanitize(self) -> (Self, bool);
    /// Input scale: `factor` = per-unit value of one wire code.
    fn scale_in(factor: f64) -> Option<Self::Scale>;
    /// Output scale: `factor` = wire codes per per-unit.
    fn scale_out(factor: f64) -> Option<Self::Scale>;
    /// `code * scale` (saturating for fixed point).
    fn from_code(code: i32, scale: &Self::Scale) -> Self;
    /// `round(self * scale)` to a code, saturating at the `i32` range (NaN gives 0).
    fn to_code(self, scale: &Self::Scale) -> i32;

    // The fast path's operations: exactly the general operation's result under the stated condition.

    /// Two per unit (the range bound of the fast path's preconditions).
    #[inline(always)]
    fn two_pu() -> Self {
        Self::from_f64(2.0)
    }
    /// `|self| <= max` (`false` for NaN), `0 <= max <= 2` pu: `limit(-max, max)` would not engage.
    #[inline(always)]
    fn abs_within(self, max: Self) -> bool {
        let (x, bad) = self.sanitize();
        !bad && !x.limit(Self::ZERO.sat_sub(max), max).1
    }
    /// `lo <= self <= hi` (`false` for NaN): `limit(lo, hi)` would not engage.
    #[inline(always)]
    fn within(self, lo: Self, hi: Self) -> bool {
        let (x, bad) = self.sanitize();
        !bad && !x.limit(lo, hi).1
    }
    /// `c` in [`Sample::mul_pre`]'s form: fixed point `2c` for `|c| <= 0.5 - 2^-30`; floats `c`.
    #[inline(always)]
    fn pre_coeff(_c: Self::Coeff) -> Option<Self::Coeff> {
        None
    }
    /// `self * c` from `pc = pre_coeff(c)`, equal to [`Sample::mul_c`]`(c)`. Fixed point:
    /// `SMMULR(x, 2c) = (2 x c + 2^31) >> 32 = (x c + 2^30) >> 31`, one instruction.
    #[inline(always)]
    fn mul_pre(self, pc: Self::Coeff) -> Self {
        self.mul_c(pc)
    }
    /// `self * c`, equal to [`Sample::mul_c`] for `-4 <= self < 4` pu (fixed point `SMMULR(2x, c)`).
    #[inline(always)]
    fn mul_c_small(self, c: Self::Coeff) -> Self {
        self.mul_c(c)
    }

    /// [`crate::Controller::tick`], non-generic here so it gets this crate's opt-level.
    #[inline(always)]
    fn controller_tick(
        c: &mut crate::Controller<Self>,
        inp: &crate::Inputs<Self>,
    ) -> crate::Outputs<Self> {
        c.tick_impl(inp)
    }
}

/// Exact bit patterns of a [`Sample`]'s values, coefficients and scales (integer work).
pub trait SampleBits: Sample {
    /// The type's tag ([`crate::CompiledBits::numeric`]): 0 Q4.28 / Q1.31, 1 `f32`, 2 `f64`.
    const NUMERIC: u8;
    /// The largest magnitude of a clamp or limit, 2 pu ([`crate::config::MAX_LIMIT_PU`]).
    const MAX_LIMIT: Self;

    /// A signal's bit pattern (Q4.28 `i32` or IEEE bits), zero-extended to 64 bits.
    fn to_bits64(self) -> u64;
    /// A signal from its bit pattern; `None` for another width or a non-finite float.
    fn from_bits64(b: u64) -> Option<Self>;
    /// The exact bit pattern of a coefficient (Q1.31 `i32` bits; floats: IEEE bits).
    fn coeff_to_bits64(c: Self::Coeff) -> u64;
    /// A coefficient from its bit pattern; `None` if invalid (Q1.31 `-1`; non-finite floats).
    fn coeff_from_bits64(b: u64) -> Option<Self::Coeff>;
    /// `0 < c < 1` (`0 <= c < 1` with `zero_ok`).
    fn coeff_in_unit(c: Self::Coeff, zero_ok: bool) -> bool;
    /// The exact bits of a wire-code scale: `(mul, shift)` (floats: the IEEE bits, 0).
    fn scale_to_bits(s: &Self::Scale) -> (u64, u8);
    /// A scale from [`SampleBits::scale_to_bits`]'s bits; `None` if invalid.
    fn scale_from_bits(mul: u64, shift: u8) -> Option<Self::Scale>;
}

macro_rules! float_sample {
    ($t:ty, $bits:ty, $name:literal, $numeric:literal) => {
        impl Sample for $t {
            type Coeff = $t;
            type Scale = $t;
            type Residue = ();
            const ZERO: Self = 0.0;
            const NAME: &'static str = $name;
            #[inline]
            fn from_f64(x: f64) -> Self {
                x as $t
            }
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            fn quantise(c: f64) -> Option<$t> {
                Some(c as $t).filter(|q| q.is_finite())
            }
            fn coeff_to_f64(c: $t) -> f64 {
                c as f64
            }
            #[inline(always)]
            fn sat_add(self, rhs: Self) -> Self {
                self + rhs
            }
            #[inline(always)]
            fn sat_sub(self, rhs: Self) -> Self {
                self - rhs
            }
            #[inline(always)]
            fn mul_c(self, c: $t) -> Self {
                self * c
            }
            #[inline(always)]
            fn to_coeff_sat(self) -> $t {
                self
            }
            #[inline(always)]
            fn square(self) -> Self {
                self * self
            }
            #[inline(always)]
            fn mul_c_acc(self, c: $t, _r: &mut ()) -> Self {
                self * c
            }
            #[inline(always)]
            fn sanitize(self) -> (Self, bool) {
                #[allow(clippy::eq_op)]
                let ok = self == self;
                (if ok { self } else { 0.0 }, !ok)
            }
            fn scale_in(factor: f64) -> Option<$t> {
                Self::quantise(factor).filter(|q| *q > 0.0)
            }
            fn scale_out(factor: f64) -> Option<$t> {
                Self::scale_in(factor)
            }
            #[inline]
            fn from_code(code: i32, scale: &$t) -> Self {
                code as $t * *scale
            }
            #[inline]
            fn to_code(self, scale: &$t) -> i32 {
                let v = self * *scale;
                // `as` saturates at the i32 range and maps NaN to 0.
                (if v >= 0.0 { v + 0.5 } else { v - 0.5 }) as i32
            }
            #[inline(always)]
            fn two_pu() -> Self {
                2.0
            }
            #[inline(always)]
            fn abs_within(self, max: Self) -> bool {
                // `abs` is exact; NaN compares false.
                self.abs() <= max
            }
            #[inline(always)]
            fn within(self, lo: Self, hi: Self) -> bool {
                lo <= self && self <= hi
            }
            #[inline(always)]
            fn pre_coeff(c: $t) -> Option<$t> {
                Some(c)
            }
            #[inline(always)]
            fn mul_pre(self, pc: $t) -> Self {
                self * pc
            }
            #[inline(always)]
            fn mul_c_small(self, c: $t) -> Self {
                self * c
            }
            #[inline(never)]
            fn controller_tick(
                c: &mut crate::Controller<Self>,
                inp: &crate::Inputs<Self>,
            ) -> crate::Outputs<Self> {
                c.tick_impl(inp)
            }
        }

        impl SampleBits for $t {
            const NUMERIC: u8 = $numeric;
            const MAX_LIMIT: Self = 2.0;

            fn to_bits64(self) -> u64 {
                u64::from(self.to_bits())
            }
            fn from_bits64(b: u64) -> Option<Self> {
                Some(<$t>::from_bits(<$bits>::try_from(b).ok()?)).filter(|v| v.is_finite())
            }
            fn coeff_to_bits64(c: $t) -> u64 {
                c.to_bits64()
            }
            fn coeff_from_bits64(b: u64) -> Option<$t> {
                Self::from_bits64(b)
            }
            fn coeff_in_unit(c: $t, zero_ok: bool) -> bool {
                (c > 0.0 || (zero_ok && c == 0.0)) && c < 1.0
            }
            fn scale_to_bits(s: &$t) -> (u64, u8) {
                (s.to_bits64(), 0)
            }
            fn scale_from_bits(mul: u64, shift: u8) -> Option<$t> {
                Self::from_bits64(mul).filter(|s| *s > 0.0 && shift == 0)
            }
        }
    };
}

float_sample!(f64, u64, "f64", 2);
float_sample!(f32, u32, "f32", 1);
