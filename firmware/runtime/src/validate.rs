//! The device's plausibility check of a received Config, in integer work.

use wheelset_proto::plausible::{BASE_RATE_MAX_HZ, BASE_RATE_MIN_HZ, HOLD_MAX_US, TICKER_HZ};
use wheelset_proto::{Rates, RefuseReason};

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

/// The index in `table` of the design whose coefficients `r` carries, at its delay.
#[inline(never)]
pub(crate) fn check_rates(r: &Rates, table: &[Rates]) -> Result<usize, RefuseReason> {
    use RefuseReason as R;
    let hz = r.base_rate_hz;
    if !(BASE_RATE_MIN_HZ..=BASE_RATE_MAX_HZ).contains(&hz) {
        return Err(R::BaseRate);
    }
    if !period_ok(hz) {
        return Err(R::Period);
    }
    if r.yaw_div != 1 {
        return Err(R::YawDiv);
    }
    if r.traction_div != 1 {
        return Err(R::TractionDiv);
    }
    if !table.iter().any(|d| d.base_rate_hz == hz) {
        return Err(R::BaseRate);
    }
    let (i, d) = table
        .iter()
        .enumerate()
        .find(|(_, d)| d.base_rate_hz == hz && d.delay_ticks == r.delay_ticks)
        .ok_or(R::Delay)?;
    // Traction first, then the yaw law, then the runtime's own factors.
    for (got, want, why) in [
        (r.kp, d.kp, R::Kp),
        (r.ki, d.ki, R::Ki),
        (u32::from(r.ki_shift), u32::from(d.ki_shift), R::Ki),
        (r.iref_step, d.iref_step, R::IrefStep),
        (r.iref_safe_step, d.iref_safe_step, R::IrefSafeStep),
        (r.lead_k_hf, d.lead_k_hf, R::LeadKhf),
        (r.kappa, d.kappa, R::Kappa),
        (r.predict_half, d.predict_half, R::PredictHalf),
        (r.torque_step, d.torque_step, R::TorqueStep),
        (r.wsp_lead_k_hf, d.wsp_lead_k_hf, R::WspLead),
    ] {
        if got != want {
            return Err(why);
        }
    }
    if r.acc_gain_q32 != d.acc_gain_q32 {
        return Err(R::AccGain);
    }
    if r.acc_leak_q32 != d.acc_leak_q32 {
        return Err(R::AccLeak);
    }
    Ok(i)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hold_and_period() {
        assert!(check_hold(100, 5_000).is_ok()); // 20 ms
        assert_eq!(check_hold(101, 5_000), Err(RefuseReason::HoldTicks));
        assert_eq!(check_hold(u16::MAX, 20_000), Err(RefuseReason::HoldTicks));
        assert!(period_ok(5_000) && period_ok(4_000) && period_ok(20_000));
        assert!(!period_ok(3_000) && !period_ok(7_000) && !period_ok(0));
    }
}
