//! The observed rounding errors: the fixed-point pieces against exact (f64) arithmetic on
//! the same quantised coefficients and the fixed runs' own inputs.

use wheelset_control::{Config, ConfigError, Controller, Lead, Pi, PiState, Sample};

use super::{quantise, Quantised};
use crate::ranges::Scenario;

/// Largest |fixed - exact| over the scenarios (module docs), pu: the lead (with the
/// predictor), the gain, the PI given its input and the reference.
pub fn observed_errors<T: Sample>(
    cfg: &Config,
    k: &Quantised,
    scenarios: &[Scenario],
) -> Result<[f64; 4], ConfigError> {
    let c = Controller::<T>::try_new(cfg)?;
    let lead: Lead<T> = *c.compiled().lead();
    let pi: Pi<T> = *c.compiled().pi();
    let ph = quantise::<T>("predict_half", k.ph)?;
    let gain = quantise::<T>("gain", k.gain)?;
    let d2i = quantise::<T>("demand_to_iref", k.d2i)?;
    let s = cfg.scales;
    let l = &k.lead;
    let mut worst = [0.0f64; 4];
    // `v` within `[-m, m]`, in T; an input quantised (NaN as 0) and clamped to `m` (pu).
    let sym = |v: T, m: f64| v.limit(T::ZERO.sat_sub(T::from_f64(m)), T::from_f64(m)).0;
    let input = |si: f64, fs: f64, m: f64| sym(crate::ranges::q::<T>(si / fs), m);
    let yd = cfg.yaw_divisor.max(1) as usize;
    let td = cfg.traction_divisor.max(1) as usize;
    for sc in scenarios {
        let mut st = wheelset_control::LeadState::<T>::default();
        let (mut ez, mut ex1) = (0.0f64, 0.0f64);
        let (mut yp_f, mut yp_e) = (T::ZERO, 0.0f64);
        for t in sc.ticks.iter().step_by(yd) {
            let yf = input(t.si[0], s.y_dot, k.y_max);
            let ye = yf.to_f64();
            let d = yf.sat_sub(yp_f).mul_c(ph);
            let xf = sym(yf.sat_add(d).sat_add(d), k.p_max);
            yp_f = yf;
            let xe = (ye + 2.0 * (ye - yp_e) * k.ph).clamp(-k.p_max, k.p_max);
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
        for t in sc.ticks.iter().step_by(td) {
            let i = input(t.si[1], s.current, k.i_max);
            let d = input(t.si[3], s.demand, k.d_max);
            let tf = d.mul_c(d2i);
            rf = rf.sat_add(sym(tf.sat_sub(rf), k.i_step));
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
