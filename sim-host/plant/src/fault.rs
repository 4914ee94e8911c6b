//! Plant-side faults of the yaw actuator, as scenario data (`[actuator_fault]`): from
//! the fault time on the actuator delivers `T_delivered = g T_commanded`, `g = 0`
//! (off), `f` (fraction) or `-1` (reversed); the passive spring is mechanical and not
//! affected. The continuous reference scales its (linear) yaw law by `g`, the sampled
//! loops the actuation they apply; the CSV's `T_ctrl_Nm` is the delivered torque.

use serde::{Deserialize, Serialize};

use crate::control::{ContinuousController, YawLaw};
use crate::error::ConfigError;
use crate::linear::closed_loop_a;
use crate::modes::{eigenvalues, structural_zero_index};
use crate::params::Params;
use crate::scenario::Axle;

/// How the yaw actuator fails.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FaultMode {
    /// Stops acting: its output is ignored (a disconnected or dead actuator), `g = 0`.
    Off,
    /// Acts at a fraction `f` of its command, `0 <= f < 1`.
    Fraction(f64),
    /// Acts with its sign reversed, `g = -1`.
    Reversed,
}

impl FaultMode {
    /// The delivered/commanded torque ratio `g` once failed.
    pub fn gain(self) -> f64 {
        match self {
            FaultMode::Off => 0.0,
            FaultMode::Fraction(f) => f,
            FaultMode::Reversed => -1.0,
        }
    }

    /// Short name (`off`, `fraction`, `reversed`).
    pub fn name(self) -> &'static str {
        match self {
            FaultMode::Off => "off",
            FaultMode::Fraction(_) => "fraction",
            FaultMode::Reversed => "reversed",
        }
    }
}

/// A yaw-actuator fault from `t_on_ns` on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ActuatorFault {
    /// Time of the failure, ns.
    pub t_on_ns: u64,
    /// How it fails.
    pub mode: FaultMode,
}

impl ActuatorFault {
    /// Delivered/commanded torque ratio at `t_ns` (1 before the failure).
    pub fn gain(&self, t_ns: u64) -> f64 {
        if t_ns < self.t_on_ns {
            1.0
        } else {
            self.mode.gain()
        }
    }

    /// The torque the actuator delivers at `t_ns` for the command `t_cmd` (N m).
    pub fn delivered(&self, t_ns: u64, t_cmd: f64) -> f64 {
        self.gain(t_ns) * t_cmd
    }

    /// Failure time, s.
    pub fn t_on_s(&self) -> f64 {
        self.t_on_ns as f64 * 1e-9
    }
}

/// A mode of a linearised loop: its eigenvalue `lambda = sigma + j 2 pi f`. Amplitudes
/// grow as `e^{sigma t}`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
pub struct FailedMode {
    /// Growth rate `sigma = Re(lambda)`, 1/s (> 0: unstable).
    pub sigma_per_s: f64,
    /// Frequency `Im(lambda)/(2 pi)`, Hz (0: a real mode).
    pub f_hz: f64,
}

/// The least stable mode (structural zero left out) of the loop whose yaw actuator
/// delivers `gain` times the command of `law`, linearised at straight-track pure
/// rolling: the law's gain `K` scaled by `gain`. `None` if the matrix is not finite.
pub fn faulty_loop_mode(
    p: &Params,
    axle: Axle,
    drive: bool,
    law: YawLaw,
    gain: f64,
) -> Option<FailedMode> {
    let mut ctrl = ContinuousController::new(p, law);
    ctrl.k *= gain;
    let (a, _) = closed_loop_a(p, axle, drive, &ctrl);
    let mut eig = eigenvalues(&a)?;
    if let Some(iz) = structural_zero_index(&a, &eig) {
        eig.swap_remove(iz);
    }
    eig.into_iter()
        .filter(|l| l.im >= 0.0)
        .max_by(|a, b| a.re.total_cmp(&b.re))
        .map(|l| FailedMode {
            sigma_per_s: l.re,
            f_hz: l.im / (2.0 * std::f64::consts::PI),
        })
}

/// The least stable mode once the yaw actuator has stopped ([`faulty_loop_mode`], gain 0).
pub fn failed_actuator_mode(p: &Params, axle: Axle, drive: bool) -> Option<FailedMode> {
    faulty_loop_mode(p, axle, drive, YawLaw::Gain, 0.0)
}

/// `[actuator_fault]` as written in a scenario.
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawActuatorFault {
    t_s: f64,
    mode: String,
    fraction: Option<f64>,
}

impl RawActuatorFault {
    /// Validates the table; errors name `file`, the key and why.
    pub(crate) fn validate(&self, file: &str, t_max_s: f64) -> Result<ActuatorFault, ConfigError> {
        let t_on_ns = crate::scenario::time(file, "actuator_fault.t_s", self.t_s, t_max_s)?;
        let mode = match (self.mode.as_str(), self.fraction) {
            ("off", None) => Ok(FaultMode::Off),
            ("reversed", None) => Ok(FaultMode::Reversed),
            ("fraction", Some(f)) if f.is_finite() && (0.0..1.0).contains(&f) => {
                Ok(FaultMode::Fraction(f))
            }
            ("fraction", Some(f)) => Err((
                "fraction",
                format!("{f} is outside [0, 1) (1 is no fault; use mode = \"reversed\" for -1)"),
            )),
            ("fraction", None) => Err((
                "fraction",
                "mode = \"fraction\" needs `fraction` in [0, 1)".into(),
            )),
            ("off" | "reversed", Some(_)) => Err((
                "fraction",
                format!(
                    "only mode = \"fraction\" takes a fraction (mode is \"{}\")",
                    self.mode
                ),
            )),
            (m, _) => Err((
                "mode",
                format!("unknown mode \"{m}\" (expected off, fraction or reversed)"),
            )),
        };
        let mode = mode.map_err(|(key, reason)| ConfigError::Invalid {
            file: file.to_string(),
            key: format!("actuator_fault.{key}"),
            reason,
        })?;
        Ok(ActuatorFault { t_on_ns, mode })
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    /// At conicity 0.4 the healthy lead damps the wheelset; a fifth of it does not.
    #[test]
    fn a_fifth_of_the_lead_lets_the_wheelset_hunt() {
        let p = Params {
            lambda: 0.4,
            ..Params::default()
        };
        let mode = |g| faulty_loop_mode(&p, Axle::Flexible, true, YawLaw::Lead, g).unwrap();
        assert!(mode(1.0).sigma_per_s < 0.0);
        assert!(mode(0.2).sigma_per_s > 0.0);
    }

    fn raw(t_s: f64, mode: &str, fraction: Option<f64>) -> RawActuatorFault {
        RawActuatorFault {
            t_s,
            mode: mode.into(),
            fraction,
        }
    }

    #[test]
    fn modes_scale_the_command_from_the_fault_time() {
        let t = 2_000_000_000;
        for (mode, g) in [
            (FaultMode::Off, 0.0),
            (FaultMode::Fraction(0.25), 0.25),
            (FaultMode::Reversed, -1.0),
        ] {
            let f = ActuatorFault { t_on_ns: t, mode };
            assert_eq!(f.delivered(t - 1, 100.0), 100.0);
            assert_eq!(f.delivered(t, 100.0), 100.0 * g);
            assert_eq!(f.delivered(t + 10, -40.0), -40.0 * g);
        }
    }

    /// With the actuator gone the wheelset hunts at every conicity of the envelope
    /// (10 MN), at about the kinematic (Klingel) frequency `v/(2 pi) sqrt(lambda/(r0 Lg))`.
    #[test]
    fn the_passive_less_wheelset_is_unstable() {
        for lambda in [0.05, 0.1, 0.2, 0.3, 0.4] {
            let p = Params {
                lambda,
                ..Params::default()
            };
            let m = failed_actuator_mode(&p, Axle::Flexible, true).unwrap();
            let klingel = p.v / (2.0 * std::f64::consts::PI) * (lambda / (p.r0 * p.l_g)).sqrt();
            println!(
                "lambda {lambda}: sigma {:.3} 1/s, {:.2} Hz (Klingel {klingel:.2} Hz), x10 in {:.2} s",
                m.sigma_per_s,
                m.f_hz,
                10f64.ln() / m.sigma_per_s
            );
            assert!(m.sigma_per_s > 0.0, "{lambda}: {m:?}");
            assert!(
                (m.f_hz / klingel - 1.0).abs() < 0.3,
                "{lambda}: {m:?} vs {klingel}"
            );
        }
    }

    /// The loop with the delivered gain: the healthy lead damps every conicity of the
    /// envelope, less of it damps less (the growth rate does not rise with the gain over
    /// `[0, 1]`: a mode the actuator does not reach, -2.08 1/s, bounds it from below at
    /// the low conicities), and a reversed actuator is less stable than a stopped one, its least
    /// stable mode a real one (the wheelset pushed off the centre line).
    #[test]
    fn the_delivered_gain_sets_the_least_stable_mode() {
        for lambda in [0.05, 0.1, 0.2, 0.3, 0.4] {
            let p = Params {
                lambda,
                ..Params::default()
            };
            let mode = |g| faulty_loop_mode(&p, Axle::Flexible, true, YawLaw::Lead, g).unwrap();
            let sigma: Vec<f64> = [1.0, 0.8, 0.5, 0.2, 0.0]
                .iter()
                .map(|&g| mode(g).sigma_per_s)
                .collect();
            let (off, rev) = (mode(0.0), mode(-1.0));
            println!(
                "lambda {lambda}: sigma at g = 1, 0.8, 0.5, 0.2, 0: {sigma:.2?}; reversed {rev:?}"
            );
            assert!(sigma[0] < 0.0, "{lambda}: {sigma:?}");
            assert!(
                sigma.windows(2).all(|w| w[0] <= w[1] + 1e-6),
                "{lambda}: {sigma:?}"
            );
            assert!(sigma[4] > 0.0, "{lambda}: {sigma:?}");
            assert_eq!(Some(off), failed_actuator_mode(&p, Axle::Flexible, true));
            assert!(off.f_hz > 1.0, "{off:?}");
            assert!(rev.sigma_per_s > off.sigma_per_s, "{rev:?} vs {off:?}");
            if lambda < 0.4 {
                assert_eq!(rev.f_hz, 0.0, "{lambda}: {rev:?}");
            }
        }
        // Conicity 0.4: a fifth of the lead leaves the wheelset hunting; 0.3 with 0.8 of
        // it still damps.
        let at = |lambda, g| {
            let p = Params {
                lambda,
                ..Params::default()
            };
            faulty_loop_mode(&p, Axle::Flexible, true, YawLaw::Lead, g).unwrap()
        };
        assert!(at(0.4, 0.2).sigma_per_s > 5.0);
        assert!(at(0.3, 0.8).sigma_per_s < -1.0);
        // Passive: the spring is mechanical, the actuator's gain changes nothing.
        let p = Params::default();
        let passive = |g| faulty_loop_mode(&p, Axle::Flexible, true, YawLaw::Passive, g);
        assert_eq!(passive(1.0), passive(-1.0));
    }

    #[test]
    fn bad_tables_are_refused_with_the_key() {
        let key = |r: RawActuatorFault| {
            r.validate("x.toml", 20.0)
                .unwrap_err()
                .key()
                .map(String::from)
        };
        assert_eq!(
            key(raw(-1.0, "off", None)).as_deref(),
            Some("actuator_fault.t_s")
        );
        assert_eq!(
            key(raw(21.0, "off", None)).as_deref(),
            Some("actuator_fault.t_s")
        );
        assert_eq!(
            key(raw(1.0, "stuck", None)).as_deref(),
            Some("actuator_fault.mode")
        );
        assert_eq!(
            key(raw(1.0, "fraction", None)).as_deref(),
            Some("actuator_fault.fraction")
        );
        assert_eq!(
            key(raw(1.0, "fraction", Some(1.0))).as_deref(),
            Some("actuator_fault.fraction")
        );
        assert_eq!(
            key(raw(1.0, "fraction", Some(f64::NAN))).as_deref(),
            Some("actuator_fault.fraction")
        );
        assert_eq!(
            key(raw(1.0, "off", Some(0.5))).as_deref(),
            Some("actuator_fault.fraction")
        );
        let ok = raw(1.5, "fraction", Some(0.5))
            .validate("x.toml", 20.0)
            .unwrap();
        assert_eq!(ok.mode, FaultMode::Fraction(0.5));
        assert_eq!(ok.t_on_ns, 1_500_000_000);
    }
}
