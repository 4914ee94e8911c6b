//! The `monitor` section of `hil run`: the device's stability-monitor and actuator-check
//! alarms as the host saw them (rising edges of `Flags::HUNTING` / `Flags::ACTUATOR_FAULT`
//! in the Actuation frames), and the check of them against the scenario.
//!
//! ```json
//! "monitor": {"alarms": [{"kind": "actuator", "t_s": 6.2}, {"kind": "hunting", "t_s": 6.28}],
//!             "first_alarm_s": 6.2, "expect": "alarm", "deadline_s": 6.39, ...}
//! ```
//!
//! **Expected.** A scenario without a plant fault must raise no alarm at all (the
//! healthy loop is damped; a plant that hunts on its own, e.g. passive control above its
//! critical conicity, is reported by its divergence). With an `[actuator_fault]` from
//! `t_f`: no alarm before `t_f`, and the first alarm by the **deadline**, stated from the
//! growth rate `sigma` of the unstable mode of the passive-less wheelset
//! (`sim_host::fault::failed_actuator_mode`, the scenario's parameters):
//!
//! ```text
//! t_alarm - t_f <= [ ln(thr / A_0) + ln(1 + 2 sigma tau)/2 ] / sigma + B
//! ```
//!
//! the time for the mode to grow from the band-passed RMS `A_0` present at the fault
//! (measured on the plant's `y'` over the block before `t_f` with the device's own
//! filter, [`wheelset_control::Monitor`] in f64; at least the wire LSB of `y'`, 1 um/s)
//! to the hunting threshold `thr`, plus the exponential mean square's lag for a mode
//! growing at `sigma` (`ms = p/(1 + 2 sigma tau)`, module docs of
//! `wheelset_control::monitor`), plus one actuator-check block `B` of slack. This is the
//! hunting alarm's bound; the actuator check usually comes first. A fault that leaves the
//! mode stable (a fraction that still damps it) states no deadline and expects nothing.

use serde::Serialize;
use sim_host::fault::{failed_actuator_mode, FaultMode};
use sim_host::scenario::Scenario;
use sim_host::sim::Trajectory;
use wheelset_control::{Monitor, MonitorParams, MonitorState};

use crate::budget::Verdict;

/// One alarm: a rising edge of a monitor flag.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Alarm {
    /// `hunting` (stability monitor) or `actuator` (actuator check).
    pub kind: &'static str,
    /// Arrival time of the first Actuation frame carrying it, s.
    pub t_s: f64,
}

/// The `monitor` section of the run report.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MonitorReport {
    /// Every alarm, in time order.
    pub alarms: Vec<Alarm>,
    /// The first alarm's time, s (`null`: none).
    pub first_alarm_s: Option<f64>,
    /// `none` (no alarm allowed) or `alarm` (an alarm by `deadline_s`, none before
    /// `fault_s`).
    pub expect: &'static str,
    /// The plant's actuator fault time, s.
    pub fault_s: Option<f64>,
    /// Growth rate of the passive-less wheelset's unstable mode, 1/s.
    pub sigma_per_s: Option<f64>,
    /// Band-passed RMS of `y'` at the fault, m/s (`A_0`).
    pub rms_at_fault_m_s: Option<f64>,
    /// The stated deadline of the first alarm, s (absolute).
    pub deadline_s: Option<f64>,
    /// Pass, or fail with `reason`.
    pub verdict: Verdict,
    /// Why it failed (empty on pass).
    pub reason: String,
}

/// Rising edges of `(t_ns, hunting, actuator)` flag samples, in order.
#[must_use]
pub fn alarms(samples: impl IntoIterator<Item = (u64, bool, bool)>) -> Vec<Alarm> {
    let mut out = Vec::new();
    let (mut h0, mut a0) = (false, false);
    for (t_ns, h, a) in samples {
        let t_s = t_ns as f64 * 1e-9;
        if a && !a0 {
            out.push(Alarm {
                kind: "actuator",
                t_s,
            });
        }
        if h && !h0 {
            out.push(Alarm {
                kind: "hunting",
                t_s,
            });
        }
        (h0, a0) = (h, a);
    }
    out
}

/// Band-passed RMS of the plant's `y'` over the block before `t_s`, with the device's
/// filter in f64 on the trajectory's records (their own rate).
fn band_rms_before(p: &MonitorParams, tr: &Trajectory, t_s: f64) -> Option<f64> {
    let dt = tr.records.get(1)?.t_s - tr.records.first()?.t_s;
    if dt.is_nan() || dt <= 0.0 {
        return None;
    }
    let rate = (1.0 / dt).round() as u32;
    let m = Monitor::<f64>::try_new(p, rate).ok()?;
    let mut s = MonitorState::<f64>::default();
    let (mut sum, mut n) = (0.0, 0u32);
    for r in tr.records.iter().take_while(|r| r.t_s < t_s) {
        m.tick(&mut s, r.yd_mps, true);
        // (`phase` is reset to the divisor on the ticks that run a monitor step.)
        if r.t_s >= t_s - p.act_block_s && s.phase == m.divisor() {
            sum += s.band * s.band;
            n += 1;
        }
    }
    (n > 0).then(|| (sum / f64::from(n)).sqrt())
}

/// Checks `alarms` of a run of `sc` (trajectory `tr`) against the expectation above.
#[must_use]
pub fn judge(
    sc: &Scenario,
    tr: &Trajectory,
    p: &MonitorParams,
    alarms: Vec<Alarm>,
) -> MonitorReport {
    let first = alarms.first().map(|a| a.t_s);
    let mut r = MonitorReport {
        alarms,
        first_alarm_s: first,
        expect: "none",
        fault_s: None,
        sigma_per_s: None,
        rms_at_fault_m_s: None,
        deadline_s: None,
        verdict: Verdict::Pass,
        reason: String::new(),
    };
    let fault = sc.actuator_fault.filter(|f| f.mode.gain() < 1.0);
    let Some(f) = fault else {
        if let Some(t) = first {
            r.verdict = Verdict::Fail;
            r.reason = format!("an alarm at {t:.3} s on a scenario without a fault");
        }
        return r;
    };
    let t_f = f.t_on_s();
    r.fault_s = Some(t_f);
    let mode = failed_actuator_mode(&sc.params, sc.axle, sc.drive);
    r.sigma_per_s = mode.map(|m| m.sigma_per_s);
    let a0 = band_rms_before(p, tr, t_f).map(|a| a.max(1e-6));
    r.rms_at_fault_m_s = a0;
    // A fraction that still damps the mode, or a mode that does not grow: nothing due.
    let unstable = matches!(f.mode, FaultMode::Off | FaultMode::Reversed);
    if let (Some(m), Some(a0), true) = (mode, a0, unstable) {
        let sigma = m.sigma_per_s;
        if sigma > 0.0 {
            let tau = p.window_s / 2.0;
            let grow = ((p.threshold_m_s / a0).ln().max(0.0)
                + 0.5 * (1.0 + 2.0 * sigma * tau).ln())
                / sigma;
            r.expect = "alarm";
            r.deadline_s = Some(t_f + grow + p.act_block_s);
        }
    }
    if let Some(early) = r.alarms.iter().find(|a| a.t_s < t_f) {
        r.verdict = Verdict::Fail;
        r.reason = format!(
            "a {} alarm at {:.3} s, before the fault at {t_f:.3} s",
            early.kind, early.t_s
        );
        return r;
    }
    if let Some(d) = r.deadline_s {
        match first {
            Some(t) if t <= d => {}
            Some(t) => {
                r.verdict = Verdict::Fail;
                r.reason = format!("the first alarm at {t:.3} s is after the deadline {d:.3} s");
            }
            None => {
                r.verdict = Verdict::Fail;
                r.reason = format!("no alarm by the deadline {d:.3} s (fault at {t_f:.3} s)");
            }
        }
    }
    r
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rising_edges_become_alarms() {
        let s = [
            (0, false, false),
            (1_000_000_000, false, true),
            (1_100_000_000, true, true),
            (1_200_000_000, false, true),
            (1_300_000_000, true, false),
        ];
        let a = alarms(s);
        let kinds: Vec<_> = a.iter().map(|a| (a.kind, a.t_s)).collect();
        assert_eq!(
            kinds,
            [("actuator", 1.0), ("hunting", 1.1), ("hunting", 1.3)]
        );
    }
}
