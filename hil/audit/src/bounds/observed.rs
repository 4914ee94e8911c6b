//! The observed rounding errors: the fixed-point pieces against exact (f64) arithmetic on
//! the same quantised coefficients and the fixed runs' own inputs.

use wheelset_control::{Config, ConfigError, Controller, Lead, Pi, PiState, Sample};

use super::{quantise, Quantised};
use crate::ranges::Scenario;

/// Largest |fixed - exact| over the scenarios for the lead (with the predictor), the
/// gain, the PI given its input and the reference, pu: the exact runs use f64 on the
/// quantised coefficients and the fixed runs' own inputs.
pub fn observed_errors<T: Sample>(
    cfg: &Config,
    k: &Quantised,
    scenarios: &[Scenario],
) -> Result<[f64; 4], ConfigError> {
    let c = Controller::<T>::try_new(cfg)?;
    let lead: Lead<T> = *c.lead();
    let pi: Pi<T> = *c.pi();
    let ph = quantise::<T>("predict_half", k.ph)?;
    let gain = quantise::<T>("gain", k.gain)?;
    let d2i = quantise::<T>("demand_to_iref", k.d2i)?;
    let s = cfg.scales;
    let l = &k.lead;
    let mut worst = [0.0f64; 4];
    let clampf = |v: f64, m: f64| v.clamp(-m, m);
    let yd = cfg.yaw_divisor.max(1) as usize;
    let td = cfg.traction_divisor.max(1) as usize;
    for sc in scenarios {
        let mut st = wheelset_control::LeadState::<T>::default();
        let (mut ez, mut ex1) = (0.0f64, 0.0f64);
        let (mut yp_f, mut yp_e) = (T::ZERO, 0.0f64);
        let tmax = T::from_f64(k.y_max);
        let pmax = T::from_f64(k.p_max);
        for t in sc.ticks.iter().step_by(yd) {
            let v = t.si[0] / s.y_dot;
            let yf = T::from_f64(if v.is_finite() { v } else { 0.0 })
                .limit(T::ZERO.sat_sub(tmax), tmax)
                .0;
            let ye = yf.to_f64();
            let d = yf.sat_sub(yp_f).mul_c(ph);
            let xf = yf
                .sat_add(d)
                .sat_add(d)
                .limit(T::ZERO.sat_sub(pmax), pmax)
                .0;
            yp_f = yf;
            let xe = clampf(ye + 2.0 * (ye - yp_e) * k.ph, k.p_max);
            yp_e = ye;
            let of = lead.process(&mut st, xf).to_f64();
            ez = ez + l.kappa * (l.g_half * (xe + ex1) - ez);
            ex1 = xe;
            let oe = l.k_hf * (xe - ez);
            worst[0] = worst[0].max((of - oe).abs());
            let gf = xf.mul_c(gain).to_f64();
            worst[1] = worst[1].max((gf - xe * k.gain).abs());
        }
        // Traction: fixed vs exact ramp, and fixed vs exact PI on the same (fixed) error.
        let mut ps = PiState::<T>::new(T::ZERO);
        let mut ie = 0.0f64;
        let (mut rf, mut re) = (T::ZERO, 0.0f64);
        let step = T::from_f64(k.i_step);
        let (imax, dmax) = (T::from_f64(k.i_max), T::from_f64(k.d_max));
        for t in sc.ticks.iter().step_by(td) {
            let fin = |v: f64| if v.is_finite() { v } else { 0.0 };
            let i = T::from_f64(fin(t.si[1] / s.current))
                .limit(T::ZERO.sat_sub(imax), imax)
                .0;
            let d = T::from_f64(fin(t.si[3] / s.demand))
                .limit(T::ZERO.sat_sub(dmax), dmax)
                .0;
            let tf = d.mul_c(d2i);
            rf = rf.sat_add(tf.sat_sub(rf).limit(T::ZERO.sat_sub(step), step).0);
            let te = d.to_f64() * k.d2i;
            re += (te - re).clamp(-k.i_step, k.i_step);
            worst[3] = worst[3].max((rf.to_f64() - re).abs());
            let e = rf.sat_sub(i);
            let uf = pi.process(&mut ps, e).to_f64();
            let ee = e.to_f64();
            ie = (ie + k.ki * ee).clamp(k.u_min, k.u_max);
            let ue = (k.kp * ee + ie).clamp(k.u_min, k.u_max);
            worst[2] = worst[2].max((uf - ue).abs());
        }
    }
    Ok(worst)
}
