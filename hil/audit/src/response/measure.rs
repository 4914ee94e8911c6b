//! The fixed-point (or any [`Sample`]) controller's response *measured*: a [`Drive`]
//! steps one controller isolated inside [`Controller`] with a sinusoid (or a constant),
//! and a least-squares fit of the settled output gives its gain and phase.

use super::*;

/// A driver of one controller inside [`Controller`]: an SI input sample in, the SI
/// output out, one controller step per call (the controller's own rate; the base tick
/// is repeated `divisor` times and the last output taken).
pub struct Drive<T: Sample> {
    ctrl: Controller<T>,
    /// The full scales of the configuration `ctrl` was built from.
    scales: wheelset_control::FullScales,
    kind: Kind,
    divisor: u16,
    /// Output divisor: the quantised gain (SI) for the predictor, else 1.
    out_div: f64,
}

impl<T: Sample> Drive<T> {
    /// Build from the isolated configuration of `kind`.
    pub fn new(kind: Kind, base: &Config) -> Result<Self, wheelset_control::ConfigError> {
        let cfg = isolate(kind, base);
        let divisor = if kind.is_yaw() {
            cfg.yaw_divisor
        } else {
            cfg.traction_divisor
        };
        let out_div = if kind == Kind::YawPredictor {
            coefficients::<T>(Kind::YawGain, &cfg)?
                .1
                .dc_gain()
                .unwrap_or(1.0)
        } else {
            1.0
        };
        Ok(Self {
            ctrl: Controller::try_new(&cfg)?,
            scales: cfg.scales,
            kind,
            divisor,
            out_div,
        })
    }

    /// One controller step on the SI input `x` (m/s of `y'`, or A of current error).
    pub fn step(&mut self, x: f64) -> f64 {
        let s = self.scales;
        let yaw = self.kind.is_yaw();
        let inp = if yaw {
            Inputs {
                y_dot: T::from_f64(x / s.y_dot),
                ..Inputs::default()
            }
        } else {
            // Reference 0 (no demand), so e = -i_a: drive i_a = -x.
            Inputs {
                current: T::from_f64(-x / s.current),
                ..Inputs::default()
            }
        };
        let mut out = self.ctrl.tick(&inp);
        for _ in 1..self.divisor {
            out = self.ctrl.tick(&inp);
        }
        if yaw {
            out.yaw_torque.to_f64() * s.torque / self.out_div
        } else {
            out.voltage.to_f64() * s.voltage
        }
    }
}

/// Least-squares fit of `y[n] ~ a sin(w n) + b cos(w n) + d`; returns `(a, b, d)`.
fn fit_sine(y: &[f64], w: f64, n0: usize) -> (f64, f64, f64) {
    // The normal equations `(R^T R) x = R^T y`, solved by LU decomposition.
    let mut m = nalgebra::Matrix3::<f64>::zeros();
    let mut rhs = nalgebra::Vector3::<f64>::zeros();
    for (k, &v) in y.iter().enumerate() {
        let ph = w * (n0 + k) as f64;
        let r = nalgebra::Vector3::new(ph.sin(), ph.cos(), 1.0);
        m += r * r.transpose();
        rhs += r * v;
    }
    match m.lu().solve(&rhs) {
        Some(x) => (x[0], x[1], x[2]),
        None => (0.0, 0.0, 0.0),
    }
}

/// Stimulus amplitudes of the measured responses, SI: `y'` 10 mm/s (a typical hunting
/// amplitude, the lead's output below the torque limit), a current error of 10 A.
pub fn measure_amplitude(kind: Kind) -> f64 {
    if kind.is_yaw() {
        0.01
    } else {
        10.0
    }
}

/// Settling steps before fitting: 30 time constants of the lead's pole; none otherwise
/// (the PI's constant integrator offset is fitted as `d`).
fn settle_steps(kind: Kind, cfg: &Config) -> usize {
    match kind {
        Kind::YawLead => {
            let d = cfg.lead.discretise(cfg.yaw_period());
            match d {
                Ok(d) if d.alpha > 0.0 && d.alpha < 1.0 => (30.0 / -d.alpha.ln()).ceil() as usize,
                _ => 1000,
            }
        }
        // The predictor needs one previous sample; the PI's constant offset is fitted.
        Kind::YawPredictor => 2,
        _ => 0,
    }
}

/// The response of the controller as it runs with sample type `T`, *measured*: drive it
/// with `amp sin(2 pi f n T)` (`amp` in the SI input unit; the audit's from
/// [`measure_amplitude`]), let it settle, fit a sine, cosine and constant over an integer
/// number of periods of at least 2000 samples.
pub fn measured_at<T: Sample>(
    kind: Kind,
    cfg: &Config,
    f_hz: f64,
    amp: f64,
) -> Result<C64, wheelset_control::ConfigError> {
    let mut d = Drive::<T>::new(kind, cfg)?;
    let fs = kind.rate_hz(cfg);
    let w = 2.0 * std::f64::consts::PI * f_hz / fs;
    let settle = settle_steps(kind, cfg);
    let per = fs / f_hz;
    let cycles = (2000.0 / per).ceil().max(1.0);
    let n = (cycles * per).round().max(8.0) as usize;
    let y: Vec<f64> = (0..settle + n)
        .map(|k| d.step(amp * (w * k as f64).sin()))
        .skip(settle)
        .collect();
    let (a, b, _) = fit_sine(&y, w, settle);
    Ok(C64::new(a / amp, b / amp))
}

/// The DC gain measured on the running controller: a constant input (SI: `y'` 0.15 m/s,
/// or 10 A) held 60 lead time constants, output over input. `None` for the PI.
pub fn measured_dc<T: Sample>(
    kind: Kind,
    cfg: &Config,
) -> Result<Option<f64>, wheelset_control::ConfigError> {
    if kind == Kind::TractionPi {
        return Ok(None);
    }
    let mut d = Drive::<T>::new(kind, cfg)?;
    let x = 0.15;
    let n = 2 * settle_steps(kind, cfg) + 2;
    let y = (0..n).fold(0.0, |_, _| d.step(x));
    // The input as the controller saw it (quantised).
    let xq = T::from_f64(x / cfg.scales.y_dot).to_f64() * cfg.scales.y_dot;
    Ok(Some(y / xq))
}
