//! Transfer functions of the three controllers: continuous (docs/model.md), discrete from the
//! f64 coefficients, discrete from the quantised coefficients (computed), and the
//! fixed-point controller's response *measured* by driving it with sinusoids and fitting.
//! Poles, zeros and DC gains.
//!
//! Units: the yaw controllers map `y'` (m/s) to `T_psi` (N m): gain in N m s/m; the PI
//! maps the current error `e = i_ref - i_a` (A) to `u_a` (V): gain in V/A.

use wheelset_control::{Config, Controller, Inputs, LeadPu, PiPu, Sample, YawMode};

mod measure;
pub use measure::{measure_amplitude, measured_at, measured_dc, Drive};

/// A complex number (`num_complex`'s, as nalgebra re-exports it).
pub type C64 = nalgebra::Complex<f64>;

/// The audited controllers.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Kind {
    /// Phase-lead yaw damping `Ks(s) = K a (s + w1)/(s + w2)` on `y'`.
    YawLead,
    /// Pure-gain yaw damping `T_psi = K y'`.
    YawGain,
    /// PI traction current loop `Kp (1 + 1/(Ti s))` on `i_ref - i_a`.
    TractionPi,
    /// The optional `y'` predictor (delay compensation) ahead of the yaw law,
    /// `x = y' + alpha (y'[n] - y'[n-1])`; audited when enabled.
    YawPredictor,
}

impl Kind {
    /// The filters active under `cfg`, in report order: the three controllers, then the
    /// predictor if enabled.
    pub fn active(cfg: &Config) -> Vec<Kind> {
        let predictor = (cfg.yaw_predict_ticks > 0.0).then_some(Kind::YawPredictor);
        let all = [Kind::YawLead, Kind::YawGain, Kind::TractionPi];
        all.into_iter().chain(predictor).collect()
    }
    /// `(name in the JSON and the report, gain unit, the continuous law as in
    /// docs/model.md)`.
    pub fn words(self) -> (&'static str, &'static str, &'static str) {
        match self {
            Kind::YawLead => (
                "yaw_lead",
                "N m s/m",
                "Ks(s) = K a (s + w1)/(s + w2), Tustin",
            ),
            Kind::YawGain => ("yaw_gain", "N m s/m", "T_psi = K y'"),
            Kind::TractionPi => (
                "traction_pi",
                "V/A",
                "Kt(s) = Kp (1 + 1/(Ti s)), backward-Euler integrator",
            ),
            Kind::YawPredictor => (
                "yaw_predictor",
                "1 (x per y')",
                "x = y' + alpha (y'[n] - y'[n-1]), alpha = yaw_predict_ticks/yaw_divisor; \
                 reference: the ideal advance e^(s tau), tau = yaw_predict_ticks base periods \
                 (FIR: no limit cycles)",
            ),
        }
    }
    /// A filter of the yaw loop (`y'` in, `T_psi` out), not the traction PI.
    pub fn is_yaw(self) -> bool {
        self != Kind::TractionPi
    }
    /// Sample rate of this controller under `cfg`, Hz.
    pub fn rate_hz(self, cfg: &Config) -> f64 {
        1.0 / if self.is_yaw() {
            cfg.yaw_period()
        } else {
            cfg.traction_period()
        }
    }
    /// SI per per-unit of the output over SI per per-unit of the input: a pu gain times
    /// this is the SI gain.
    pub fn pu_to_si(self, cfg: &Config) -> f64 {
        let s = &cfg.scales;
        match self {
            Kind::YawLead | Kind::YawGain => s.torque / s.y_dot,
            Kind::TractionPi => s.voltage / s.current,
            Kind::YawPredictor => 1.0,
        }
    }
}

/// Continuous frequency response at `f_hz` (SI units), from the configuration's
/// continuous parameters.
pub fn continuous(kind: Kind, cfg: &Config, f_hz: f64) -> C64 {
    let s = C64::new(0.0, 2.0 * std::f64::consts::PI * f_hz);
    match kind {
        Kind::YawLead => {
            let l = &cfg.lead;
            (s + l.w1) / (s + l.w2) * (l.k * l.a)
        }
        Kind::YawGain => C64::new(cfg.gain_k, 0.0),
        Kind::TractionPi => {
            let p = &cfg.pi;
            (1.0 + 1.0 / (s * p.ti)) * p.kp
        }
        Kind::YawPredictor => C64::cis(s.im * cfg.yaw_predict_ticks * cfg.base_period()),
    }
}

/// A controller's discrete coefficients in SI units (one set: f64 or quantised).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Coeffs {
    /// Lead: `y = K_hf (x - z)`, `z += kappa ((g/2)(x + x1) - z)`.
    Lead {
        /// `K_hf`, N m s/m.
        k_hf: f64,
        g_half: f64,
        kappa: f64,
    },
    /// Gain `K`, N m s/m.
    Gain { k: f64 },
    /// Predictor `x = y + alpha (y[n] - y[n-1])`.
    Predictor { alpha: f64 },
    /// PI: `u = Kp e + I`, `I += Ki e`.
    Pi {
        /// `Kp`, V/A.
        kp: f64,
        /// `Ki = Kp T/Ti`, V/A per sample.
        ki: f64,
    },
}

impl Coeffs {
    pub fn lead(pu: &LeadPu, cfg: &Config) -> Self {
        Coeffs::Lead {
            k_hf: pu.k_hf * Kind::YawLead.pu_to_si(cfg),
            g_half: pu.g_half,
            kappa: pu.kappa,
        }
    }
    pub fn pi(pu: &PiPu, cfg: &Config) -> Self {
        let k = Kind::TractionPi.pu_to_si(cfg);
        Coeffs::Pi {
            kp: pu.kp * k,
            ki: pu.ki * k,
        }
    }

    /// `(name, value, unit, scaled)` of each coefficient, SI; `scaled` = its per-unit
    /// value is the SI one over [`Kind::pu_to_si`] (else the two are equal).
    pub fn list(&self) -> Vec<(&'static str, f64, &'static str, bool)> {
        match *self {
            Coeffs::Lead {
                k_hf,
                g_half,
                kappa,
            } => vec![
                ("k_hf", k_hf, "N m s/m", true),
                ("g_half", g_half, "1", false),
                ("kappa", kappa, "1", false),
            ],
            Coeffs::Gain { k } => vec![("k", k, "N m s/m", true)],
            Coeffs::Predictor { alpha } => vec![("alpha", alpha, "1", false)],
            Coeffs::Pi { kp, ki } => {
                vec![("kp", kp, "V/A", true), ("ki", ki, "V/A per sample", true)]
            }
        }
    }

    /// The discrete transfer function at `z = e^{j 2 pi f T}`.
    pub fn response(&self, f_hz: f64, t_s: f64) -> C64 {
        let zi = C64::cis(-2.0 * std::f64::consts::PI * f_hz * t_s); // z^-1
        match *self {
            Coeffs::Lead { .. } => {
                let (b0, b1, a1) = self.lead_direct_form();
                (b0 + zi * b1) / (1.0 - zi * a1)
            }
            Coeffs::Gain { k } => C64::new(k, 0.0),
            Coeffs::Predictor { alpha } => (1.0 + alpha) - zi * alpha,
            Coeffs::Pi { kp, ki } => kp + ki / (1.0 - zi),
        }
    }

    /// Lead direct form `(b0, b1, a1)` of `y[n] = a1 y[n-1] + b0 x[n] + b1 x[n-1]`:
    /// with `h = kappa g/2`, `alpha = 1 - kappa`: `b0 = K(1 - h)`, `b1 = -K(alpha + h)`,
    /// `a1 = alpha`. Zeros for the other forms.
    pub fn lead_direct_form(&self) -> (f64, f64, f64) {
        match *self {
            Coeffs::Lead {
                k_hf,
                g_half,
                kappa,
            } => {
                let h = kappa * g_half;
                let alpha = 1.0 - kappa;
                (k_hf * (1.0 - h), -k_hf * (alpha + h), alpha)
            }
            _ => (0.0, 0.0, 0.0),
        }
    }

    /// DC gain; `None` = infinite (the PI's integrator).
    pub fn dc_gain(&self) -> Option<f64> {
        match *self {
            Coeffs::Lead { .. } => {
                let (b0, b1, a1) = self.lead_direct_form();
                Some((b0 + b1) / (1.0 - a1))
            }
            Coeffs::Gain { k } => Some(k),
            Coeffs::Predictor { .. } => Some(1.0),
            Coeffs::Pi { .. } => None,
        }
    }

    /// Discrete poles and zeros (real, in the z-plane).
    pub fn poles_zeros(&self) -> (Vec<f64>, Vec<f64>) {
        match *self {
            Coeffs::Lead { .. } => {
                let (b0, b1, a1) = self.lead_direct_form();
                (vec![a1], vec![-b1 / b0])
            }
            Coeffs::Gain { .. } => (vec![], vec![]),
            // (1 + alpha) - alpha z^-1: a zero at alpha/(1 + alpha) (FIR).
            Coeffs::Predictor { alpha } => (vec![], vec![alpha / (1.0 + alpha)]),
            // U/E = ((Kp + Ki) - Kp z^-1)/(1 - z^-1)
            Coeffs::Pi { kp, ki } => (vec![1.0], vec![kp / (kp + ki)]),
        }
    }
}

/// Continuous poles and zeros (real, rad/s) and DC gain (`None` = infinite).
pub fn continuous_pz(kind: Kind, cfg: &Config) -> (Vec<f64>, Vec<f64>, Option<f64>) {
    match kind {
        Kind::YawLead => (
            vec![-cfg.lead.w2],
            vec![-cfg.lead.w1],
            Some(cfg.lead.dc_gain()),
        ),
        Kind::YawGain => (vec![], vec![], Some(cfg.gain_k)),
        Kind::TractionPi => (vec![0.0], vec![-1.0 / cfg.pi.ti], None),
        Kind::YawPredictor => (vec![], vec![], Some(1.0)),
    }
}

/// Equivalent continuous root of a discrete one by the inverse bilinear map
/// `s = (2/T)(z - 1)/(z + 1)`, rad/s (exact inverse of plain Tustin).
pub fn z_to_s(z: f64, t_s: f64) -> f64 {
    2.0 / t_s * (z - 1.0) / (z + 1.0)
}

/// The f64 and the quantised coefficients of `kind` for sample type `T` under `cfg`.
pub fn coefficients<T: Sample>(
    kind: Kind,
    cfg: &Config,
) -> Result<(Coeffs, Coeffs), wheelset_control::ConfigError> {
    let c = Controller::<T>::try_new(cfg)?;
    let s = &cfg.scales;
    Ok(match kind {
        Kind::YawLead => {
            let ideal = cfg
                .lead
                .discretise(cfg.yaw_period())?
                .to_pu(s.y_dot, s.torque);
            (
                Coeffs::lead(&ideal, cfg),
                Coeffs::lead(&c.compiled().lead().quantised(), cfg),
            )
        }
        Kind::YawGain => {
            let q = crate::bounds::qc::<T>("gain_k (pu)", cfg.gain_k * s.y_dot / s.torque)?;
            (
                Coeffs::Gain { k: cfg.gain_k },
                Coeffs::Gain {
                    k: q * s.torque / s.y_dot,
                },
            )
        }
        Kind::TractionPi => {
            let ideal = cfg
                .pi
                .discretise(cfg.traction_period())?
                .to_pu(s.current, s.voltage);
            (
                Coeffs::pi(&ideal, cfg),
                Coeffs::pi(&c.compiled().pi().quantised(), cfg),
            )
        }
        Kind::YawPredictor => {
            // The controller multiplies by alpha/2 twice (keeps it in Q1.31).
            let half = cfg.yaw_predict_ticks / (2.0 * cfg.yaw_divisor as f64);
            let q = crate::bounds::qc::<T>("yaw_predict_ticks/(2 yaw_divisor)", half)?;
            (
                Coeffs::Predictor { alpha: 2.0 * half },
                Coeffs::Predictor { alpha: 2.0 * q },
            )
        }
    })
}

/// The configuration that isolates `kind` inside the whole controller: yaw mode lead or
/// gain with traction off, or yaw passive with traction on; the y' predictor off.
pub fn isolate(kind: Kind, base: &Config) -> Config {
    let (yaw_mode, traction_enabled) = match kind {
        Kind::YawLead => (YawMode::Lead, false),
        Kind::YawGain | Kind::YawPredictor => (YawMode::Gain, false),
        Kind::TractionPi => (YawMode::Passive, true),
    };
    // The y' predictor is audited on its own, behind the gain (its value divided out).
    let predictor = kind == Kind::YawPredictor;
    Config {
        yaw_mode,
        traction_enabled,
        yaw_predict_ticks: if predictor {
            base.yaw_predict_ticks
        } else {
            0.0
        },
        ..*base
    }
}

/// Gain error `20 log10(|a|/|b|)`, dB.
pub fn gain_err_db(a: C64, b: C64) -> f64 {
    20.0 * (a.norm() / b.norm()).log10()
}

/// Phase error `arg(a) - arg(b)` wrapped to `(-180, 180]`, degrees.
pub fn phase_err_deg(a: C64, b: C64) -> f64 {
    let mut d = (a.arg() - b.arg()).to_degrees();
    while d > 180.0 {
        d -= 360.0;
    }
    while d <= -180.0 {
        d += 360.0;
    }
    d
}
