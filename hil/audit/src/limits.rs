//! Limit cycles and dead bands: after a disturbance, hold the input at zero or at a small
//! constant and watch the fixed-point output settle (or not) against the f64 one.
//!
//! Disturbance: a burst of 0.2 s of deterministic pseudo-random input at 10 % of the
//! input clamp. Then the hold input for `2 s`; the last second is the observation
//! window: a sustained oscillation is `max - min > 0` of the output there (reported as
//! the amplitude `(max - min)/2`), a dead band is the offset of the window's mean from
//! the f64 controller's final value.

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use serde::Serialize;
use wheelset_control::{Config, Sample};

use super::response::{Drive, Kind};

/// The outcome of one limit-cycle run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LimitCycle {
    /// Controller.
    pub controller: String,
    /// The held input after the disturbance, SI (`y'` m/s or current error A).
    pub hold_input_si: f64,
    /// Description of the hold input.
    pub hold: String,
    /// Peak-to-peak of the fixed-point output in the window, output LSBs of the signal format.
    pub p2p_lsb: f64,
    /// Oscillation amplitude `(max - min)/2`, SI.
    pub amplitude_si: f64,
    /// The output moves in the window (`p2p > 0.5 LSB`).
    pub oscillates: bool,
    /// One definition ([`super::closed`]): `none`, `bounded dither` (the output moves
    /// by at most one LSB of its format, e.g. the PI integrator stepping by one LSB on a
    /// ramp) or `self-sustained oscillation` (more than one LSB without a driving input).
    pub classification: String,
    /// Period of the oscillation in samples (from the zero crossings of the mean-removed
    /// output), if it oscillates.
    pub period_samples: Option<f64>,
    /// Final offset of the fixed output from the f64 one, SI (a dead band).
    pub offset_si: f64,
    /// The same in output LSBs.
    pub offset_lsb: f64,
    /// Output unit.
    pub unit: String,
}

/// Run the limit-cycle checks of `kind` with sample type `T` whose signal LSB (pu) is
/// `lsb`.
pub fn limit_cycles<T: Sample>(
    kind: Kind,
    cfg: &Config,
    lsb: f64,
) -> Result<Vec<LimitCycle>, wheelset_control::ConfigError> {
    if kind == Kind::YawPredictor {
        // FIR: no recursion, no limit cycle.
        return Ok(Vec::new());
    }
    let fs = kind.rate_hz(cfg);
    let (s, w) = (&cfg.scales, &cfg.wire);
    // The burst's amplitude (the PI's error well inside the voltage limits), scales, unit.
    let (amp, in_fs, out_fs, unit, wire) = if kind.is_yaw() {
        (0.1 * cfg.limits.y_dot, s.y_dot, s.torque, "N m", w.y_dot)
    } else {
        (5.0, s.current, s.voltage, "V", w.current)
    };
    let burst = (0.2 * fs) as usize;
    let hold_n = (2.0 * fs) as usize;
    let win = (1.0 * fs) as usize;
    let holds = [
        (0.0, "zero".to_string()),
        (in_fs * lsb, "1 LSB of the signal format".to_string()),
        (in_fs * 3.0 * lsb, "3 LSB of the signal format".to_string()),
        (wire, "1 wire LSB".to_string()),
    ];
    let mut out = Vec::new();
    for (x_hold, label) in holds {
        let mut a = Drive::<T>::new(kind, cfg)?;
        let mut b = Drive::<f64>::new(kind, cfg)?;
        let mut rng = Pcg64::seed_from_u64(0x1234_5678);
        for _ in 0..burst {
            let x = amp * rng.random_range(-1.0..1.0);
            a.step(x);
            b.step(x);
        }
        let mut ya = Vec::with_capacity(win);
        let mut yb = 0.0;
        for k in 0..hold_n {
            let y = a.step(x_hold);
            yb = b.step(T::from_f64(x_hold / in_fs).to_f64() * in_fs);
            if k >= hold_n - win {
                ya.push(y);
            }
        }
        let mean = ya.iter().sum::<f64>() / ya.len().max(1) as f64;
        let out_lsb = lsb * out_fs;
        // A constant error ramps the PI's integrator: judge its first difference.
        let (osc_src, last) = if kind == Kind::TractionPi {
            (
                ya.windows(2).map(|w| w[1] - w[0]).collect::<Vec<_>>(),
                *ya.last().unwrap_or(&0.0),
            )
        } else {
            (ya.clone(), mean)
        };
        let (omn, omx) = osc_src
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| {
                (a.min(v), b.max(v))
            });
        let op2p = if osc_src.is_empty() { 0.0 } else { omx - omn };
        let oscillates = op2p > 0.5 * out_lsb;
        let period = if oscillates {
            let m = osc_src.iter().sum::<f64>() / osc_src.len() as f64;
            let crossings = osc_src
                .windows(2)
                .filter(|w| (w[0] - m) * (w[1] - m) < 0.0)
                .count();
            (crossings > 1).then(|| 2.0 * osc_src.len() as f64 / crossings as f64)
        } else {
            None
        };
        let offset = last - yb;
        out.push(LimitCycle {
            controller: kind.words().0.to_string(),
            hold_input_si: x_hold,
            hold: label,
            p2p_lsb: op2p / out_lsb,
            amplitude_si: op2p / 2.0,
            oscillates,
            classification: if !oscillates {
                "none".into()
            } else if op2p <= out_lsb * (1.0 + 1e-9) {
                "bounded dither".into()
            } else {
                "self-sustained oscillation".into()
            },
            period_samples: period,
            offset_si: offset,
            offset_lsb: offset / out_lsb,
            unit: unit.to_string(),
        });
    }
    Ok(out)
}
