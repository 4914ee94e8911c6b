//! Discretisation: coefficients against textbook Tustin, step/impulse responses against
//! the difference equations, frequency responses against the continuous controllers,
//! DC gains.

use std::f64::consts::PI;

use wheelset_control::{
    ConfigError, Fx, Lead, LeadParams, LeadState, Pi, PiParams, PiState, Sample,
};

/// Rates the tests cover, Hz.
const RATES: [f64; 5] = [1000.0, 2500.0, 5000.0, 10_000.0, 20_000.0];

fn lead_f64(p: &LeadParams, t: f64) -> (Lead<f64>, wheelset_control::LeadDiscrete) {
    let d = p.discretise(t).expect("valid");
    // SI "per unit": full scales 1, so coefficients are in N m s/m.
    (Lead::<f64>::new(&d.to_pu(1.0, 1.0)).expect("fits f64"), d)
}

/// The direct form `y[n] = a1 y[n-1] + b0 x[n] + b1 x[n-1]`: `(b0, b1, a1)`, N m s/m.
fn direct_form(d: &wheelset_control::LeadDiscrete) -> (f64, f64, f64) {
    let h = d.kappa * d.g / 2.0;
    (d.k_hf * (1.0 - h), -d.k_hf * (d.alpha + h), d.alpha)
}

#[test]
fn lead_direct_form_equals_textbook_tustin() {
    let p = LeadParams::default();
    for fs in RATES {
        let t = 1.0 / fs;
        let (_, d) = lead_f64(&p, t);
        let (b0, b1, a1) = direct_form(&d);
        // H(z) = K a ((2/T + w1) + (w1 - 2/T) z^-1) / ((2/T + w2) + (w2 - 2/T) z^-1)
        let ka = p.k * p.a;
        let den = 2.0 / t + p.w2;
        let tb0 = ka * (2.0 / t + p.w1) / den;
        let tb1 = ka * (p.w1 - 2.0 / t) / den;
        let ta1 = -(p.w2 - 2.0 / t) / den;
        assert!(
            (b0 - tb0).abs() <= 1e-9 * tb0.abs(),
            "{fs}: b0 {b0} vs {tb0}"
        );
        assert!(
            (b1 - tb1).abs() <= 1e-9 * tb1.abs(),
            "{fs}: b1 {b1} vs {tb1}"
        );
        assert!((a1 - ta1).abs() <= 1e-12, "{fs}: a1 {a1} vs {ta1}");
        // The point: b0 and -b1 differ by only a few percent.
        assert!((b0 + b1).abs() / b0 < 0.25);
    }
}

#[test]
fn prewarped_lead_matches_continuous_exactly_at_the_prewarp_frequency() {
    let wp = 2.0 * std::f64::consts::PI * 10.0; // the ~10 Hz kinematic mode
    let p = LeadParams {
        prewarp_rad_s: wp,
        ..LeadParams::default()
    };
    for fs in RATES {
        let t = 1.0 / fs;
        let (_, d) = lead_f64(&p, t);
        let (hr, hi) = discrete_response(&d, wp, t);
        let (cr, ci) = continuous_lead(&p, wp);
        let err = ((hr - cr).powi(2) + (hi - ci).powi(2)).sqrt() / (cr * cr + ci * ci).sqrt();
        assert!(
            err < 1e-9,
            "{fs} Hz: relative error {err:e} at the pre-warp frequency"
        );
        // tan without libm
        let x = wp * t / 2.0;
        assert!((d.c - p.w2 * x.tan() / wp).abs() < 1e-13);
    }
}

fn continuous_lead(p: &LeadParams, w: f64) -> (f64, f64) {
    // K a (jw + w1)/(jw + w2)
    let ka = p.k * p.a;
    let (nr, ni) = (p.w1, w);
    let (dr, di) = (p.w2, w);
    let m = dr * dr + di * di;
    (ka * (nr * dr + ni * di) / m, ka * (ni * dr - nr * di) / m)
}

fn discrete_response(d: &wheelset_control::LeadDiscrete, w: f64, t: f64) -> (f64, f64) {
    let (b0, b1, a1) = direct_form(d);
    // H(e^{jwT}) = (b0 + b1 e^{-jwT}) / (1 - a1 e^{-jwT})
    let (c, s) = ((w * t).cos(), -(w * t).sin());
    let (nr, ni) = (b0 + b1 * c, b1 * s);
    let (dr, di) = (1.0 - a1 * c, -a1 * s);
    let m = dr * dr + di * di;
    ((nr * dr + ni * di) / m, (ni * dr - nr * di) / m)
}

/// Stated tolerance: below fs/20 the Tustin lead is within 1 % in magnitude and 1 deg in
/// phase of `Ks(jw)` (warping `tan(wT/2)/(wT/2) - 1` <= 0.4 % there).
#[test]
fn lead_frequency_response_within_tolerance_below_fs_over_20() {
    let p = LeadParams::default();
    for fs in RATES {
        let t = 1.0 / fs;
        let (_, d) = lead_f64(&p, t);
        let mut worst_mag: f64 = 0.0;
        let mut worst_ph: f64 = 0.0;
        for k in 0..=400 {
            // log-spaced 0.1 Hz .. fs/20
            let f = 0.1 * (fs / 20.0 / 0.1_f64).powf(k as f64 / 400.0);
            let w = 2.0 * std::f64::consts::PI * f;
            let (hr, hi) = discrete_response(&d, w, t);
            let (cr, ci) = continuous_lead(&p, w);
            let mag = ((hr * hr + hi * hi) / (cr * cr + ci * ci)).sqrt();
            worst_mag = worst_mag.max((mag - 1.0).abs());
            worst_ph = worst_ph.max((hi.atan2(hr) - ci.atan2(cr)).abs().to_degrees());
        }
        assert!(worst_mag < 0.01, "{fs} Hz: magnitude error {worst_mag}");
        assert!(worst_ph < 1.0, "{fs} Hz: phase error {worst_ph} deg");
    }
}

#[test]
fn lead_step_and_impulse_equal_the_difference_equation() {
    let p = LeadParams::default();
    for fs in RATES {
        let (lead, d) = lead_f64(&p, 1.0 / fs);
        let (b0, b1, a1) = direct_form(&d);
        for input in [|n: usize| if n == 0 { 1.0 } else { 0.0 }, |_n: usize| 1.0] {
            let mut s = LeadState::default();
            let (mut y1, mut x1) = (0.0, 0.0);
            for n in 0..(fs as usize) {
                let x = input(n);
                let y = lead.process(&mut s, x);
                let yd = a1 * y1 + b0 * x + b1 * x1;
                assert!(
                    (y - yd).abs() <= 1e-9 * (1.0 + yd.abs()),
                    "{fs} Hz n={n}: {y} vs {yd}"
                );
                y1 = yd;
                x1 = x;
            }
        }
    }
}

#[test]
fn lead_dc_gain_is_exact() {
    let p = LeadParams::default();
    let want = 1.05e5 * 7.5 * 37.0 / 274.0;
    assert!((p.dc_gain() - want).abs() < 1e-9 * want);
    for fs in RATES {
        let (lead, d) = lead_f64(&p, 1.0 / fs);
        assert!((d.dc_gain() - want).abs() < 1e-9 * want);
        // Step response settles to the DC gain (5 s >> 1/w1 = 27 ms).
        let mut s = LeadState::default();
        let mut y = 0.0;
        for _ in 0..(5.0 * fs) as usize {
            y = lead.process(&mut s, 1.0);
        }
        assert!((y - want).abs() < 1e-9 * want, "{fs}: {y} vs {want}");
    }
}

/// Fixed point: DC gain from the quantised K_hf and g/2 alone, whatever kappa is; the
/// settled step response is within a few LSB of it.
#[test]
fn fixed_lead_dc_gain_within_coefficient_quantisation() {
    let p = LeadParams::default();
    let (y_fs, t_fs) = (1.0, 1.0e6);
    for fs in RATES {
        let d = p.discretise(1.0 / fs).expect("valid");
        let lead = Lead::<Fx>::new(&d.to_pu(y_fs, t_fs)).expect("fits");
        let q = lead.quantised();
        let dc_q = q.k_hf * (1.0 - 2.0 * q.g_half) * t_fs / y_fs;
        let want = p.dc_gain();
        assert!(
            (dc_q / want - 1.0).abs() < 1e-8,
            "{fs}: quantised DC {dc_q} vs {want}"
        );
        let x = Fx::from_f64(0.5);
        let mut s = LeadState::default();
        let mut y = Fx::ZERO;
        for _ in 0..(5.0 * fs) as usize {
            y = lead.process(&mut s, x);
        }
        let y_si = y.to_f64() * t_fs / (0.5 * y_fs);
        // Within the low-pass's dead band (0.5/kappa LSB, <= 64 LSB of Q4.28 at these
        // rates) on 0.053 pu: 5e-6 relative.
        assert!(
            (y_si / want - 1.0).abs() < 5e-6,
            "{fs}: settled {y_si} vs {want}"
        );
    }
}

#[test]
fn pi_step_response_equals_difference_equation() {
    let p = PiParams::default();
    for fs in RATES {
        let t = 1.0 / fs;
        let d = p.discretise(t).expect("valid");
        assert!((d.ki - p.kp * t / p.ti).abs() < 1e-15);
        let pi = Pi::<f64>::new(&d.to_pu(1.0, 1.0), -1e9, 1e9).expect("fits");
        let mut s = PiState::default();
        for n in 0..1000 {
            let u = pi.process(&mut s, 1.0);
            // u[n] = Kp e + Ki sum_{k<=n} e = Kp + Ki (n + 1)
            let want = p.kp + d.ki * (n as f64 + 1.0);
            assert!((u - want).abs() < 1e-9 * want, "{fs} n={n}: {u} vs {want}");
        }
        // Ramp-invariance: after 1 s the integral part is Kp t/Ti (the continuous PI).
        let mut s = PiState::default();
        let mut u = 0.0;
        for _ in 0..fs as usize {
            u = pi.process(&mut s, 1.0);
        }
        let cont = p.kp * (1.0 + 1.0 / p.ti);
        assert!((u - cont).abs() < 2.0 * d.ki + 1e-9, "{fs}: {u} vs {cont}");
    }
}

/// The lead's refusals name their cause: a yaw rate too low for the lead (with that rate),
/// and a pre-warp frequency at or past 0.45 of the yaw rate (`w_p T < 0.9 pi`).
#[test]
fn the_leads_refusals_name_the_rate_and_the_prewarp() {
    let p = LeadParams::default();
    match p.discretise(1.0 / 100.0) {
        Err(ConfigError::Range { field, value, .. }) => {
            assert_eq!((field, value), ("yaw rate", 100.0));
        }
        other => panic!("{other:?}"),
    }
    let field = |wp: f64, t: f64| match (LeadParams {
        prewarp_rad_s: wp,
        ..p
    })
    .discretise(t)
    {
        Err(ConfigError::Range { field, .. }) => field,
        other => panic!("{other:?}"),
    };
    // At exactly 0.9 pi (t = 0.5 s, so the product is exact), between 0.9 pi and pi, and
    // negative.
    let t = 0.5;
    assert_eq!(field(PI * 1.8, t), "lead.prewarp_rad_s");
    assert_eq!(field(3.0 / t, t), "lead.prewarp_rad_s");
    assert_eq!(field(-1.0, 1e-3), "lead.prewarp_rad_s");
    // Just below the edge the pre-warp is taken (the lead at 2 kHz, pre-warped to 400 Hz).
    assert!(LeadParams {
        prewarp_rad_s: 2.0 * PI * 400.0,
        ..p
    }
    .discretise(5e-4)
    .is_ok());
}

#[test]
fn invalid_discretisations_are_refused() {
    let p = LeadParams::default();
    assert!(
        p.discretise(1.0 / 100.0).is_err(),
        "w2 T/2 > 1 must be refused"
    );
    assert!(p.discretise(f64::NAN).is_err());
    let bad = LeadParams { w1: 300.0, ..p };
    assert!(bad.discretise(1e-3).is_err());
    let warp = LeadParams {
        prewarp_rad_s: 1e5,
        ..p
    };
    assert!(warp.discretise(1e-3).is_err());
    assert!(PiParams { kp: 1.0, ti: 0.0 }.discretise(1e-3).is_err());
    assert!(PiParams {
        kp: f64::INFINITY,
        ti: 0.5
    }
    .discretise(1e-3)
    .is_err());
}

/// The backward-Euler PI against `Kp (1 + 1/(Ti s))`: `1/(1 - z^-1) = 1/(jwT) + 1/2 +
/// O(wT)`, a half-sample lead on the integral term only. Stated tolerance: within 0.1 %
/// in magnitude and 0.1 deg in phase from 0.1 Hz to fs/20 for Ti = 0.5 s, and within
/// 1.2 % / 0.6 deg for Ti = 0.05 s (the appendix's value; worst at 1 kHz).
#[test]
fn pi_frequency_response_within_tolerance_below_fs_over_20() {
    for (ti, tol_mag, tol_deg) in [(0.5, 1e-3, 0.1), (0.05, 1.2e-2, 0.6)] {
        let p = PiParams { kp: 1.0, ti };
        for fs in RATES {
            let t = 1.0 / fs;
            let d = p.discretise(t).expect("valid");
            let mut worst_mag: f64 = 0.0;
            let mut worst_ph: f64 = 0.0;
            for k in 0..=400 {
                let f = 0.1 * (fs / 20.0 / 0.1_f64).powf(k as f64 / 400.0);
                let w = 2.0 * std::f64::consts::PI * f;
                // H_d = Kp + Ki / (1 - e^{-jwT})
                let (c, s) = ((w * t).cos(), (w * t).sin());
                let (dr, di) = (1.0 - c, s);
                let m = dr * dr + di * di;
                let (hr, hi) = (d.kp + d.ki * dr / m, -d.ki * di / m);
                // H_c = Kp (1 - j/(w Ti))
                let (cr, ci) = (p.kp, -p.kp / (w * ti));
                let mag = ((hr * hr + hi * hi) / (cr * cr + ci * ci)).sqrt();
                worst_mag = worst_mag.max((mag - 1.0).abs());
                worst_ph = worst_ph.max((hi.atan2(hr) - ci.atan2(cr)).abs().to_degrees());
            }
            assert!(
                worst_mag < tol_mag,
                "Ti {ti}, {fs} Hz: magnitude {worst_mag}"
            );
            assert!(worst_ph < tol_deg, "Ti {ti}, {fs} Hz: phase {worst_ph} deg");
        }
    }
}

/// The lead in per unit: `K_hf` scaled by `y_dot_fs / torque_fs` (input over output full
/// scale), the low-pass and pole terms unscaled.
#[test]
fn the_lead_in_per_unit_scales_its_gain_by_input_over_output() {
    let (_, d) = lead_f64(&LeadParams::default(), 2e-4);
    let pu = d.to_pu(2.0, 4.0e4);
    assert!((pu.k_hf - d.k_hf * 2.0 / 4.0e4).abs() <= 1e-15 * pu.k_hf.abs());
    assert_eq!((pu.g_half, pu.kappa), (d.g / 2.0, d.kappa));
}
