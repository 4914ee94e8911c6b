//! The device's plausibility check of a received [`Config`](wheelset_proto::Config): the
//! ranges of `wheelset_proto::plausible` (stated there once, with the reasons), applied
//! with integer work only.
//!
//! Every value is compared in one fixed format, Q40 (`value x 2^40` as `u64`): a
//! fixed-point coefficient (Q1.31) is its bits `<< 9`, a fixed-point signal (Q4.28) its
//! bits `<< 12`, an `f32` its mantissa shifted by its exponent (normal, positive numbers
//! only: zero, subnormal, infinite, NaN and negative patterns are refused, as nothing
//! here is plausibly any of them), a Q32 factor its value `<< 8`. A rate-dependent
//! value `x` at period `T` must match the start-up core's `x0` at `T0` (module docs of
//! `wheelset_proto::plausible`):
//!
//! ```text
//! linear:  | x den - x0 num | <= x0 num 2^-10
//! kappa:   | k (2 - k0) den - k0 (2 - k) num | <= k0 (2 - k) num 2^-10 + 2^24 (num + den)
//!          (k in Q21, the slack its rounding)
//! T/T0 = num/den, both below 2^20 (refused otherwise): u64 arithmetic, no overflow
//! ```

use wheelset_control::{SampleBits, ScheduleBits};
use wheelset_proto::plausible::{
    BASE_RATE_MAX_HZ, BASE_RATE_MIN_HZ, HOLD_MAX_US, LOOP_RATE_MIN_HZ, PREDICT_HALF_MAX_QUARTERS,
    RATE_TOLERANCE_LOG2, TICKER_HZ,
};
use wheelset_proto::{Rates, RefuseReason};

use crate::AccBits;

/// The start-up core's rate-dependent part: what received coefficients are checked
/// against.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Reference {
    pub(crate) schedule: ScheduleBits,
    pub(crate) acc: AccBits,
}

const Q: u32 = 40;
const ONE: u64 = 1 << Q;

/// What a value's bits are.
#[derive(Clone, Copy, PartialEq, Eq)]
enum Kind {
    /// A coefficient of the sample type (fixed point Q1.31).
    Coeff,
    /// A signal of the sample type (fixed point Q4.28).
    Signal,
    /// A Q32 integer factor (`acc_*_q32`; 0 allowed where the start-up core has 0).
    Q32,
}

/// A value's bits as Q40 (see the module docs); `None` if not a plausible positive
/// number of its format or not below 4.
#[inline(never)]
fn q40<T: SampleBits>(bits: u64, kind: Kind) -> Option<u64> {
    let v = match (kind, T::NUMERIC) {
        (Kind::Q32, _) => bits.checked_shl(Q - 32)?,
        (_, 0) => {
            let x = u32::try_from(bits).ok()? as i32;
            let sh = if kind == Kind::Coeff { Q - 31 } else { Q - 28 };
            u64::from(x.max(0) as u32) << sh
        }
        (_, 1) => {
            let bits = u32::try_from(bits).ok()?;
            let e = (bits >> 23) & 0xff;
            // Normal, positive, below 4 (e < 129): value = m 2^(e - 150) = m 2^(e - 110)
            // in Q40.
            if bits >> 31 != 0 || e == 0 || e >= 129 {
                return None;
            }
            let m = u64::from((bits & 0x7f_ffff) | 0x80_0000);
            m.checked_shl(e.wrapping_sub(110))
                .unwrap_or_else(|| m >> 110u32.saturating_sub(e).min(63))
        }
        _ => return None,
    };
    (v > 0 && v < 4 * ONE).then_some(v)
}

/// `|a - b| <= b 2^-10 + slack`.
#[inline(never)]
fn near(a: u64, b: u64, slack: u64) -> bool {
    a.abs_diff(b) <= (b >> RATE_TOLERANCE_LOG2).saturating_add(slack)
}

/// `hold_ticks` at `base_rate_hz`: at most [`HOLD_MAX_US`].
#[inline(never)]
pub(crate) fn check_hold(hold_ticks: u16, base_rate_hz: u32) -> Result<(), RefuseReason> {
    let us = u64::from(hold_ticks) * u64::from(TICKER_HZ);
    if us <= u64::from(HOLD_MAX_US) * u64::from(base_rate_hz) {
        Ok(())
    } else {
        Err(RefuseReason::HoldTicks)
    }
}

/// Whether the board's ticker can run `base_rate_hz`: a whole number of ticks per period.
pub(crate) fn period_ok(base_rate_hz: u32) -> bool {
    base_rate_hz != 0 && TICKER_HZ.is_multiple_of(base_rate_hz)
}

/// Checks the rates (the sample type and the fingerprint checked by the caller) against
/// the plausible ranges and the start-up core `r0` (see the module docs). `u64`
/// arithmetic: once the rates and divisors are in range, `num, den <= 40 x 20 000 <
/// 2^20`, so a Q40 value (`< 2^42`) times either fits, and `kappa` is compared in Q21.
#[inline(never)]
pub(crate) fn check_rates<T: SampleBits>(r: &Rates, r0: &Reference) -> Result<(), RefuseReason> {
    use RefuseReason as R;
    let hz = r.base_rate_hz;
    if !(BASE_RATE_MIN_HZ..=BASE_RATE_MAX_HZ).contains(&hz) {
        return Err(R::BaseRate);
    }
    if !period_ok(hz) {
        return Err(R::Period);
    }
    let loop_ok = |div: u16| div != 0 && hz >= LOOP_RATE_MIN_HZ * u32::from(div);
    if !loop_ok(r.yaw_div) {
        return Err(R::YawDiv);
    }
    if !loop_ok(r.traction_div) {
        return Err(R::TractionDiv);
    }
    if r.predict_half != 0 {
        let p = q40::<T>(u64::from(r.predict_half), Kind::Coeff).ok_or(R::PredictHalf)?;
        if p > u64::from(PREDICT_HALF_MAX_QUARTERS) * (ONE / 4) {
            return Err(R::PredictHalf);
        }
    }
    check_coefficients::<T>(r, r0)
}

/// The rate-dependent coefficients against the start-up core's at the requested rates.
fn check_coefficients<T: SampleBits>(r: &Rates, r0: &Reference) -> Result<(), RefuseReason> {
    use RefuseReason as R;
    let hz = r.base_rate_hz;
    let s0 = &r0.schedule;
    // T/T0 = num/den for the three periods, each below 2^20 (or refused).
    let ratio = |d: u16, d0: u16| {
        (
            u32::from(d).saturating_mul(s0.base_rate_hz),
            u32::from(d0).saturating_mul(hz),
        )
    };
    let yaw = ratio(r.yaw_div, s0.yaw_divisor);
    let traction = ratio(r.traction_div, s0.traction_divisor);
    let base = ratio(1, 1);
    let c = |why, v: u32, v0, p, kind| rated::<T>(why, u64::from(v), v0, p, kind);
    c(R::Kappa, r.kappa, s0.kappa, yaw, Kind::Coeff)?;
    c(R::Ki, r.ki, s0.ki, traction, Kind::Coeff)?;
    c(
        R::IrefStep,
        r.iref_step,
        s0.iref_step,
        traction,
        Kind::Signal,
    )?;
    c(
        R::IrefSafeStep,
        r.iref_safe_step,
        s0.iref_safe_step,
        traction,
        Kind::Signal,
    )?;
    c(
        R::TorqueStep,
        r.torque_step,
        s0.torque_step,
        yaw,
        Kind::Signal,
    )?;
    let (g, g0, l, l0) = (
        r.acc_gain_q32,
        r0.acc.gain_q32,
        r.acc_leak_q32,
        r0.acc.leak_q32,
    );
    rated::<T>(R::AccGain, g, g0, base, Kind::Q32)?;
    if l != 0 || l0 != 0 {
        rated::<T>(R::AccLeak, l, l0, base, Kind::Q32)?;
    }
    Ok(())
}

/// One rate-dependent value `v` against the start-up core's `v0`, at the period ratio
/// `T/T0 = num/den` (module docs); `Err(why)` if it is not within the tolerance.
#[inline(never)]
fn rated<T: SampleBits>(
    why: RefuseReason,
    v: u64,
    v0: u64,
    (num, den): (u32, u32),
    kind: Kind,
) -> Result<(), RefuseReason> {
    const MAX: u32 = 1 << 20;
    let (x, x0) = q40::<T>(v, kind)
        .zip(q40::<T>(v0, kind))
        .filter(|_| num < MAX && den < MAX)
        .ok_or(why)?;
    let (num, den) = (u64::from(num), u64::from(den));
    let ok = if why == RefuseReason::Kappa {
        // c = k/(2 - k) scales with T: k (2 - k0) den = k0 (2 - k) num, in Q21
        // (k < 2^21, 2 - k0 <= 2^22, den < 2^20: below 2^63).
        let (k, k0, two) = (x >> (Q - 21), x0 >> (Q - 21), 2u64 << 21);
        k < two / 2
            && near(
                k * (two - k0) * den,
                k0 * (two - k) * num,
                4 * two * (num + den),
            )
    } else {
        // x < 2^42, num, den < 2^20: below 2^62. (No LSB slack: at 1-20 kHz the
        // smallest value, torque_step at 20 kHz, is 2 684 LSB of Q4.28, its rounding
        // 2e-4 relative.)
        near(x * den, x0 * num, 0)
    };
    if ok {
        Ok(())
    } else {
        Err(why)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn q40_of_both_formats() {
        use wheelset_control::Fx;
        let f = q40::<f32>;
        assert_eq!(q40::<Fx>(1 << 30, Kind::Coeff), Some(ONE / 2));
        assert_eq!(q40::<Fx>(1 << 27, Kind::Signal), Some(ONE / 2));
        assert_eq!(f(u64::from(0.5f32.to_bits()), Kind::Coeff), Some(ONE / 2));
        assert_eq!(f(u64::from(3.0f32.to_bits()), Kind::Signal), Some(3 * ONE));
        let tiny = f(u64::from(1e-9f32.to_bits()), Kind::Signal).expect("normal");
        assert!((1099..=1100).contains(&tiny), "{tiny}");
        for bad in [
            0.0f32,
            -0.5,
            f32::MIN_POSITIVE / 2.0,
            f32::NAN,
            f32::INFINITY,
            4.0,
        ] {
            assert_eq!(f(u64::from(bad.to_bits()), Kind::Coeff), None, "{bad}");
        }
        assert_eq!(q40::<Fx>(0, Kind::Coeff), None);
        assert_eq!(q40::<Fx>(u64::from(u32::MAX), Kind::Coeff), None); // -1 LSB
        assert_eq!(q40::<f64>(1, Kind::Coeff), None);
        assert_eq!(q40::<Fx>(1 << 32, Kind::Coeff), None);
        assert_eq!(q40::<Fx>(1 << 32, Kind::Q32), Some(ONE));
        assert_eq!(q40::<Fx>(1 << 34, Kind::Q32), None);
    }

    #[test]
    fn hold_and_period() {
        assert!(check_hold(100, 5_000).is_ok()); // 20 ms
        assert_eq!(check_hold(101, 5_000), Err(RefuseReason::HoldTicks));
        assert_eq!(check_hold(u16::MAX, 20_000), Err(RefuseReason::HoldTicks));
        assert!(period_ok(5_000) && period_ok(4_000) && period_ok(20_000));
        assert!(!period_ok(3_000) && !period_ok(7_000) && !period_ok(0));
    }
}
