//! The sample trait: the few operations a filter needs, for `f64`, `f32` and fixed point.
//!
//! Every signal inside the controller is **per unit** (`x_pu = x_SI / FS`, the full
//! scales are in [`crate::FullScales`]), so one sample type serves every signal.
//!
//! - `f64`: the reference. `f32`: the FPU build. [`Fx`] (= `fixed::types::I4F28`,
//!   Q4.28, range `[-8, 8)` pu, LSB `2^-28` = 3.7e-9 pu): the production build.
//! - Coefficients are quantised once, at construction ([`Sample::quantise`]); for
//!   [`Fx`] they are Q1.31 ([`Coef`], validated into `(-1, 1)`, LSB `2^-31` = 4.7e-10).
//! - Fixed-point sums and differences saturate (`QADD`/`QSUB` on Cortex-M4); a product
//!   is the exact 64-bit `i32 x i32` product rounded to nearest (ties up),
//!   `y = (x c + 2^30) >> 31` ([`mul_q31`]), which cannot overflow because `|c| < 1`.
//!   The range analysis in the crate docs shows the saturations cannot engage inside
//!   the filters once the inputs are clamped; they are the belt, the input clamps
//!   (counted) are the braces.

use fixed::types::{I1F31, I4F28};

/// The production fixed-point signal type: Q4.28 per unit (`[-8, 8)`, LSB `2^-28`).
pub type Fx = I4F28;
/// The production fixed-point coefficient type: Q1.31, validated into `(-1, 1)`
/// (LSB `2^-31`), so that a product with a Q4.28 signal cannot overflow.
pub type Coef = I1F31;

/// Number of fractional bits of [`Fx`] signals.
pub const FX_FRAC: u32 = 28;
/// Number of fractional bits of [`Coef`] coefficients.
pub const COEF_FRAC: u32 = 31;

/// A wire-code scale for the fixed-point type, precomputed at construction:
/// `out = sat32((in * mul + round) >> shift)`, i.e. a multiplication by `mul / 2^shift`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FxScale {
    /// Multiplier (positive, `< 2^31`).
    pub mul: i32,
    /// Right shift, `0..=62`.
    pub shift: u32,
    /// `2^(shift-1)` (0 for `shift == 0`): rounds to nearest.
    pub round: i64,
}

impl FxScale {
    /// The scale closest to `factor` with the most precision: the largest `shift` such
    /// that `round(factor 2^shift) < 2^31`. `None` if `factor` is not finite, not
    /// positive, `>= 2^31`, or smaller than `2^-40` (no useful precision left).
    pub fn new(factor: f64) -> Option<Self> {
        if !(1e-12..2_147_483_647.0).contains(&factor) {
            return None;
        }
        let mut shift = 0u32;
        let mut scaled = factor;
        while shift < 62 && scaled * 2.0 < 2_147_483_647.0 {
            scaled *= 2.0;
            shift += 1;
        }
        let mul = round_f64(scaled);
        if !(1.0..2_147_483_648.0).contains(&mul) || mul < 1024.0 {
            return None;
        }
        Some(Self {
            mul: mul as i32,
            shift,
            round: if shift == 0 { 0 } else { 1i64 << (shift - 1) },
        })
    }

    /// The scale `mul / 2^shift` from its parts, as [`Self::new`] produces them: `None`
    /// unless `mul` is in `[1024, 2^31)` and `shift <= 62`. Integer work only.
    pub fn from_bits(mul: u64, shift: u8) -> Option<Self> {
        let shift = u32::from(shift);
        if !(1024..(1u64 << 31)).contains(&mul) || shift > 62 {
            return None;
        }
        Some(Self {
            mul: mul as i32,
            shift,
            round: if shift == 0 { 0 } else { 1i64 << (shift - 1) },
        })
    }

    /// `sat32((x * mul + round) >> shift)`.
    ///
    /// Without a 64-bit shift by a variable amount (on a 32-bit core a library call,
    /// `__aeabi_lasr`, ~11 instructions): the product is one `SMLAL` into `(hi, lo)`;
    /// `shift >= 32` (the output scales) is `hi >> (shift - 32)`, which always fits; a
    /// shorter shift (the input scales) combines the words and saturates when the high
    /// word is not the sign extension of the result.
    #[inline]
    pub fn apply(&self, x: i32) -> i32 {
        let p = x as i64 * self.mul as i64 + self.round;
        let (hi, lo) = ((p >> 32) as i32, p as u32);
        let s = self.shift;
        if s >= 32 {
            // |p| < 2^62, so `p >> s` is within `i32` (no saturation can engage).
            hi >> (s - 32).min(31)
        } else if s == 0 {
            sat32(p)
        } else {
            let q = ((lo >> s) | ((hi as u32) << (32 - s))) as i32;
            if hi >> s == q >> 31 {
                q
            } else if hi < 0 {
                i32::MIN
            } else {
                i32::MAX
            }
        }
    }

    /// The factor this scale really applies, `mul / 2^shift`.
    pub fn factor(&self) -> f64 {
        let mut f = self.mul as f64;
        for _ in 0..self.shift {
            f *= 0.5;
        }
        f
    }
}

/// Round half away from zero in `no_std` (construction-time only).
pub(crate) fn round_f64(x: f64) -> f64 {
    let t = x as i64 as f64; // truncation; |x| < 2^63 at every call site
    let d = x - t;
    if d >= 0.5 {
        t + 1.0
    } else if d <= -0.5 {
        t - 1.0
    } else {
        t
    }
}

/// Saturate an `i64` to `i32`.
#[inline(always)]
pub(crate) fn sat32(x: i64) -> i32 {
    if x > i32::MAX as i64 {
        i32::MAX
    } else if x < i32::MIN as i64 {
        i32::MIN
    } else {
        x as i32
    }
}

/// `(x c + 2^30) >> 31`: the Q4.28 x Q1.31 product, rounded to nearest (ties up).
///
/// Never overflows, so needs no saturation: `|x| <= 2^31` and `|c| <= 2^31 - 1` (a
/// [`Coef`] is validated into `(-1, 1)` by [`Sample::quantise`]) give
/// `|x c + 2^30| < 2^62`, so the shifted result lies in `[-2^31, 2^31 - 1]`. Cortex-M4:
/// `SMLAL` + two ALU instructions.
#[inline(always)]
pub fn mul_q31(x: i32, c: i32) -> i32 {
    ((x as i64 * c as i64 + (1 << (COEF_FRAC - 1))) >> COEF_FRAC) as i32
}

/// `(a b + 2^31) >> 32`, the high word of the product rounded (Cortex-M4: `SMMULR`).
/// With `a = 2x` (or `b = 2c`) it is [`mul_q31`]`(x, c)` exactly:
/// `(2 x c + 2^31) >> 32 = (x c + 2^30) >> 31`.
#[inline(always)]
pub fn smmulr(a: i32, b: i32) -> i32 {
    ((a as i64 * b as i64 + (1 << 31)) >> 32) as i32
}

/// A per-unit sample: the operations the filters use. One filter implementation serves
/// every type (idsp style); nothing here allocates, divides or panics.
pub trait Sample: Copy + Default + PartialEq + PartialOrd + core::fmt::Debug {
    /// Quantised coefficient (`Self` for floats, [`Coef`] Q1.31 for [`Fx`]).
    type Coeff: Copy + core::fmt::Debug + PartialEq;
    /// An integrator's sub-LSB remainder (`()` for floats, `u32` for [`Fx`]).
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
    /// `self^2` (a signal squared, pu^2), rounded to nearest and saturating: the
    /// stability monitor's mean square ([`crate::monitor`]). The default goes through
    /// `f64`; `f32`, `f64` and [`Fx`] (the exact 64-bit product) override it.
    #[inline]
    fn square(self) -> Self {
        let x = self.to_f64();
        Self::from_f64(x * x)
    }
    /// `self * c` for an integrator's increment, with first-order error feedback: fixed
    /// point floors the product and carries the remainder in `r` to the next call, so
    /// the running sum of increments is exact to one LSB (no dead band, no drift from a
    /// rounding bias); floats just multiply.
    fn mul_c_acc(self, c: Self::Coeff, r: &mut Self::Residue) -> Self;
    /// `clamp(self, lo, hi)` and whether it clamped (`lo <= hi` assumed).
    fn limit(self, lo: Self, hi: Self) -> (Self, bool);
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

    // The fast path's operations ([`crate::Controller::tick`]): each gives exactly the
    // result of the general operation it stands for, under the condition stated. The
    // defaults are the general operations themselves, and `pre_coeff` `None`, which
    // keeps a type without its own versions on the general path.

    /// Two per unit (the range bound of the fast path's preconditions).
    #[inline(always)]
    fn two_pu() -> Self {
        Self::from_f64(2.0)
    }
    /// `|self| <= max` (`false` for NaN): the clamp `limit(-max, max)` would not engage
    /// (`0 <= max <= 2` pu).
    #[inline(always)]
    fn abs_within(self, max: Self) -> bool {
        let (x, bad) = self.sanitize();
        !bad && !x.limit(Self::ZERO.sat_sub(max), max).1
    }
    /// `lo <= self <= hi` (`false` for NaN): `limit(lo, hi)` would not engage
    /// (`lo <= hi`).
    #[inline(always)]
    fn within(self, lo: Self, hi: Self) -> bool {
        let (x, bad) = self.sanitize();
        !bad && !x.limit(lo, hi).1
    }
    /// `c` in the form [`Sample::mul_pre`] takes, if it has one: fixed point `2c`,
    /// for `|c| <= 0.5 - 2^-30` (so `2c` is a Q1.31 coefficient, and a product with
    /// `|x| <= 4` pu stays below 2 pu by at least one LSB); floats `c` itself.
    #[inline(always)]
    fn pre_coeff(_c: Self::Coeff) -> Option<Self::Coeff> {
        None
    }
    /// `self * c` from `pc = pre_coeff(c)`: the same value as [`Sample::mul_c`]`(c)`.
    /// Fixed point: `SMMULR(x, 2c) = (2 x c + 2^31) >> 32 = (x c + 2^30) >> 31` (one
    /// instruction instead of five).
    #[inline(always)]
    fn mul_pre(self, pc: Self::Coeff) -> Self {
        self.mul_c(pc)
    }
    /// `self * c`, the same value as [`Sample::mul_c`] when `-4 <= self < 4` pu (fixed
    /// point: `SMMULR(2x, c)`, two instructions; `2x` does not overflow in that range).
    #[inline(always)]
    fn mul_c_small(self, c: Self::Coeff) -> Self {
        self.mul_c(c)
    }

    /// [`crate::Controller::tick`] for this type: the production types implement it as
    /// a non-generic function of this crate, so it is compiled with this crate's
    /// optimisation level (the `fw` profile gives it `s`: see the workspace
    /// `Cargo.toml`), not the caller's.
    #[inline(always)]
    fn controller_tick(
        c: &mut crate::Controller<Self>,
        inp: &crate::Inputs<Self>,
    ) -> crate::Outputs<Self> {
        c.tick_impl(inp)
    }
}

/// Exact bit patterns of a [`Sample`]'s values, coefficients and scales: how a compiled
/// controller is written as constants and sent over the wire ([`crate::CompiledBits`]).
/// Conversions are integer work only (no float maths on the device).
pub trait SampleBits: Sample {
    /// The type's tag in exact bit patterns ([`crate::CompiledBits::numeric`]): 0 Q4.28 /
    /// Q1.31, 1 `f32`, 2 `f64`.
    const NUMERIC: u8;
    /// The largest per-unit magnitude of a clamp or limit, 2 pu
    /// ([`crate::config::MAX_LIMIT_PU`], the Q4.28 range analysis).
    const MAX_LIMIT: Self;
    /// The zero coefficient.
    const COEFF_ZERO: Self::Coeff;

    /// The exact bit pattern of a signal value (Q4.28: the `i32` bits; floats: IEEE bits),
    /// zero-extended to 64 bits.
    fn to_bits64(self) -> u64;
    /// A signal value from its bit pattern; `None` for a pattern of another width or a
    /// non-finite float. Integer work only.
    fn from_bits64(b: u64) -> Option<Self>;
    /// The exact bit pattern of a coefficient (Q1.31 `i32` bits; floats: IEEE bits).
    fn coeff_to_bits64(c: Self::Coeff) -> u64;
    /// A coefficient from its bit pattern; `None` if it is not a valid coefficient (Q1.31:
    /// `-1` itself, which [`Sample::quantise`] never produces; floats: not finite).
    fn coeff_from_bits64(b: u64) -> Option<Self::Coeff>;
    /// `0 < c < 1` (`0 <= c < 1` with `zero_ok`).
    fn coeff_in_unit(c: Self::Coeff, zero_ok: bool) -> bool;
    /// The exact bits of a wire-code scale: `(mul, shift)` (floats: the IEEE bits, 0).
    fn scale_to_bits(s: &Self::Scale) -> (u64, u8);
    /// A wire-code scale from [`Sample::scale_to_bits`]'s bits; `None` if invalid (fixed
    /// point: `mul` in `[1024, 2^31)`, `shift <= 62`; floats: finite and positive).
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
                let q = c as $t;
                if q.is_finite() {
                    Some(q)
                } else {
                    None
                }
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
            fn square(self) -> Self {
                self * self
            }
            #[inline(always)]
            fn mul_c_acc(self, c: $t, _r: &mut ()) -> Self {
                self * c
            }
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
            #[inline(always)]
            fn sanitize(self) -> (Self, bool) {
                #[allow(clippy::eq_op)]
                let ok = self == self;
                (if ok { self } else { 0.0 }, !ok)
            }
            fn scale_in(factor: f64) -> Option<$t> {
                let q = factor as $t;
                if q.is_finite() && q > 0.0 {
                    Some(q)
                } else {
                    None
                }
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
            const COEFF_ZERO: $t = 0.0;

            fn to_bits64(self) -> u64 {
                u64::from(self.to_bits())
            }
            fn from_bits64(b: u64) -> Option<Self> {
                let v = <$t>::from_bits(<$bits>::try_from(b).ok()?);
                if v.is_finite() {
                    Some(v)
                } else {
                    None
                }
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

impl Sample for Fx {
    type Coeff = Coef;
    type Scale = FxScale;
    type Residue = u32;
    const ZERO: Self = Fx::ZERO;
    const NAME: &'static str = "Q4.28";
    fn from_f64(x: f64) -> Self {
        // `saturating_from_num` panics on NaN: a NaN is no value, so it becomes 0
        // (callers that care count it as invalid before converting).
        if x.is_nan() {
            Fx::ZERO
        } else {
            Fx::saturating_from_num(x)
        }
    }
    fn to_f64(self) -> f64 {
        self.to_bits() as f64 / (1u64 << FX_FRAC) as f64
    }
    fn quantise(c: f64) -> Option<Coef> {
        // (-1, 1) strictly: keeps `mul_q31` free of overflow (see there).
        Coef::checked_from_num(c).filter(|q| *q != Coef::MIN)
    }
    fn coeff_to_f64(c: Coef) -> f64 {
        c.to_bits() as f64 / (1u64 << COEF_FRAC) as f64
    }
    #[inline(always)]
    fn sat_add(self, rhs: Self) -> Self {
        self.saturating_add(rhs)
    }
    #[inline(always)]
    fn sat_sub(self, rhs: Self) -> Self {
        self.saturating_sub(rhs)
    }
    #[inline(always)]
    fn mul_c(self, c: Coef) -> Self {
        Fx::from_bits(mul_q31(self.to_bits(), c.to_bits()))
    }
    #[inline(always)]
    fn square(self) -> Self {
        // Q4.28 x Q4.28 = Q8.56, rounded to Q4.28 and saturated (|x| >= 2.83 pu).
        let x = i64::from(self.to_bits());
        Fx::from_bits(sat32((x * x + (1 << (FX_FRAC - 1))) >> FX_FRAC))
    }
    #[inline(always)]
    fn mul_c_acc(self, c: Coef, r: &mut u32) -> Self {
        // p = x c + r (one SMLAL); floor to Q4.28 and keep the low 31 bits as the
        // remainder. No overflow: |x c| < 2^62 (|x| <= 2^31, |c| < 2^31) and
        // 0 <= r < 2^31, so p >> 31 lies in [-2^31, 2^31).
        let p = self.to_bits() as i64 * c.to_bits() as i64 + *r as i64;
        *r = (p & ((1 << COEF_FRAC) - 1)) as u32;
        Fx::from_bits((p >> COEF_FRAC) as i32)
    }
    #[inline(always)]
    fn limit(self, lo: Self, hi: Self) -> (Self, bool) {
        let y = self.max(lo).min(hi);
        (y, y != self)
    }
    #[inline(always)]
    fn sanitize(self) -> (Self, bool) {
        (self, false)
    }
    fn scale_in(factor: f64) -> Option<FxScale> {
        // Codes -> bits: factor (pu per code) * 2^28 bits per pu.
        FxScale::new(factor * (1u64 << FX_FRAC) as f64)
    }
    fn scale_out(factor: f64) -> Option<FxScale> {
        // Bits -> codes: factor (codes per pu) / 2^28 bits per pu.
        FxScale::new(factor / (1u64 << FX_FRAC) as f64)
    }
    #[inline]
    fn from_code(code: i32, scale: &FxScale) -> Self {
        Fx::from_bits(scale.apply(code))
    }
    #[inline]
    fn to_code(self, scale: &FxScale) -> i32 {
        scale.apply(self.to_bits())
    }
    #[inline(always)]
    fn two_pu() -> Self {
        Fx::from_bits(2 << FX_FRAC)
    }
    #[inline(always)]
    fn abs_within(self, max: Self) -> bool {
        // One unsigned compare (`ADD`, `CMP ..., LSL #1`): `x + max` in `[0, 2 max]`
        // (for `0 <= max < 2^30`, which every limit is; below `-max` or above `max`
        // it wraps or lands beyond `2 max`).
        let m = max.to_bits();
        (self.to_bits().wrapping_add(m) as u32) <= (m as u32) << 1
    }
    #[inline(always)]
    fn within(self, lo: Self, hi: Self) -> bool {
        // `x - lo` in `[0, hi - lo]`, unsigned (for `lo <= hi`).
        let l = lo.to_bits();
        (self.to_bits().wrapping_sub(l) as u32) <= (hi.to_bits().wrapping_sub(l) as u32)
    }
    #[inline(always)]
    fn pre_coeff(c: Coef) -> Option<Coef> {
        let b = c.to_bits();
        (b.unsigned_abs() <= (1 << 30) - 2).then(|| Coef::from_bits(2 * b))
    }
    #[inline(always)]
    fn mul_pre(self, pc: Coef) -> Self {
        Fx::from_bits(smmulr(self.to_bits(), pc.to_bits()))
    }
    #[inline(always)]
    fn mul_c_small(self, c: Coef) -> Self {
        Fx::from_bits(smmulr(self.to_bits().wrapping_shl(1), c.to_bits()))
    }
    #[inline(never)]
    fn controller_tick(
        c: &mut crate::Controller<Self>,
        inp: &crate::Inputs<Self>,
    ) -> crate::Outputs<Self> {
        c.tick_impl(inp)
    }
}

impl SampleBits for Fx {
    const NUMERIC: u8 = 0;
    const MAX_LIMIT: Self = Fx::from_bits(2 << FX_FRAC);
    const COEFF_ZERO: Coef = Coef::ZERO;

    fn to_bits64(self) -> u64 {
        u64::from(self.to_bits() as u32)
    }
    fn from_bits64(b: u64) -> Option<Self> {
        Some(Fx::from_bits(u32::try_from(b).ok()? as i32))
    }
    fn coeff_to_bits64(c: Coef) -> u64 {
        u64::from(c.to_bits() as u32)
    }
    fn coeff_from_bits64(b: u64) -> Option<Coef> {
        // (-1, 1) strictly, as `quantise` (keeps `mul_q31` free of overflow).
        Some(Coef::from_bits(u32::try_from(b).ok()? as i32)).filter(|q| *q != Coef::MIN)
    }
    fn coeff_in_unit(c: Coef, zero_ok: bool) -> bool {
        // Below 1 by the format.
        c > Coef::ZERO || (zero_ok && c == Coef::ZERO)
    }
    fn scale_to_bits(s: &FxScale) -> (u64, u8) {
        (u64::from(s.mul as u32), s.shift as u8)
    }
    fn scale_from_bits(mul: u64, shift: u8) -> Option<FxScale> {
        FxScale::from_bits(mul, shift)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fixed_mul_rounds_to_nearest() {
        let half = Coef::from_num(0.5);
        // 3 LSB * 0.5 = 1.5 LSB -> 2 (ties up); -3 LSB * 0.5 = -1.5 -> -1 (ties up).
        assert_eq!(Fx::from_bits(3).mul_c(half).to_bits(), 2);
        assert_eq!(Fx::from_bits(-3).mul_c(half).to_bits(), -1);
        assert!(Fx::quantise(-1.0).is_none() && Fx::quantise(1.0).is_none());
        assert!(Fx::quantise(0.999_999_999).is_some());
    }

    #[test]
    fn mul_q31_never_overflows_for_valid_coefficients() {
        let reference = |x: i32, c: i32| (x as i128 * c as i128 + (1 << 30)) >> 31;
        let cmax = i32::MAX;
        let edges = [
            i32::MIN,
            i32::MIN + 1,
            -(1 << 30),
            -3,
            -1,
            0,
            1,
            3,
            1 << 30,
            i32::MAX,
        ];
        for &x in &edges {
            for &c in &[-cmax, -cmax + 1, -1, 0, 1, cmax - 1, cmax] {
                let r = reference(x, c);
                assert!(r >= i32::MIN as i128 && r <= i32::MAX as i128, "{x} {c}");
                assert_eq!(mul_q31(x, c) as i128, r, "{x} {c}");
            }
        }
        let mut s = 0x2545_f491_4f6c_dd1du64;
        for _ in 0..200_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let (x, c) = (s as i32, ((s >> 32) as i32).max(-cmax));
            assert_eq!(mul_q31(x, c) as i128, reference(x, c), "{x} {c}");
        }
    }

    /// `apply` without the 64-bit variable shift is the plain formula, bit for bit, for
    /// every shift and at the edges of `x` and `mul` (saturation both ways included).
    #[test]
    fn fx_scale_apply_is_the_formula() {
        let reference = |x: i32, f: &FxScale| sat32((x as i64 * f.mul as i64 + f.round) >> f.shift);
        let xs = [
            i32::MIN,
            i32::MIN + 1,
            -(1 << 30),
            -12345,
            -1,
            0,
            1,
            7,
            1 << 30,
            i32::MAX,
        ];
        let muls = [1024u64, 1025, 268_435_456, (1 << 31) - 1];
        let mut seed = 0x9E37_79B9_7F4A_7C15u64;
        for shift in 0..=62u8 {
            for &m in &muls {
                let f = FxScale::from_bits(m, shift).expect("valid");
                for &x in &xs {
                    assert_eq!(f.apply(x), reference(x, &f), "{x} {m} {shift}");
                }
                for _ in 0..2000 {
                    seed ^= seed << 13;
                    seed ^= seed >> 7;
                    seed ^= seed << 17;
                    let x = seed as i32 >> (seed >> 59);
                    let f = FxScale::from_bits(1024 + (seed >> 33) % ((1 << 31) - 1024), shift)
                        .expect("valid");
                    assert_eq!(f.apply(x), reference(x, &f), "{x} {f:?}");
                }
            }
        }
    }

    #[test]
    fn fx_scale_is_accurate() {
        for f in [1e-6 * 268_435_456.0, 0.037_252_902_984, 1.0, 3.3e5, 7.0e-9] {
            let s = FxScale::new(f).expect("representable");
            assert!((s.factor() / f - 1.0).abs() < 1e-6, "{f}: {s:?}");
        }
        assert!(FxScale::new(f64::NAN).is_none());
        assert!(FxScale::new(-1.0).is_none());
        assert!(FxScale::new(3e9).is_none());
        let s = FxScale::new(1000.0).expect("ok");
        assert_eq!(s.apply(i32::MAX), i32::MAX);
        assert_eq!(s.apply(i32::MIN), i32::MIN);
        assert_eq!(s.apply(-7), -7000);
    }

    #[test]
    fn float_sanitize_and_codes() {
        assert_eq!(f32::NAN.sanitize(), (0.0, true));
        assert_eq!(1.5f32.sanitize(), (1.5, false));
        assert_eq!(f64::INFINITY.to_code(&1.0), i32::MAX);
        assert_eq!(f64::NAN.to_code(&1.0), 0);
        assert_eq!((-2.5f64).to_code(&1.0), -3);
        assert!(f32::NAN.limit(-1.0, 1.0).1);
    }

    /// Error feedback: a constant increment of 0.3 LSB accumulates exactly, where the
    /// rounded product adds 0 forever (a dead band).
    #[test]
    fn integrator_increment_has_no_dead_band() {
        let c = Coef::from_num(0.3 / 1000.0); // x = 1000 LSB -> 0.3 LSB per step
        let x = Fx::from_bits(1000);
        let mut r = 0u32;
        let mut acc = 0i64;
        for n in 1..=10_000i64 {
            acc += x.mul_c_acc(c, &mut r).to_bits() as i64;
            let exact = (x.to_bits() as i64 * c.to_bits() as i64 * n) >> 31;
            assert!((acc - exact).abs() <= 1, "{n}: {acc} vs {exact}");
        }
        assert_eq!(
            x.mul_c(c).to_bits(),
            0,
            "the rounded product is a dead band"
        );
        // Negative increments and the extremes stay in range.
        let mut r = 0u32;
        for (x, c) in [
            (Fx::MIN, Coef::MAX),
            (Fx::MAX, Coef::MAX),
            (Fx::MIN, -Coef::MAX),
        ] {
            let y = x.mul_c_acc(c, &mut r).to_f64();
            assert!((y - x.to_f64() * c.to_num::<f64>()).abs() < 1e-6, "{x} {c}");
        }
    }

    #[test]
    fn fixed_from_non_finite_f64_does_not_panic() {
        assert_eq!(Fx::from_f64(f64::NAN), Fx::ZERO);
        assert_eq!(Fx::from_f64(f64::INFINITY), Fx::MAX);
        assert_eq!(Fx::from_f64(f64::NEG_INFINITY), Fx::MIN);
        assert_eq!(Fx::from_f64(1e300), Fx::MAX);
        assert_eq!(Fx::from_f64(0.5).to_f64(), 0.5);
    }
}
