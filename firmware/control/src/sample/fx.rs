//! The fixed-point sample [`Fx`] (Q4.28) with Q1.31 coefficients and wire-code scales.

use super::{Coef, Fx, Sample, SampleBits, COEF_FRAC, FX_FRAC};

/// A wire-code scale, `out = sat32((in * mul + round) >> shift)`; `repr(C)` in read order.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(C)]
pub struct FxScale {
    /// `2^(shift-1)` (0 for `shift == 0`): rounds to nearest.
    pub round: i64,
    /// Multiplier (positive, `< 2^31`).
    pub mul: i32,
    /// Right shift, `0..=62`.
    pub shift: u32,
    /// `wide`: `min(shift - 32, 31)`; otherwise `shift` (`0..=31`).
    sh: Shift,
    /// Not `wide`: `31 - shift`, the high word's left shift (after a shift by one); `wide`: 0.
    sh_up: Shift,
    /// `shift >= 32`: the result is the product's high word shifted right by `sh`.
    wide: bool,
}

/// A shift amount `0..=31`, an enum so the compiler drops the `& 31` before each shift.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
#[rustfmt::skip]
enum Shift {
    S0, S1, S2, S3, S4, S5, S6, S7, S8, S9, S10, S11, S12, S13, S14, S15,
    S16, S17, S18, S19, S20, S21, S22, S23, S24, S25, S26, S27, S28, S29, S30, S31,
}

impl Shift {
    const ALL: [Shift; 32] = {
        use Shift::*;
        [
            S0, S1, S2, S3, S4, S5, S6, S7, S8, S9, S10, S11, S12, S13, S14, S15, S16, S17, S18,
            S19, S20, S21, S22, S23, S24, S25, S26, S27, S28, S29, S30, S31,
        ]
    };
    const fn of(n: u32) -> Self {
        Self::ALL[(n & 31) as usize]
    }
    #[inline(always)]
    fn get(self) -> u32 {
        self as u32
    }
}

impl FxScale {
    /// The scale from its parts (no validation; `round` 0 for a shift above 63); `const` for
    /// the compiled-in controllers.
    pub(crate) const fn from_parts(mul: i32, shift: u32) -> Self {
        let round = if shift == 0 || shift > 63 {
            0
        } else {
            1i64 << (shift - 1)
        };
        let wide = shift >= 32;
        let (sh, sh_up) = if wide {
            let s = shift - 32;
            (if s > 31 { 31 } else { s }, 0)
        } else {
            (shift, 31 - shift)
        };
        Self {
            mul,
            shift,
            round,
            wide,
            sh: Shift::of(sh),
            sh_up: Shift::of(sh_up),
        }
    }

    /// The scale closest to `factor`: the largest `shift` with `round(factor 2^shift) < 2^31`.
    pub fn new(factor: f64) -> Option<Self> {
        if !(1e-12..2_147_483_647.0).contains(&factor) {
            return None;
        }
        let (mut shift, mut scaled) = (0u8, factor);
        while shift < 62 && scaled * 2.0 < 2_147_483_647.0 {
            scaled *= 2.0;
            shift += 1;
        }
        Self::from_bits(round_f64(scaled) as u64, shift)
    }

    /// The scale from its parts: `None` unless `mul` in `[1024, 2^31)` and `shift <= 62`.
    pub fn from_bits(mul: u64, shift: u8) -> Option<Self> {
        let shift = u32::from(shift);
        if !(1024..(1u64 << 31)).contains(&mul) || shift > 62 {
            return None;
        }
        Some(Self::from_parts(mul as i32, shift))
    }

    /// `sat32((x * mul + round) >> shift)` without a 64-bit variable shift (a library call on
    /// a 32-bit core): one `SMLAL` into `(hi, lo)`; `wide` is `hi >> sh`, which always fits;
    /// otherwise `lo >> shift | (hi << 1) << (31 - shift)`, saturated when the high word is
    /// not the result's sign extension.
    #[inline(always)]
    pub fn apply(&self, x: i32) -> i32 {
        let p = x as i64 * self.mul as i64 + self.round;
        let (hi, lo) = ((p >> 32) as i32, p as u32);
        let sh = self.sh.get();
        if self.wide {
            // |p| < 2^63 and shift >= 32: `p >> shift` is within `i32` (no saturation).
            hi >> sh
        } else {
            let q = ((lo >> sh) | (((hi as u32) << 1) << self.sh_up.get())) as i32;
            if hi >> sh == q >> 31 {
                q
            } else {
                (hi >> 31) ^ i32::MAX
            }
        }
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

#[inline(always)]
pub(crate) fn sat32(x: i64) -> i32 {
    x.clamp(i32::MIN.into(), i32::MAX.into()) as i32
}

/// `(x c + 2^30) >> 31`: the Q4.28 x Q1.31 product, rounded to nearest (ties up). Never
/// overflows: `|x| <= 2^31`, `|c| <= 2^31 - 1` give `|x c + 2^30| < 2^62`.
#[inline(always)]
pub fn mul_q31(x: i32, c: i32) -> i32 {
    ((x as i64 * c as i64 + (1 << (COEF_FRAC - 1))) >> COEF_FRAC) as i32
}

/// `(a b + 2^31) >> 32`, the rounded high word (`SMMULR`); with `a = 2x` (or `b = 2c`)
/// it equals [`mul_q31`]`(x, c)`.
#[inline(always)]
pub fn smmulr(a: i32, b: i32) -> i32 {
    ((a as i64 * b as i64 + (1 << 31)) >> 32) as i32
}

impl Sample for Fx {
    type Coeff = Coef;
    type Scale = FxScale;
    type Residue = u64;
    const ZERO: Self = Fx::ZERO;
    const NAME: &'static str = "Q4.28";
    fn from_f64(x: f64) -> Self {
        // `saturating_from_num` panics on NaN: NaN becomes 0 (callers count it first).
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
    fn to_coeff_sat(self) -> Coef {
        // Q4.28 -> Q1.31: three bits up, saturated to (-1, 1) strictly (as `quantise`).
        let b = i64::from(self.to_bits()) << (COEF_FRAC - FX_FRAC);
        let m = i64::from(i32::MAX);
        Coef::from_bits(b.clamp(-m, m) as i32)
    }
    #[inline(always)]
    fn square(self) -> Self {
        // Q4.28 x Q4.28 = Q8.56, rounded to Q4.28 and saturated (|x| >= 2.83 pu).
        let x = i64::from(self.to_bits());
        Fx::from_bits(sat32((x * x + (1 << (FX_FRAC - 1))) >> FX_FRAC))
    }
    #[inline(always)]
    fn mul_c_acc(self, c: Coef, r: &mut u64) -> Self {
        // p = x c + r (one SMLAL); floor to Q4.28, keep the low 31 bits. No overflow:
        // |x c| < 2^62 and 0 <= r < 2^31.
        let p = self.to_bits() as i64 * c.to_bits() as i64 + *r as i64;
        *r = (p & ((1 << COEF_FRAC) - 1)) as u64;
        Fx::from_bits((p >> COEF_FRAC) as i32)
    }
    const ACC_SHIFT_MAX: u32 = 30;
    fn acc_shift(c_max: f64) -> Option<u32> {
        // The largest s in 1..=30 with c_max 2^s (growing with s) still a Q1.31 coefficient.
        if !(c_max.is_finite() && c_max > 0.0) {
            return None;
        }
        let fits = |s: u32| Self::quantise(c_max * (1u64 << s) as f64).is_some();
        (1..=Self::ACC_SHIFT_MAX).rev().find(|&s| fits(s))
    }
    fn acc_shift_ok(s: u32) -> bool {
        (1..=Self::ACC_SHIFT_MAX).contains(&s)
    }
    #[inline(always)]
    fn mul_c_acc_shr(self, c: Coef, s: u32, r: &mut u64) -> Self {
        // p = x c + r; the increment is floor(p / 2^(31+s)) = (p >> 32) >> (s - 1), the
        // remainder the low 31 + s bits. No overflow: |x c| <= 2^62 - 2^31, r < 2^61, so
        // |p| < 2^63. The wrapping shifts keep an invalid s (refused earlier) from panicking.
        let p = self.to_bits() as i64 * c.to_bits() as i64 + *r as i64;
        let hi = (p >> 32) as i32;
        let sh = s.wrapping_sub(1);
        let q = hi.wrapping_shr(sh);
        let r_hi = hi.wrapping_sub(q.wrapping_shl(sh));
        *r = (u64::from(r_hi as u32) << 32) | u64::from(p as u32);
        Fx::from_bits(q)
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
    #[inline(always)]
    fn from_code(code: i32, scale: &FxScale) -> Self {
        Fx::from_bits(scale.apply(code))
    }
    #[inline(always)]
    fn to_code(self, scale: &FxScale) -> i32 {
        scale.apply(self.to_bits())
    }
    #[inline(always)]
    fn two_pu() -> Self {
        Fx::from_bits(2 << FX_FRAC)
    }
    #[inline(always)]
    fn abs_within(self, max: Self) -> bool {
        // One unsigned compare: `x + max` in `[0, 2 max]` (for `0 <= max < 2^30`).
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
        Some(Coef::from_bits(u32::try_from(b).ok()? as i32)).filter(|q| *q != Coef::MIN)
    }
    fn coeff_in_unit(c: Coef, zero_ok: bool) -> bool {
        c > Coef::ZERO || (zero_ok && c == Coef::ZERO)
    }
    fn scale_to_bits(s: &FxScale) -> (u64, u8) {
        (u64::from(s.mul as u32), s.shift as u8)
    }
    fn scale_from_bits(mul: u64, shift: u8) -> Option<FxScale> {
        FxScale::from_bits(mul, shift)
    }
}
