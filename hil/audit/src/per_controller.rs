//! The per-controller audit: coefficients, poles/zeros, DC gain, frequency response
//! (analytic and measured on the running controller), limit cycles.

use wheelset_control::{Config, ConfigError, Sample};

use super::limits;
use super::model::{CoefRow, ControllerAudit, DcGain, FreqPoint, PoleZero, Roots, Worst};
use super::response::{self, Coeffs, Kind};
use super::tolerances::Tolerances;

/// The named frequencies of the audit's responses, Hz.
pub const NAMED_HZ: [f64; 5] = [1.0, 10.0, 16.0, 50.0, 100.0];

/// The frequency grid: the named points plus 40 log-spaced points 0.1 Hz .. 0.45 fs.
pub fn grid(fs: f64) -> Vec<(f64, bool)> {
    let (a, b) = (0.1f64, 0.45 * fs);
    let n = 40;
    let mut v: Vec<(f64, bool)> = (0..n)
        .map(|i| (a * (b / a).powf(i as f64 / (n - 1) as f64), false))
        .filter(|(f, _)| !NAMED_HZ.iter().any(|g| (g - f).abs() < 1e-9))
        .collect();
    v.extend(
        NAMED_HZ
            .iter()
            .filter(|f| **f < 0.5 * fs)
            .map(|f| (*f, true)),
    );
    v.sort_by(|x, y| x.0.total_cmp(&y.0));
    v
}

pub fn audit_controller<T: Sample>(
    kind: Kind,
    cfg: &Config,
    tol: &Tolerances,
    lsb: f64,
    freqs: &[(f64, bool)],
) -> Result<ControllerAudit, ConfigError> {
    let fs = kind.rate_hz(cfg);
    let t_s = 1.0 / fs;
    let (ideal, quant) = response::coefficients::<T>(kind, cfg)?;
    let coefficients = ideal
        .list()
        .iter()
        .zip(quant.list())
        .map(|((n, v, u, scaled), (_, q, _, _))| CoefRow {
            name: n.to_string(),
            unit: u.to_string(),
            ideal_pu: if *scaled { v / kind.pu_to_si(cfg) } else { *v },
            ideal: *v,
            quantised: q,
            abs_err: q - v,
            rel_err: if *v != 0.0 { (q - v) / v } else { 0.0 },
        })
        .collect();
    let (cp, cz, cdc) = response::continuous_pz(kind, cfg);
    let roots = |c: &Coeffs| {
        let (p, z) = c.poles_zeros();
        Roots {
            poles_s: p.iter().map(|&r| response::z_to_s(r, t_s)).collect(),
            zeros_s: z.iter().map(|&r| response::z_to_s(r, t_s)).collect(),
            poles_z: p,
            zeros_z: z,
        }
    };
    let rf = roots(&ideal);
    let rq = roots(&quant);
    let cat = |r: &Roots, s: bool| -> Vec<f64> {
        if s {
            r.poles_s.iter().chain(&r.zeros_s).copied().collect()
        } else {
            r.poles_z.iter().chain(&r.zeros_z).copied().collect()
        }
    };
    let cont = Roots {
        poles_z: vec![],
        zeros_z: vec![],
        poles_s: cp,
        zeros_s: cz,
    };
    let shift = |a: Vec<f64>, b: Vec<f64>, f: fn(f64, f64) -> f64| -> Vec<f64> {
        a.into_iter().zip(b).map(|(a, b)| f(a, b)).collect()
    };
    let poles_zeros = PoleZero {
        shift_quantisation_z: shift(cat(&rq, false), cat(&rf, false), |a, b| a - b),
        shift_quantisation_rel: shift(cat(&rq, true), cat(&rf, true), |a, b| {
            if b != 0.0 {
                (a - b) / b
            } else {
                a - b
            }
        }),
        shift_discretisation_s: shift(cat(&rf, true), cat(&cont, true), |a, b| a - b),
        continuous: cont,
        discrete_f64: rf,
        discrete_quantised: rq,
    };
    let fixed_dc = response::measured_dc::<T>(kind, cfg)?;
    let dc_gain = DcGain {
        continuous: cdc,
        discrete_f64: ideal.dc_gain(),
        fixed: fixed_dc,
        discrete_quantised: quant.dc_gain(),
        fixed_vs_continuous_rel: fixed_dc.zip(cdc).map(|(a, b)| (a - b) / b),
    };
    let point = |&(f, named): &(f64, bool)| -> Result<FreqPoint, ConfigError> {
        let c = response::continuous(kind, cfg, f);
        let d = ideal.response(f, t_s);
        let dq = quant.response(f, t_s);
        let amp = response::measure_amplitude(kind);
        let fx = response::measured_at::<T>(kind, cfg, f, amp)?;
        let fm = response::measured_at::<f64>(kind, cfg, f, amp)?;
        Ok(FreqPoint {
            f_hz: f,
            named,
            continuous: c.into(),
            discrete_f64: d.into(),
            fixed: fx.into(),
            discrete_quantised: dq.into(),
            discrete_f64_measured: fm.into(),
            fixed_vs_f64_db: response::gain_err_db(fx, d),
            fixed_vs_f64_deg: response::phase_err_deg(fx, d),
            f64_vs_continuous_db: response::gain_err_db(d, c),
            f64_vs_continuous_deg: response::phase_err_deg(d, c),
        })
    };
    let freq_response = freqs
        .iter()
        .filter(|p| p.0 < 0.5 * fs)
        .map(point)
        .collect::<Result<Vec<_>, _>>()?;
    let below = tol.frac_fs * fs;
    let worst_of = |g: &dyn Fn(&FreqPoint) -> f64| {
        freq_response
            .iter()
            .filter(|p| p.f_hz <= below)
            .map(|p| (g(p), p.f_hz))
            .fold(
                (0.0f64, 0.0f64),
                |a, b| if b.0.abs() > a.0.abs() { b } else { a },
            )
    };
    let worst = Worst {
        below_hz: below,
        fixed_gain_db: worst_of(&|p| p.fixed_vs_f64_db),
        fixed_phase_deg: worst_of(&|p| p.fixed_vs_f64_deg),
        discrete_gain_db: worst_of(&|p| p.f64_vs_continuous_db),
        discrete_phase_deg: worst_of(&|p| p.f64_vs_continuous_deg),
        measurement_gain_db: freq_response
            .iter()
            .map(|p| (20.0 * (p.discrete_f64_measured.gain / p.discrete_f64.gain).log10()).abs())
            .fold(0.0, f64::max),
    };
    let limit_cycles = limits::limit_cycles::<T>(kind, cfg, lsb)?;
    let (name, unit, law) = kind.words();
    Ok(ControllerAudit {
        name: name.to_string(),
        rate_hz: fs,
        law: law.to_string(),
        unit: unit.to_string(),
        coefficients,
        poles_zeros,
        dc_gain,
        freq_response,
        worst,
        measure_amplitude: response::measure_amplitude(kind),
        limit_cycles,
    })
}
