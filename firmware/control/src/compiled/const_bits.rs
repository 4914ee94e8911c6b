//! The `const` constructor from bits known valid: the firmware's start, no conversion code.

#[allow(clippy::wildcard_imports)]
use super::*;

macro_rules! from_valid_bits {
    ($t:ty, $signal:expr, $coeff:expr, $scale:expr) => {
        impl Compiled<$t> {
            /// The controller of `b` without validation, `const`, for bits known valid
            /// ([`Compiled::to_bits`] output, checked by [`Compiled::from_bits`] in a test).
            pub const fn from_valid_bits(b: &CompiledBits) -> Self {
                let s = $signal;
                let c = $coeff;
                let sc = $scale;
                let sch = &b.schedule;
                Self {
                    lead: Lead {
                        k_hf: c(sch.lead_k_hf),
                        g_half: c(b.lead_g_half),
                        kappa: c(sch.kappa),
                    },
                    gain: c(b.gain),
                    pi: Pi {
                        kp: c(sch.kp),
                        ki: c(sch.ki),
                        ki_shift: sch.ki_shift as u32,
                        u_min: s(b.u_min),
                        u_max: s(b.u_max),
                    },
                    y_dot_max: s(b.clamps[0]),
                    current_max: s(b.clamps[1]),
                    speed_max: s(b.clamps[2]),
                    demand_max: s(b.clamps[3]),
                    torque_max: s(b.clamps[4]),
                    demand_to_iref: c(b.demand_to_iref),
                    back_emf: c(b.back_emf),
                    predict_half: c(sch.predict_half),
                    y_dot_pred_max: s(b.y_dot_pred_max),
                    iref_step: s(sch.iref_step),
                    iref_safe_step: s(sch.iref_safe_step),
                    torque_step: s(sch.torque_step),
                    yaw_divisor: sch.yaw_divisor,
                    traction_divisor: sch.traction_divisor,
                    delay_ticks: sch.delay_ticks,
                    base_rate_hz: sch.base_rate_hz,
                    codec: Codec {
                        y_dot: sc(b.codec[0]),
                        current: sc(b.codec[1]),
                        speed: sc(b.codec[2]),
                        demand: sc(b.codec[3]),
                        torque: sc(b.codec[4]),
                        voltage: sc(b.codec[5]),
                    },
                    yaw_mode: b.yaw_mode,
                    traction_enabled: b.traction_enabled,
                    wsp: Wsp {
                        enabled: b.wsp.enabled,
                        slip_on: s(b.wsp.slip_on),
                        slip_accel: s(b.wsp.slip_accel),
                        accel_ratio: c(b.wsp.accel_ratio),
                        cut: c(b.wsp.cut),
                        sp_half: s(b.wsp.sp_half),
                        sp_half_slope: c(b.wsp.sp_half_slope),
                        kp: c(b.wsp.kp),
                        kp_shift: b.wsp.kp_shift,
                        ki: c(b.wsp.ki),
                        ki_shift: b.wsp.ki_shift,
                        lead_k_hf: c(sch.wsp_lead_k_hf),
                        lead_rho: c(b.wsp.lead_rho),
                        v_ref: sc(b.wsp.v_ref),
                    },
                }
            }
        }
    };
}

pub(crate) const fn fx_signal(v: u64) -> Fx {
    Fx::from_bits(v as u32 as i32)
}
pub(crate) const fn fx_coeff(v: u64) -> Coef {
    Coef::from_bits(v as u32 as i32)
}
const fn fx_scale(x: ScaleBits) -> FxScale {
    FxScale::from_parts(x.mul as u32 as i32, x.shift as u32)
}
pub(crate) const fn f32_value(v: u64) -> f32 {
    f32::from_bits(v as u32)
}
const fn f32_scale(x: ScaleBits) -> f32 {
    f32::from_bits(x.mul as u32)
}

from_valid_bits!(Fx, fx_signal, fx_coeff, fx_scale);
from_valid_bits!(f32, f32_value, f32_value, f32_scale);
