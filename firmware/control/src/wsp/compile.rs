//! Compiling the protection: [`WspParams`] validated and quantised, and its exact bits.

use super::{Wsp, WspBits, WspParams, MAX_SHIFT};
use crate::compiled::ScaleBits;
use crate::config::{coeff, range, ConfigError, FullScales, Limits, Motor};
use crate::lead::LeadParams;
use crate::sample::{Sample, SampleBits};

impl<T: Sample> Wsp<T> {
    /// Validate `p` against the motor, scales, limits and the lead, and quantise;
    /// `speed_lsb` is the wire's motor-speed LSB, rad/s.
    pub fn try_new(
        p: &WspParams,
        motor: &Motor,
        s: &FullScales,
        l: &Limits,
        speed_lsb: f64,
        lead: &LeadParams,
    ) -> Result<Self, ConfigError> {
        range(
            "wsp.r0_m",
            p.r0_m,
            p.r0_m > 0.1 && p.r0_m <= 2.0,
            "must be in (0.1, 2] m",
        )?;
        range(
            "wsp.slip_on_mps",
            p.slip_on_mps,
            p.slip_on_mps > 0.0 && p.slip_on_mps <= 10.0,
            "must be in (0, 10] m/s",
        )?;
        range(
            "wsp.slip_accel_mps",
            p.slip_accel_mps,
            p.slip_accel_mps > 0.0 && p.slip_accel_mps < p.slip_on_mps,
            "must be in (0, slip_on_mps)",
        )?;
        range(
            "wsp.accel_on_mps2",
            p.accel_on_mps2,
            p.accel_on_mps2 > 0.0 && p.accel_on_mps2 <= 100.0,
            "must be in (0, 100] m/s^2",
        )?;
        range(
            "wsp.cut_fraction",
            p.cut_fraction,
            p.cut_fraction > 0.0 && p.cut_fraction < 1.0,
            "must be in (0, 1)",
        )?;
        range(
            "wsp.slip_sp_mps",
            p.slip_sp_mps,
            p.slip_sp_mps > 0.0 && p.slip_sp_mps < p.slip_on_mps,
            "must be in (0, slip_on_mps)",
        )?;
        range(
            "wsp.slip_sp_per_a",
            p.slip_sp_per_a,
            p.slip_sp_per_a >= 0.0 && p.slip_sp_per_a * s.current <= 1.0,
            "must be in [0, 1 m/s per scales.current]",
        )?;
        range(
            "wsp.kp_a_per_mps",
            p.kp_a_per_mps,
            p.kp_a_per_mps > 0.0 && p.kp_a_per_mps <= 1e4,
            "must be in (0, 1e4] A per m/s",
        )?;
        range(
            "wsp.ki_a_per_s_per_mps",
            p.ki_a_per_s_per_mps,
            p.ki_a_per_s_per_mps > 0.0 && p.ki_a_per_s_per_mps <= 1e5,
            "must be in (0, 1e5] A/s per m/s",
        )?;
        range(
            "wsp.lead_w1_rad_s",
            p.lead_w1_rad_s,
            p.lead_w1_rad_s > 0.0 && p.lead_w1_rad_s < lead.w2,
            "must be in (0, lead.w2): a phase lead with the lead's pole",
        )?;
        range(
            "wsp.lead_gain",
            p.lead_gain,
            p.lead_gain > 0.0 && p.lead_gain <= 1.0,
            "must be in (0, 1]",
        )?;
        range(
            "wsp.v_ref_lsb_m_per_s",
            p.v_ref_lsb_m_per_s,
            p.v_ref_lsb_m_per_s > 0.0 && p.v_ref_lsb_m_per_s <= 1.0,
            "must be in (0, 1] m/s",
        )?;
        // m/s at the rim -> motor-speed pu.
        let pu = motor.n / (p.r0_m * s.speed);
        let slip_on = p.slip_on_mps * pu;
        range(
            "wsp.slip_on_mps",
            p.slip_on_mps,
            slip_on <= 0.5,
            "is more than 0.5 pu of motor speed",
        )?;
        let fit = ConfigError::fit;
        let q = |name, v: f64| fit(T::quantise(v).filter(|_| v > 0.0 && v < 1.0), name, v);
        // A gain `g > 0` as `c 2^s`, `c` in [1/2, 1) (or `s = 0` and `c = g < 1`).
        let split = |name: &'static str, g: f64| {
            let mut sh = 0u8;
            let mut c = g;
            while c >= 1.0 && sh < MAX_SHIFT {
                c *= 0.5;
                sh += 1;
            }
            q(name, c).map(|c| (c, sh))
        };
        // The slew, pu/s; half a motor-speed code above each threshold (module docs, "Exact
        // decisions").
        let slew = l.current_ref_rate / s.current;
        let half = 0.5 * speed_lsb / s.speed;
        range(
            "wire.speed",
            speed_lsb,
            speed_lsb > 0.0 && 2.0 * half <= p.slip_accel_mps * pu,
            "must be positive and at most wsp.slip_accel_mps at the motor",
        )?;
        // kp' = kp / (pu scales.current), ki' = ki / (pu current_ref_rate).
        let (kp, kp_shift) = split(
            "wsp kp / (n/r0 scales.current)",
            p.kp_a_per_mps / (pu * s.current),
        )?;
        let (ki, ki_shift) = split(
            "wsp ki / (n/r0 current_ref_rate)",
            p.ki_a_per_s_per_mps / (pu * l.current_ref_rate),
        )?;
        let slope = 0.5 * p.slip_sp_per_a * s.current * pu;
        let sp_half_slope = fit(
            T::quantise(slope).filter(|_| slope < 1.0),
            "wsp slip_sp_per_a scales.current n/r0 / 2",
            slope,
        )?;
        // g' = (w2 - w1')/w2 = g (1 + rho), rho = (w1 - w1')/(w2 - w1).
        let k_hf = lead.k * lead.a * s.y_dot / s.torque;
        let rho = (lead.w1 - p.lead_w1_rad_s) / (lead.w2 - lead.w1);
        let v_ref_pu = p.v_ref_lsb_m_per_s * pu;
        Ok(Self {
            enabled: p.enabled,
            slip_on: T::from_f64(slip_on + half),
            slip_accel: T::from_f64(p.slip_accel_mps * pu + half),
            accel_ratio: q(
                "wsp accel_on n/r0 / current_ref_rate",
                p.accel_on_mps2 * pu / slew,
            )?,
            cut: q("wsp.cut_fraction", p.cut_fraction)?,
            sp_half: T::from_f64(0.5 * p.slip_sp_mps * pu),
            sp_half_slope,
            kp,
            kp_shift,
            ki,
            ki_shift,
            // Signed, as the lead's own K_hf (a negative K is a sign test's lead).
            lead_k_hf: coeff::<T>("wsp lead_gain lead.k a (pu)", p.lead_gain * k_hf)?,
            lead_rho: fit(
                T::quantise(rho).filter(|_| rho.abs() < 1.0),
                "wsp lead rho = (w1 - w1')/(w2 - w1)",
                rho,
            )?,
            v_ref: ConfigError::fit(
                T::scale_in(v_ref_pu),
                "wsp v_ref lsb n/(r0 scales.speed)",
                v_ref_pu,
            )?,
        })
    }
}

impl<T: SampleBits> Wsp<T> {
    /// The exact bits.
    pub fn to_bits(&self) -> WspBits {
        let (mul, shift) = T::scale_to_bits(&self.v_ref);
        WspBits {
            enabled: self.enabled,
            slip_on: self.slip_on.to_bits64(),
            slip_accel: self.slip_accel.to_bits64(),
            accel_ratio: T::coeff_to_bits64(self.accel_ratio),
            cut: T::coeff_to_bits64(self.cut),
            sp_half: self.sp_half.to_bits64(),
            sp_half_slope: T::coeff_to_bits64(self.sp_half_slope),
            kp: T::coeff_to_bits64(self.kp),
            kp_shift: self.kp_shift,
            ki: T::coeff_to_bits64(self.ki),
            ki_shift: self.ki_shift,
            lead_rho: T::coeff_to_bits64(self.lead_rho),
            v_ref: ScaleBits { mul, shift },
        }
    }

    /// From exact bits, validated (thresholds `0 < slip_accel < slip_on <= 2` pu, shifts <= 16).
    pub fn from_bits(b: &WspBits) -> Result<Self, crate::BitsError> {
        let e = |field| crate::BitsError { field };
        let sig = |field, v| {
            T::from_bits64(v)
                .filter(|x| *x > T::ZERO && *x <= T::MAX_LIMIT)
                .ok_or(e(field))
        };
        let unit = |field, v, zero_ok| {
            T::coeff_from_bits64(v)
                .filter(|c| T::coeff_in_unit(*c, zero_ok))
                .ok_or(e(field))
        };
        let shift = |field, s: u8| if s <= MAX_SHIFT { Ok(s) } else { Err(e(field)) };
        let slip_on = sig("wsp.slip_on", b.slip_on)?;
        let slip_accel = sig("wsp.slip_accel", b.slip_accel)?;
        let sp_half = sig("wsp.sp_half", b.sp_half)?;
        if slip_accel >= slip_on {
            return Err(e("wsp.slip_accel"));
        }
        if sp_half >= slip_on {
            return Err(e("wsp.sp_half"));
        }
        Ok(Self {
            enabled: b.enabled,
            slip_on,
            slip_accel,
            accel_ratio: unit("wsp.accel_ratio", b.accel_ratio, false)?,
            cut: unit("wsp.cut", b.cut, false)?,
            sp_half,
            sp_half_slope: unit("wsp.sp_half_slope", b.sp_half_slope, true)?,
            kp: unit("wsp.kp", b.kp, false)?,
            kp_shift: shift("wsp.kp_shift", b.kp_shift)?,
            ki: unit("wsp.ki", b.ki, false)?,
            ki_shift: shift("wsp.ki_shift", b.ki_shift)?,
            // Rate-dependent: set by the schedule (`Compiled::with_schedule`).
            lead_k_hf: Default::default(),
            lead_rho: T::coeff_from_bits64(b.lead_rho).ok_or(e("wsp.lead_rho"))?,
            v_ref: T::scale_from_bits(b.v_ref.mul, b.v_ref.shift).ok_or(e("wsp.v_ref"))?,
        })
    }
}
