//! The closed-loop audit: the fixed-point runtime in the loop with the plant through the
//! wire (`wheelset_loop::device_loop::run_device` on `curve`) against the continuous
//! reference (`wheelset_plant::sim::run_continuous`). The straight-track limit cycle in
//! [`WINDOW_S`] (torque peak to peak, RMS, [`dominant_hz`]; `y` peak to peak) is
//! attributed by re-running the core ([`CoreController`]) with every source, then with
//! one removed at a time (wire LSB of `y'`, internal rounding, predictor, output wire LSB).
//!
//! A **self-sustained oscillation** persists without an input (on straight track the
//! plant input is zero) and exceeds the torque's proven rounding-error bound; a **bounded
//! dither** stays within it (as [`super::limits`]).

use serde::Serialize;
use wheelset_control::{Config, SampleBits};
use wheelset_loop::core::{CoreController, Sources};
use wheelset_loop::device_loop::{control_config, run_device, DeviceOptions};
use wheelset_loop::drive::drive;
use wheelset_plant::control::{SampledController, YawLaw};
use wheelset_plant::params::Params;
use wheelset_plant::sampled::{margins_of, At, Law, Laws, Loop, Other};

use super::bounds::Quantised;
use wheelset_plant::scenario::Scenario as Track;
use wheelset_plant::sim::{run_continuous, Trajectory};
use wheelset_proto::units::TORQUE_LSB_NM;

/// The straight-track window of `curve`, s.
pub const WINDOW_S: (f64, f64) = (17.0, 20.0);

/// The limit cycle of one run in the window.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Cycle {
    /// Torque peak to peak, N m.
    pub torque_p2p_nm: f64,
    /// Torque RMS about its mean, N m.
    pub torque_rms_nm: f64,
    /// Dominant frequency of the torque, Hz (0 when it does not move).
    pub freq_hz: f64,
    /// `y` peak to peak, m.
    pub y_p2p_m: f64,
}

/// The limit-cycle record of the closed-loop audit.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct LimitCycleReport {
    /// Amplitude: torque peak to peak of the device run.
    pub amplitude: f64,
    /// Unit of `amplitude` (`N m peak to peak`).
    pub unit: String,
    /// Dominant frequency, Hz.
    pub freq_hz: f64,
    /// Source -> amplitude (same unit) with that source removed.
    pub attribution: std::collections::BTreeMap<String, f64>,
    /// The device run's figures.
    pub device: Cycle,
    /// The continuous reference's figures in the same window.
    pub reference: Cycle,
    /// The core in the loop with every source (reproduces the device).
    pub core_all_sources: Cycle,
    /// Per removed source, the run's figures.
    pub removed: Vec<(String, Cycle)>,
    /// `self-sustained oscillation` or `bounded dither` or `none`, and why.
    pub classification: String,
    /// The window, s.
    pub window_s: (f64, f64),
    /// The torque's proven rounding-error bound, N m: a cycle within twice this (or one
    /// wire LSB) is a bounded dither.
    pub dither_limit_nm: f64,
}

/// The whole closed-loop section.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct ClosedLoopAudit {
    /// The straight-track limit cycle.
    pub limit_cycle: LimitCycleReport,
    /// Stability margins, ideal vs quantised.
    pub margins: Vec<Margin>,
    /// What the section is, in words.
    pub note: String,
}

/// Dominant frequency of `x` sampled at `fs` (mean removed; DFT magnitude maximum on a
/// `df` grid from `df` to `fs/2`).
pub fn dominant_hz(x: &[f64], fs: f64, df: f64) -> f64 {
    if x.len() < 4 {
        return 0.0;
    }
    let m = x.iter().sum::<f64>() / x.len() as f64;
    let (mut best, mut bf) = (0.0f64, 0.0f64);
    let mut f = df;
    while f < fs / 2.0 {
        let w = 2.0 * std::f64::consts::PI * f / fs;
        // Goertzel.
        let c = 2.0 * w.cos();
        let (mut s1, mut s2) = (0.0f64, 0.0f64);
        for v in x {
            let s = v - m + c * s1 - s2;
            s2 = s1;
            s1 = s;
        }
        let p = s1 * s1 + s2 * s2 - c * s1 * s2;
        if p > best {
            best = p;
            bf = f;
        }
        f += df;
    }
    bf
}

fn stats(t: &[(f64, f64)], tr: &Trajectory, fs: f64) -> Cycle {
    let inw = |t: f64| (WINDOW_S.0..=WINDOW_S.1).contains(&t);
    let tv: Vec<f64> = t.iter().filter(|s| inw(s.0)).map(|s| s.1).collect();
    let yv: Vec<f64> = tr
        .records
        .iter()
        .filter(|r| inw(r.t_s))
        .map(|r| r.y_m)
        .collect();
    let p2p = |v: &[f64]| {
        v.iter().copied().fold(f64::NEG_INFINITY, f64::max)
            - v.iter().copied().fold(f64::INFINITY, f64::min)
    };
    let n = tv.len().max(1) as f64;
    let mean = tv.iter().sum::<f64>() / n;
    let rms = (tv.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n).sqrt();
    let tp = if tv.is_empty() { 0.0 } else { p2p(&tv) };
    Cycle {
        torque_p2p_nm: tp,
        torque_rms_nm: rms,
        freq_hz: if tp > 0.0 {
            dominant_hz(&tv, fs, 0.25)
        } else {
            0.0
        },
        y_p2p_m: if yv.is_empty() { 0.0 } else { p2p(&yv) },
    }
}

fn of_trajectory(tr: &Trajectory) -> Cycle {
    let t: Vec<(f64, f64)> = tr.records.iter().map(|r| (r.t_s, r.t_psi_nm)).collect();
    let dt = tr
        .records
        .windows(2)
        .next()
        .map(|w| w[1].t_s - w[0].t_s)
        .unwrap_or(1.0);
    stats(&t, tr, 1.0 / dt)
}

fn core_run<T: SampleBits>(sc: &Track, cfg: &Config, src: Sources) -> Result<Cycle, String> {
    let mut ctrl = CoreController::<T>::try_new(cfg, cfg.wsp.enabled)
        .map_err(|e| e.to_string())?
        .with_sources(src);
    // `(t_s, T_psi N m)` as commanded (before the actuator's delay), in the window.
    let mut torque = Vec::new();
    let tr = drive(sc, &mut ctrl, 1, false, "audit core loop", |_, t_ns, a| {
        let t = t_ns as f64 * 1e-9;
        if (WINDOW_S.0..=WINDOW_S.1).contains(&t) {
            torque.push((t, a.t_psi));
        }
    })
    .map_err(|e| e.to_string())?;
    let fs = 1e9 / ctrl.period_ns() as f64;
    Ok(stats(&torque, &tr, fs))
}

/// The straight-track limit cycle (module docs) at the operating point `params`;
/// `lead_err_nm` is the torque's proven rounding-error bound (the dither limit), N m.
pub fn limit_cycle(lead_err_nm: f64, params: &Params) -> Result<LimitCycleReport, String> {
    let mut sc = Track::load("curve", params).map_err(|e| e.to_string())?;
    let law = YawLaw::Lead;
    let cfg = control_config(&sc.params, law, sc.drive);
    let period_ns = 1_000_000_000 / u64::from(cfg.base_rate_hz.max(1));
    if period_ns.is_multiple_of(sc.dt_ns) {
        sc.output_dt_ns = period_ns;
    }
    let dev = run_device(&sc, law, &DeviceOptions::default()).map_err(|e| e.to_string())?;
    let device = of_trajectory(&dev.trajectory);
    let reference = of_trajectory(&run_continuous(&sc, law));
    let all = Sources::WIRE;
    let fx = |cfg: &Config, src| core_run::<wheelset_control::Fx>(&sc, cfg, src);
    let core_all = fx(&cfg, all)?;
    let no_predictor = Config {
        yaw_predict_ticks: 0.0,
        ..cfg
    };
    let no_y_wire = Sources {
        y_wire: false,
        ..all
    };
    let no_out_wire = Sources {
        out_wire: false,
        ..all
    };
    let removed = [
        ("wire LSB of y'", fx(&cfg, no_y_wire)?),
        (
            "internal rounding (core in f64)",
            core_run::<f64>(&sc, &cfg, all)?,
        ),
        ("predictor", fx(&no_predictor, all)?),
        ("output wire LSB", fx(&cfg, no_out_wire)?),
    ]
    .map(|(n, c)| (n.to_string(), c))
    .to_vec();
    let attribution = removed
        .iter()
        .map(|(n, c)| (n.clone(), c.torque_p2p_nm))
        .collect();
    let lsb = TORQUE_LSB_NM;
    let classification = if device.torque_p2p_nm <= 0.0 {
        "none: the torque is constant in the window".to_string()
    } else if device.torque_p2p_nm <= 2.0 * lead_err_nm.max(lsb) {
        format!(
            "bounded dither: {:.3} N m peak to peak, within twice the proven rounding bound \
             or one wire LSB",
            device.torque_p2p_nm
        )
    } else {
        format!(
            "self-sustained oscillation: {:.2} N m peak to peak ({:.0} wire LSB) at {:.1} Hz \
             on straight track (no input drives it), {:.0}x the proven rounding-error \
             bound {:.3} N m; the continuous reference moves {:.2e} N m",
            device.torque_p2p_nm,
            device.torque_p2p_nm / lsb,
            device.freq_hz,
            device.torque_p2p_nm / lead_err_nm.max(f64::MIN_POSITIVE),
            lead_err_nm,
            reference.torque_p2p_nm
        )
    };
    Ok(LimitCycleReport {
        amplitude: device.torque_p2p_nm,
        unit: "N m peak to peak".into(),
        freq_hz: device.freq_hz,
        attribution,
        device,
        reference,
        core_all_sources: core_all,
        removed,
        classification,
        window_s: WINDOW_S,
        dither_limit_nm: lead_err_nm,
    })
}

/// One loop's stability and margins, ideal (f64 controller) vs quantised (as the device
/// holds it), read by [`wheelset_plant::sampled::margins_of`] with the other loop closed.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Margin {
    /// `yaw (lead)` or `traction (PI)`.
    #[serde(rename = "loop")]
    pub loop_name: String,
    /// Gain margin with the f64 controller: the smaller gain change to instability, dB
    /// (positive; `null`: the loop is unstable, or no gain change destabilises it).
    pub gain_db_ideal: Option<f64>,
    /// Gain margin with the quantised controller, dB.
    pub gain_db_quantised: Option<f64>,
    /// Phase margin with the f64 controller: the smaller of the phase lag and lead to
    /// instability, degrees (positive; `null`: unstable, or no gain crossover).
    pub phase_deg_ideal: Option<f64>,
    /// Phase margin with the quantised controller, degrees.
    pub phase_deg_quantised: Option<f64>,
    /// Where the gain margin is read, Hz (quantised).
    pub phase_crossover_hz: Option<f64>,
    /// Where the phase margin is read (`|L| = 1`), Hz (quantised).
    pub gain_crossover_hz: Option<f64>,
    /// Open-loop poles outside the unit circle, `P` (quantised).
    pub open_loop_unstable_poles: usize,
    /// Counter-clockwise turns of `1 + L` round the origin, `W` (quantised).
    pub encirclements: i64,
    /// Closed-loop poles outside the unit circle, `Z = P - W` (quantised).
    pub closed_loop_unstable_poles: i64,
    /// `Z = 0` (quantised).
    pub stable: bool,
    /// The gain reduction to instability, dB, negative (`null`: no lower limit)
    /// (quantised).
    pub gain_reduction_db: Option<f64>,
    /// The gain increase to instability, dB (`null`: none) (quantised).
    pub gain_increase_db: Option<f64>,
    /// The extra phase lag to instability, degrees (`null`: none) (quantised).
    pub phase_lag_deg: Option<f64>,
    /// The extra phase lead to instability, degrees (`null`: none) (quantised).
    pub phase_lead_deg: Option<f64>,
}

/// The stability and margins of the yaw (lead) and traction (PI) loops of `cfg` at the
/// operating point `p`, each broken at its actuator with the other closed, ideal and
/// quantised (`q`). Errors: as [`wheelset_plant::sampled::margins_of`].
pub fn margins(cfg: &Config, q: &Quantised, p: &Params) -> Result<Vec<Margin>, String> {
    let s = &cfg.scales;
    let ideal = Laws::of(&Config {
        yaw_mode: wheelset_control::YawMode::Lead,
        traction_enabled: true,
        ..*cfg
    })?;
    let quantised = Laws {
        yaw: Some(Law::lead(
            q.lead.k_hf * s.torque / s.y_dot,
            q.lead.g_half,
            q.lead.kappa,
            2.0 * q.ph,
        )),
        traction: Some(Law::pi(
            q.kp * s.voltage / s.current,
            q.ki * s.voltage / s.current,
        )),
    };
    let (t0, d) = (cfg.base_period(), usize::from(cfg.delay_ticks.max(1)));
    let read = |laws: &Laws, l: Loop| margins_of(p, t0, d, laws, l, Other::Closed);
    [(Loop::Yaw, "yaw (lead)"), (Loop::Traction, "traction (PI)")]
        .into_iter()
        .map(|(l, name)| {
            let (i, m) = (read(&ideal, l)?, read(&quantised, l)?);
            let v = |a: Option<At>| a.map(|a| a.value);
            Ok(Margin {
                loop_name: name.into(),
                gain_db_ideal: v(i.gain()),
                gain_db_quantised: v(m.gain()),
                phase_deg_ideal: v(i.phase),
                phase_deg_quantised: v(m.phase),
                phase_crossover_hz: m.gain().map(|a| a.hz),
                gain_crossover_hz: m.phase.map(|a| a.hz),
                open_loop_unstable_poles: m.open_loop_unstable,
                encirclements: m.encirclements,
                closed_loop_unstable_poles: m.closed_loop_unstable,
                stable: m.stable,
                gain_reduction_db: v(m.gain_down),
                gain_increase_db: v(m.gain_up),
                phase_lag_deg: v(m.phase_lag),
                phase_lead_deg: v(m.phase_lead),
            })
        })
        .collect()
}

#[cfg(test)]
mod margin_tests;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dominant_frequency_of_a_sine() {
        let fs = 5000.0;
        let x: Vec<f64> = (0..15000)
            .map(|n| 1.0 + (2.0 * std::f64::consts::PI * 37.5 * n as f64 / fs).sin())
            .collect();
        assert!((dominant_hz(&x, fs, 0.25) - 37.5).abs() < 0.26);
    }
}
