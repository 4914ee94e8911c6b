//! Stability margins of each loop broken at its actuator, from the loop's frequency
//! response on the unit circle and the sampled closed loop's own verdict.
//!
//! ```text
//! yaw:      L(z) = -C_y(z) z^-d P_y(z),   P_y: T_psi -> y' (N m -> m/s)
//!           C_y = K_hf (1 - h (1 + z^-1)/(1 - a z^-1)) (1 + alpha (1 - z^-1)),
//!           a = 1 - kappa, h = kappa g/2, alpha = yaw_predict_ticks
//! traction: L(z) =  C_i(z) z^-d P_i(z),   P_i: u_a -> i_a (V -> A),
//!           C_i = Kp + Ki/(1 - z^-1)
//! P(z) = C (zI - Ad)^-1 Bd                (ZOH at the base period)
//! ```
//!
//! `T_psi = +C_y y'` acts through eq. 5's `-T_psi`, hence the yaw loop's minus sign. The
//! yaw plant is open-loop unstable, so the loop is judged by its closed-loop eigenvalues
//! first; its margins are then the critical gains nearest 1 above and below (where `L`
//! crosses the negative real axis) and `min |180 + arg L|` over the gain crossovers
//! (`docs/audit.md`).

use super::*;
use crate::params::Params;
use nalgebra::{Complex, DMatrix, DVector};
use std::f64::consts::PI;
use wheelset_control::{Config, YawMode};

/// Which loop is broken.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Loop {
    /// The yaw damper (lead or gain), at the actuator torque `T_psi`.
    Yaw,
    /// The traction current loop, at the armature voltage `u_a`.
    Traction,
}

impl Loop {
    /// Name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Loop::Yaw => "yaw",
            Loop::Traction => "traction",
        }
    }
}

/// A margin and the frequency it is read at (Hz).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct At {
    /// dB (gain margins) or degrees (phase margin).
    pub value: f64,
    /// Frequency of the crossing, Hz.
    pub hz: f64,
}

/// The margins of one loop (module docs).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Margins {
    /// The loop is stable (judged alone: [`margins`]).
    pub stable: bool,
    /// Poles of the discretised plant (no yaw spring) outside the unit circle.
    pub open_loop_unstable: usize,
    /// Gain increase to instability, dB (`None`: none on the grid).
    pub gain_up: Option<At>,
    /// Gain decrease to instability, dB, negative (`None`: stable down to zero gain).
    pub gain_down: Option<At>,
    /// Phase rotation to instability, degrees (`None`: no gain crossover).
    pub phase: Option<At>,
}

/// Frequencies of the response grid: 4000 points, log-spaced from 0.05 Hz to Nyquist.
pub fn grid(base_hz: f64) -> Vec<f64> {
    let m = 4000;
    let (f0, f1) = (0.05f64, 0.5 * base_hz);
    (0..m)
        .map(|i| f0 * (f1 / f0).powf(i as f64 / (m - 1) as f64))
        .collect()
}

/// `L(e^{j 2 pi f T})` of loop `which` on `freqs` with `delay_ticks` of delay.
/// Errors: divisors other than 1, an invalid configuration, a plant of the wrong shape.
pub fn loop_response(
    plant: &LinearPlant,
    cfg: &Config,
    delay_ticks: usize,
    which: Loop,
    freqs: &[f64],
) -> Result<Vec<Complex<f64>>, String> {
    cfg.validate().map_err(|e| e.to_string())?;
    if cfg.yaw_divisor != 1 || cfg.traction_divisor != 1 {
        return Err("margins: both loops must run every base tick (divisors 1)".into());
    }
    let n = plant_order(plant)?;
    let t0 = cfg.base_period();
    let (ad, bd) = zoh(&plant.a, &plant.b, t0);
    let (input, output) = match which {
        Loop::Yaw => (0, 0),
        Loop::Traction => (1, 1),
    };
    let b: DVector<Complex<f64>> = bd.column(input).map(|v| Complex::new(v, 0.0));
    let c: Vec<f64> = plant.c.row(output).iter().copied().collect();
    let (lead, pi) = discretised(cfg)?;
    let alpha = cfg.yaw_predict_ticks;
    let one = Complex::new(1.0, 0.0);
    freqs
        .iter()
        .map(|&f| {
            let zi = Complex::from_polar(1.0, -2.0 * PI * f * t0);
            let z = one / zi;
            let m: DMatrix<Complex<f64>> =
                DMatrix::from_fn(n, n, |i, j| if i == j { z } else { one * 0.0 } - ad[(i, j)]);
            let x = m
                .lu()
                .solve(&b)
                .ok_or_else(|| format!("margins: zI - Ad singular at {f} Hz"))?;
            let p: Complex<f64> = x.iter().zip(&c).map(|(v, ci)| v * *ci).sum();
            let delay = zi.powi(delay_ticks as i32);
            let ctrl = match which {
                Loop::Yaw => {
                    let pred = one + (one - zi) * alpha;
                    let law = match cfg.yaw_mode {
                        YawMode::Passive => one * 0.0,
                        YawMode::Gain => one * cfg.gain_k,
                        YawMode::Lead => {
                            let h = lead.kappa * lead.g / 2.0;
                            let lp = (one + zi) * h / (one - zi * (1.0 - lead.kappa));
                            (one - lp) * lead.k_hf
                        }
                    };
                    -(law * pred)
                }
                Loop::Traction => one * pi.kp + one * pi.ki / (one - zi),
            };
            Ok(ctrl * delay * p)
        })
        .collect()
}

fn wrap(d: f64) -> f64 {
    let d = d.rem_euclid(360.0);
    if d > 180.0 {
        d - 360.0
    } else {
        d
    }
}

/// The crossings `(gain up, gain down, phase)` of a response `l` on `freqs`,
/// interpolated linearly between grid points.
pub fn crossings(freqs: &[f64], l: &[Complex<f64>]) -> (Option<At>, Option<At>, Option<At>) {
    let mut up: Option<At> = None;
    let mut down: Option<At> = None;
    let mut phase: Option<At> = None;
    for i in 1..l.len().min(freqs.len()) {
        let (a, b) = (l[i - 1], l[i]);
        if !(a.norm().is_finite() && b.norm().is_finite()) {
            continue;
        }
        let f_at = |t: f64| freqs[i - 1] + t * (freqs[i] - freqs[i - 1]);
        // The negative real axis: Im changes sign where Re < 0.
        if a.im * b.im <= 0.0 && a.im != b.im {
            let t = a.im / (a.im - b.im);
            let re = a.re + t * (b.re - a.re);
            if re < 0.0 {
                let db = -20.0 * (-re).log10();
                let at = At {
                    value: db,
                    hz: f_at(t),
                };
                if db > 0.0 {
                    if up.is_none_or(|u| db < u.value) {
                        up = Some(at);
                    }
                } else if down.is_none_or(|d| db > d.value) {
                    down = Some(at);
                }
            }
        }
        // Gain crossover.
        let (ga, gb) = (a.norm().ln(), b.norm().ln());
        if ga * gb <= 0.0 && ga != gb {
            let t = ga / (ga - gb);
            let (pa, pb) = (a.arg().to_degrees(), b.arg().to_degrees());
            let ph = wrap(180.0 + pa + t * wrap(pb - pa)).abs();
            if phase.is_none_or(|p| ph < p.value) {
                phase = Some(At {
                    value: ph,
                    hz: f_at(t),
                });
            }
        }
    }
    // The Nyquist frequency itself: L is real there.
    if let (Some(&last), Some(&f)) = (l.last(), freqs.last()) {
        if last.re < 0.0 && last.norm().is_finite() {
            let db = -20.0 * (-last.re).log10();
            let at = At { value: db, hz: f };
            if db > 0.0 && up.is_none_or(|u| db < u.value) {
                up = Some(at);
            }
            if db <= 0.0 && down.is_none_or(|d| db > d.value) {
                down = Some(at);
            }
        }
    }
    (up, down, phase)
}

/// The margins of loop `which` of `cfg` with `delay_ticks` of delay, on the full plant
/// (case d) at the operating point of `p`. The loop's own stability is judged with the
/// other out of the way (the yaw loop without traction, the traction loop with the
/// passive yaw spring); the margins are `None` when that loop is unstable.
pub fn margins(
    p: &Params,
    cfg: &Config,
    delay_ticks: usize,
    which: Loop,
) -> Result<Margins, String> {
    let plant = Model::Full.plant(p, p.f11, p.lambda, false);
    let freqs = grid(cfg.base_rate_hz as f64);
    let l = loop_response(&plant, cfg, delay_ticks, which, &freqs)?;
    let mut alone = *cfg;
    let stable = match which {
        Loop::Yaw => {
            alone.traction_enabled = false;
            closed_loop(&plant, &alone, delay_ticks)?.stable()
        }
        Loop::Traction => {
            alone.yaw_mode = YawMode::Passive;
            let sprung = Model::Full.plant(p, p.f11, p.lambda, true);
            closed_loop(&sprung, &alone, delay_ticks)?.stable()
        }
    };
    let (ad, _) = zoh(&plant.a, &plant.b, cfg.base_period());
    let open_loop_unstable = crate::finite::eigenvalues(&ad, "the discretised plant")?
        .iter()
        .filter(|mu| mu.norm() > 1.0 + 1e-9)
        .count();
    let (gain_up, gain_down, phase) = if stable {
        crossings(&freqs, &l)
    } else {
        (None, None, None)
    };
    Ok(Margins {
        stable,
        open_loop_unstable,
        gain_up,
        gain_down,
        phase,
    })
}
