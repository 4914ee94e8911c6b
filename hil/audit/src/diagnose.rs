//! Findings attributed by experiment: each error is re-measured with one source removed
//! and the difference is that source's share.
//!
//! - **PI steady error** (the `u_a` error against f64 in the full-scale steps): the f64
//!   reference is rebuilt holding the quantised `Ki` (its `Ti` chosen so that `Kp T/Ti`
//!   is the quantised value), then also the quantised ramp steps (current-reference
//!   rate, safe-state ramps); what remains is the arithmetic's rounding and the other
//!   constants. The remedy recommended is the one that removes the largest share.
//! - **Lead response over the stimulus amplitude**: the fixed-point lead measured (as
//!   the frequency responses are) at amplitudes from 10 mm/s down to the wire LSB of
//!   `y'` (1 um/s), at the named frequencies up to `frac_fs` of the rate, against the
//!   discrete f64 response; the amplitude below which it leaves the warn tolerance.

use serde::Serialize;
use wheelset_control::{Config, ConfigError, Fx};

use super::bounds::Quantised;
use super::qdyn::QFormat;
use super::ranges::{self, Phase, Scenario};
use super::response::{self, Kind};
use super::tolerances::Tolerances;
use super::NAMED_HZ;

/// The PI's steady error attributed to its sources.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PiAttribution {
    /// Scenario.
    pub scenario: String,
    /// Max |u_a fixed - f64|, signal LSBs, against the plain f64 reference.
    pub baseline_lsb: f64,
    /// The same with the reference holding the quantised `Ki`.
    pub with_quantised_ki_lsb: f64,
    /// ... and the quantised ramp steps as well.
    pub with_quantised_ki_and_ramps_lsb: f64,
    /// `(source, share in LSB)`, largest first.
    pub shares: Vec<(String, f64)>,
    /// `Ki`'s significant bits in the coefficient format (Q1.31 holding `Ki 2^s`).
    pub ki_significant_bits: f64,
    /// `Ki`'s shift `s` (the coefficient is `Ki 2^s`; 0: none).
    pub ki_shift: u32,
    /// Relative quantisation error of `Ki`.
    pub ki_rel_err: f64,
    /// The remedy for the largest share.
    pub remedy: String,
}

impl PiAttribution {
    /// The shares as the reports write them: `source x.x LSB`, comma-separated.
    #[must_use]
    pub fn shares_text(&self) -> String {
        self.shares
            .iter()
            .map(|(n, v)| format!("{n} {v:.1} LSB"))
            .collect::<Vec<_>>()
            .join(", ")
    }
}

/// One amplitude of the lead's sweep.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AmplitudePoint {
    /// Stimulus amplitude, m/s of `y'`.
    pub amplitude_mps: f64,
    /// Worst |gain error| fixed vs f64 over the named frequencies, dB.
    pub gain_db: f64,
    /// Worst |phase error|, degrees.
    pub phase_deg: f64,
}

/// The lead's response error over the stimulus amplitude.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct AmplitudeSweep {
    /// Frequencies measured, Hz.
    pub freqs_hz: Vec<f64>,
    /// Descending amplitudes.
    pub points: Vec<AmplitudePoint>,
    /// The smallest amplitude from which up every point is within the warn tolerances
    /// (`null`: not even the largest).
    pub within_tolerance_down_to_mps: Option<f64>,
    /// In words.
    pub statement: String,
}

/// The diagnosis section.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Diagnosis {
    /// The PI's steady error.
    pub pi: Option<PiAttribution>,
    /// The lead over the amplitude.
    pub lead_amplitude: AmplitudeSweep,
}

fn u_a_err(
    cfg: &Config,
    sc: &Scenario,
    fmt: QFormat,
    adj: &dyn Fn(&Config) -> Config,
) -> Result<f64, ConfigError> {
    let o = ranges::observe::<Fx>(cfg, std::slice::from_ref(sc), fmt, adj)?;
    Ok(o.noise
        .iter()
        .filter(|n| n.output == "u_a" && n.phase == Phase::Normal && n.yaw_mode == "lead")
        .map(|n| n.max_lsb)
        .fold(0.0, f64::max))
}

/// Attribute the PI's `u_a` error in `sc` (production formats).
pub fn pi_attribution(cfg: &Config, sc: &Scenario) -> Result<PiAttribution, ConfigError> {
    let fmt = super::qdyn::Formats::PRODUCTION.signal;
    let k = Quantised::of::<Fx>(cfg)?;
    let s = cfg.scales;
    let tt = cfg.traction_period();
    let q_ki = move |c: &Config| {
        let mut c = *c;
        let ki_si = k.ki * s.voltage / s.current;
        c.pi.ti = c.pi.kp * tt / ki_si;
        c
    };
    let q_ramps = move |c: &Config| {
        let mut c = q_ki(c);
        let l = c.limits;
        c.limits.current_ref_rate = k.i_step * s.current / tt;
        let iref_max = l.demand / (c.motor.n * c.motor.k_m) / s.current;
        c.safe.traction_s = iref_max * tt / k.i_safe_step;
        c.safe.yaw_s = l.torque / s.torque * c.yaw_period() / k.t_step;
        c
    };
    let base = u_a_err(cfg, sc, fmt, &|c| *c)?;
    let no_ki = u_a_err(cfg, sc, fmt, &q_ki)?;
    let no_ramps = u_a_err(cfg, sc, fmt, &q_ramps)?;
    let mut shares = vec![
        ("quantisation of Ki".to_string(), base - no_ki),
        ("quantised ramp steps".to_string(), no_ki - no_ramps),
        (
            "arithmetic rounding and the other constants".to_string(),
            no_ramps,
        ),
    ];
    shares.sort_by(|a, b| b.1.total_cmp(&a.1));
    let ki_ideal = cfg.pi.kp * tt / cfg.pi.ti * s.current / s.voltage;
    let rel = (k.ki - ki_ideal) / ki_ideal;
    // Q1.31 holds Ki 2^s (Sample::mul_c_acc_shr shifts the product back by s).
    let sig_bits = (k.ki.abs() * 2f64.powi(31 + k.ki_shift as i32)).log2();
    let remedy = match shares.first().map(|s| s.0.as_str()) {
        Some("quantisation of Ki") => format!(
            "a finer representation of Ki: {:.1} significant bits in Q1.31 with its shift \
             s = {} (relative error {rel:.2e}); a larger shift (Ki 2^s in Q1.31, the product \
             shifted back by s) gives it more of the 31 bits. Error feedback on the \
             increment is already in place (Sample::mul_c_acc_shr) and is not the cause.",
            sig_bits, k.ki_shift
        ),
        Some("quantised ramp steps") => {
            "finer ramp steps (the current-reference increment per step in more bits)".into()
        }
        _ => "none cheap: the arithmetic's rounding dominates".into(),
    };
    Ok(PiAttribution {
        scenario: sc.name.clone(),
        baseline_lsb: base,
        with_quantised_ki_lsb: no_ki,
        with_quantised_ki_and_ramps_lsb: no_ramps,
        shares,
        ki_significant_bits: sig_bits,
        ki_shift: k.ki_shift,
        ki_rel_err: rel,
        remedy,
    })
}

/// The lead's response error over the stimulus amplitude.
pub fn lead_amplitude(cfg: &Config, tol: &Tolerances) -> Result<AmplitudeSweep, ConfigError> {
    let kind = Kind::YawLead;
    let fs = kind.rate_hz(cfg);
    let t_s = 1.0 / fs;
    let (ideal, _) = response::coefficients::<Fx>(kind, cfg)?;
    let freqs: Vec<f64> = NAMED_HZ
        .iter()
        .copied()
        .filter(|f| *f <= tol.frac_fs * fs)
        .collect();
    let amps = [1e-2, 3e-3, 1e-3, 3e-4, 1e-4, 3e-5, 1e-5, 3e-6, 1e-6];
    let point = |a: f64| -> Result<AmplitudePoint, ConfigError> {
        let (mut gain_db, mut phase_deg) = (0.0f64, 0.0f64);
        for &f in &freqs {
            let m = response::measured_at::<Fx>(kind, cfg, f, a)?;
            let d = ideal.response(f, t_s);
            gain_db = gain_db.max(response::gain_err_db(m, d).abs());
            phase_deg = phase_deg.max(response::phase_err_deg(m, d).abs());
        }
        Ok(AmplitudePoint {
            amplitude_mps: a,
            gain_db,
            phase_deg,
        })
    };
    let points = amps.into_iter().map(point).collect::<Result<Vec<_>, _>>()?;
    let ok = |x: &AmplitudePoint| {
        x.gain_db <= tol.fixed_gain_db.0 && x.phase_deg <= tol.fixed_phase_deg.0
    };
    let down_to = points
        .iter()
        .take_while(|x| ok(x))
        .last()
        .map(|x| x.amplitude_mps);
    let first_bad = points.iter().find(|x| !ok(x));
    let statement = match (down_to, first_bad) {
        (Some(a), Some(b)) => format!(
            "within the warn tolerances ({:.0e} dB, {:.0e} deg) down to {:.0e} m/s of y'; at \
             {:.0e} m/s the error is {:.2e} dB / {:.3} deg: below about {:.0e} m/s the \
             rounding and the dead band dominate the response, not the coefficients",
            tol.fixed_gain_db.0,
            tol.fixed_phase_deg.0,
            a,
            b.amplitude_mps,
            b.gain_db,
            b.phase_deg,
            a
        ),
        (Some(a), None) => {
            format!("within the warn tolerances at every amplitude down to {a:.0e} m/s")
        }
        (None, _) => "outside the warn tolerances already at 10 mm/s".into(),
    };
    Ok(AmplitudeSweep {
        freqs_hz: freqs,
        points,
        within_tolerance_down_to_mps: down_to,
        statement,
    })
}
