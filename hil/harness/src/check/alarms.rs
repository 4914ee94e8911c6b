//! The `monitor` section of `hil run`: the device's alarms (rising edges of `HUNTING`,
//! `ACTUATOR_FAULT`, `DRIVE_OSC` in the Actuation frames; `source = "device-flags"`)
//! judged against the scenario (`docs/monitor.md`). The figure's mean square, which the
//! wire does not carry, is the device's monitor code replayed on its `y'` codes ([`replay`]).
//!
//! **Yaw.** Without a plant fault no alarm is allowed (unless the plant hunts on its
//! own: then one is due before the divergence). With an `[actuator_fault]` from `t_f`
//! under an active law, none before `t_f`; after it the faulty loop
//! (`wheelset_plant::fault::faulty_loop_mode`, delivered gain `g`) decides: its least
//! stable mode grows at `sigma_g`, and with `sigma_g > 0` the first alarm is due by
//!
//! ```text
//! t_alarm - t_f <= [ ln(thr / A_0) + ln(1 + 2 sigma tau)/2 ] / sigma + B,
//! sigma = min(sigma_g, sigma_0)
//! ```
//!
//! (`A_0` the band-passed RMS of `y'` over the block before `t_f`, at least its wire LSB;
//! the second term the exponential mean square's lag; `B` one actuator-check block of
//! slack; `sigma_0` the stopped actuator's mode: a reversed actuator's faster mode lasts
//! only until its torque saturates). With `sigma_g <= 0` no alarm is due. A deadline
//! after the run's end is not judged (`optional`); a run that diverges after the fault
//! with no alarm fails.
//!
//! **The drive** ([`judge_drive`]). The device's current loop on the run's armature
//! circuit (`wheelset_plant::sampled::current_loop_mode`, the run's delay) has its fast
//! pair at radius `rho` per base tick. With `rho >= 1` the run's first alarm must be the
//! drive's, by
//!
//! ```text
//! t_alarm <= [ ln(thr / A_0) + ln(1 + 2 sigma tau)/2 ] / sigma + (P + N)/f_t,
//! sigma = f_b ln(rho),   tau = N/f_t,   A_0 = 1 mA (one wire LSB)
//! ```
//!
//! (`P` the persistence, `N` the window, `f_b` the base and `f_t` the traction rate); the
//! yaw alarms are then reported, not judged. With `rho < 1` a drive alarm is false.

use serde::Serialize;
use wheelset_control::{Compiled, Fx, InputCodes, Monitor, MonitorParams, MonitorState, YawMode};
use wheelset_plant::control::YawLaw;
use wheelset_plant::fault::faulty_loop_mode;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::Trajectory;
use wheelset_proto::Flags;
use wheelset_runtime::RuntimeConfig;

use wheelset_report::Verdict;

/// One alarm: a rising edge of a monitor flag.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Alarm {
    /// `hunting` (stability monitor), `actuator` (actuator check) or `drive` (the drive
    /// check: the traction current loop oscillates).
    pub kind: &'static str,
    /// Arrival time of the first Actuation frame carrying it, s.
    pub t_s: f64,
}

/// The `monitor` section of the run report.
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct MonitorReport {
    /// Where the alarms come from (`device-flags`, see the module docs).
    pub source: &'static str,
    /// Every alarm, in time order.
    pub alarms: Vec<Alarm>,
    /// The first alarm's time, s (`null`: none).
    pub first_alarm_s: Option<f64>,
    /// `none` (no alarm allowed), `alarm` (an alarm by `deadline_s`, none before
    /// `fault_s`) or `optional` (after an actuator fault the faulty loop still damps, or
    /// whose deadline falls after the run's end: none before `fault_s`, none due after).
    pub expect: &'static str,
    /// The plant's actuator fault time, s.
    pub fault_s: Option<f64>,
    /// The actuator's delivered/commanded torque ratio once failed (`g`).
    pub fault_gain: Option<f64>,
    /// Growth rate of the faulty loop's least stable mode, 1/s (`sigma_g`; > 0: unstable).
    pub sigma_per_s: Option<f64>,
    /// Frequency of that mode, Hz (0: a real mode, a drift).
    pub mode_hz: Option<f64>,
    /// The growth rate the deadline is stated from, 1/s (module docs: `sigma`).
    pub deadline_sigma_per_s: Option<f64>,
    /// When the wheelset diverged (|y| > 50 mm; the run stops there), s.
    pub diverged_s: Option<f64>,
    /// Band-passed RMS of `y'` at the fault, m/s (`A_0`).
    pub rms_at_fault_m_s: Option<f64>,
    /// The stated deadline of the first alarm, s (absolute): the growth deadline (module
    /// docs), or the divergence if that comes first.
    pub deadline_s: Option<f64>,
    /// Pass, or fail with `reason`.
    pub verdict: Verdict,
    /// Why it failed (empty on pass).
    pub reason: String,
    /// The device's Status `first_alarm_tick` (`null`: no alarm, or no Status).
    pub device_first_alarm_tick: Option<u32>,
    /// The sample instant of that tick, s.
    pub device_first_alarm_s: Option<f64>,
    /// The drive check's expectation ([`judge_drive`]; its verdict is in `verdict`).
    pub drive: DriveReport,
}

/// The drive check's part of the `monitor` section (module docs, "The drive").
#[derive(Debug, Clone, PartialEq, Serialize, Default)]
pub struct DriveReport {
    /// `none` (no drive alarm allowed) or `alarm` (the first alarm of the run is the
    /// drive's, by `deadline_s`).
    pub expect: &'static str,
    /// The current loop's fast pair: radius per base tick (`>= 1`: unstable).
    pub current_radius: Option<f64>,
    /// Its frequency, Hz.
    pub mode_hz: Option<f64>,
    /// Its growth rate `f_b ln(rho)`, 1/s.
    pub sigma_per_s: Option<f64>,
    /// The armature inductance of the plant, H.
    pub l_a_h: f64,
    /// The actuation delay the analysis takes, base ticks.
    pub delay_ticks: usize,
    /// The drive deadline, s (absolute).
    pub deadline_s: Option<f64>,
    /// The first drive alarm, s.
    pub first_alarm_s: Option<f64>,
    /// The device's Status `first_drive_alarm_tick` (`null`: none, or no Status).
    pub device_first_alarm_tick: Option<u32>,
}

impl MonitorReport {
    /// Fails the report, keeping an earlier failure's reason.
    fn fail(&mut self, why: String) {
        if self.verdict != Verdict::Fail {
            self.reason = why;
        }
        self.verdict = Verdict::Fail;
    }

    /// The expectation in words: what is due, by when, and from what (the `hil run`
    /// summary and the report).
    #[must_use]
    pub fn expectation(&self) -> String {
        let m = self;
        let due = match (m.expect, m.deadline_s) {
            ("alarm", Some(d)) => format!("an alarm by {d:.3} s"),
            ("optional", _) => "no alarm due (one after the fault allowed)".to_string(),
            _ => "no alarm".to_string(),
        };
        let (Some(f), Some(g)) = (m.fault_s, m.fault_gain) else {
            return match m.deadline_s {
                Some(_) if m.expect == "alarm" => {
                    format!("{due} (the plant diverged there on its own)")
                }
                _ => due,
            };
        };
        let mode = match (m.sigma_per_s, m.mode_hz) {
            (Some(s), Some(hz)) if hz > 0.0 => format!("{s:.1} 1/s at {hz:.1} Hz"),
            (Some(s), _) => format!("{s:.1} 1/s, a drift"),
            _ => "unknown".to_string(),
        };
        let why = match (m.sigma_per_s, m.deadline_s, m.deadline_sigma_per_s) {
            (Some(s), _, _) if s <= 0.0 => "; the loop with it still damps".to_string(),
            (_, Some(d), Some(sd)) if m.expect == "optional" => {
                format!("; deadline {d:.3} s (growth {sd:.1} 1/s) after the run's end")
            }
            (_, _, Some(sd)) => format!("; deadline from growth {sd:.1} 1/s"),
            _ => String::new(),
        };
        format!(
            "{due} (actuator fault at {f:.3} s, {}: the loop's least stable mode {mode}{why}{})",
            delivering(g),
            m.diverged_s.map_or(String::new(), |d| format!(
                "; the wheelset diverged at {d:.3} s"
            ))
        )
    }
}

/// What an actuator at the delivered/commanded ratio `g` does, in words.
fn delivering(g: f64) -> String {
    if g == 0.0 {
        "delivering nothing".to_string()
    } else if g == -1.0 {
        "delivering its command reversed".to_string()
    } else {
        format!("delivering {g} of its command")
    }
}

/// Rising edges of the alarm flags (`HUNTING`, `ACTUATOR_FAULT`, `DRIVE_OSC`) in
/// `(t_ns, flags)` samples, in order.
#[must_use]
pub fn alarms(samples: impl IntoIterator<Item = (u64, Flags)>) -> Vec<Alarm> {
    let mut out = Vec::new();
    let mut was = Flags(0);
    for (t_ns, now) in samples {
        let t_s = t_ns as f64 * 1e-9;
        for (kind, flag) in [
            ("drive", Flags::DRIVE_OSC),
            ("actuator", Flags::ACTUATOR_FAULT),
            ("hunting", Flags::HUNTING),
        ] {
            if now.has(flag) && !was.has(flag) {
                out.push(Alarm { kind, t_s });
            }
        }
        was = now;
    }
    out
}

/// The device's monitor replayed on the samples it received (wire codes, one per period
/// from `t = 0`) under `rt` (its yaw mode: whether the law commands) and `p`: the mean
/// square `(t_s, (m/s)^2)` at each monitor step; `None` if `rt` does not compile.
#[must_use]
pub fn replay(
    codes: &[InputCodes],
    period_ns: u64,
    rt: &RuntimeConfig,
    p: &MonitorParams,
) -> Option<Vec<(f64, f64)>> {
    let mut control = rt.control;
    control.wire = wheelset_control::WireLsb::default();
    let codec = *Compiled::<Fx>::try_new(&control).ok()?.codec();
    let m = Monitor::<Fx>::try_new(p, control.base_rate_hz).ok()?;
    let commanding = rt.enable && control.yaw_mode != YawMode::Passive;
    let mut s = MonitorState::<Fx>::default();
    let mut ms = Vec::with_capacity(codes.len() / usize::from(m.divisor().max(1)) + 1);
    for (k, c) in codes.iter().enumerate() {
        // The traction reference (0 here) moves only the actuator check's quiet blocks.
        m.tick(&mut s, codec.decode(c).y_dot, commanding, Fx::ZERO);
        if s.phase == m.divisor() {
            // 1 pu of y' = 1 m/s: the mean square is in (m/s)^2.
            ms.push(((k as u64 * period_ns) as f64 * 1e-9, s.ms.to_num::<f64>()));
        }
    }
    Some(ms)
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
        m.tick(&mut s, r.yd_mps, true, 0.0);
        // (`phase` is reset to the divisor on the ticks that run a monitor step.)
        if r.t_s >= t_s - p.act_block_s && s.phase == m.divisor() {
            sum += s.band * s.band;
            n += 1;
        }
    }
    (n > 0).then(|| (sum / f64::from(n)).sqrt())
}

/// Checks `alarms` of a run of `sc` under the yaw law `law` (trajectory `tr`) against
/// the expectation above.
#[must_use]
pub fn judge(
    sc: &Scenario,
    law: YawLaw,
    tr: &Trajectory,
    p: &MonitorParams,
    alarms: Vec<Alarm>,
) -> MonitorReport {
    // The yaw alarms judged: those before the first drive alarm (module docs, "The drive").
    let cut = alarms
        .iter()
        .find(|a| a.kind == "drive")
        .map_or(f64::INFINITY, |a| a.t_s);
    let judged = |a: &&Alarm| a.kind != "drive" && a.t_s < cut;
    let first = alarms.iter().find(judged).map(|a| a.t_s);
    let mut r = MonitorReport {
        source: "device-flags",
        first_alarm_s: alarms.first().map(|a| a.t_s),
        alarms,
        expect: "none",
        diverged_s: tr.info.diverged_at_s,
        ..MonitorReport::default()
    };
    let diverged = tr.info.diverged_at_s;
    // The passive law commands no torque: its actuator's fault changes nothing.
    let fault = sc.actuator_fault.filter(|_| law != YawLaw::Passive);
    let Some(f) = fault else {
        // A plant that hunts on its own (passive control above its critical conicity).
        if let Some(d) = diverged {
            r.expect = "alarm";
            r.deadline_s = Some(d);
            if !r.first_alarm_s.is_some_and(|t| t <= d) {
                r.fail(format!(
                    "the plant hunted (diverged at {d:.3} s) with no alarm before"
                ));
            }
        } else if let Some(t) = first {
            r.fail(format!(
                "an alarm at {t:.3} s on a scenario without a fault"
            ));
        }
        return r;
    };
    let t_f = f.t_on_s();
    let g = f.mode.gain();
    r.fault_s = Some(t_f);
    r.fault_gain = Some(g);
    r.expect = "optional";
    let mode = faulty_loop_mode(&sc.params, sc.axle, sc.drive, law, g);
    let stopped = faulty_loop_mode(&sc.params, sc.axle, sc.drive, law, 0.0);
    r.sigma_per_s = mode.map(|m| m.sigma_per_s);
    r.mode_hz = mode.map(|m| m.f_hz);
    let a0 = band_rms_before(p, tr, t_f).map(|a| a.max(1e-6));
    r.rms_at_fault_m_s = a0;
    if let (Some(m), Some(a0)) = (mode, a0) {
        let sigma_g = m.sigma_per_s;
        if sigma_g > 0.0 {
            let sigma = match stopped.map(|s| s.sigma_per_s) {
                Some(s0) if s0 > 0.0 => sigma_g.min(s0),
                _ => sigma_g,
            };
            let tau = p.window_s / 2.0;
            let grow = ((p.threshold_m_s / a0).ln().max(0.0)
                + 0.5 * (1.0 + 2.0 * sigma * tau).ln())
                / sigma;
            let deadline = t_f + grow + p.act_block_s;
            r.deadline_sigma_per_s = Some(sigma);
            r.deadline_s = Some(deadline);
            let end = tr.records.last().map_or(t_f, |x| x.t_s);
            if deadline <= end {
                r.expect = "alarm";
            }
        }
    }
    // A run that diverged is due an alarm before, whatever the linearisation said.
    if let Some(d) = diverged {
        r.expect = "alarm";
        r.deadline_s = Some(r.deadline_s.map_or(d, |x| x.min(d)));
    }
    if let Some(early) = r.alarms.iter().filter(judged).find(|a| a.t_s < t_f) {
        r.fail(format!(
            "a {} alarm at {:.3} s, before the fault at {t_f:.3} s",
            early.kind, early.t_s
        ));
        return r;
    }
    if let Some(d) = diverged.filter(|&d| !r.first_alarm_s.is_some_and(|t| t <= d)) {
        r.fail(format!(
            "the wheelset diverged at {d:.3} s with no alarm before (fault at {t_f:.3} s)"
        ));
        return r;
    }
    if let (Some(d), "alarm") = (r.deadline_s, r.expect) {
        match first {
            Some(t) if t <= d => {}
            Some(t) => {
                r.fail(format!(
                    "the first alarm at {t:.3} s is after the deadline {d:.3} s"
                ));
            }
            None => {
                r.fail(format!(
                    "no alarm by the deadline {d:.3} s (fault at {t_f:.3} s)"
                ));
            }
        }
    }
    r
}

/// The drive check's expectation for a run of `sc` on `rt` with the monitor `p` and
/// `delay_ticks` of delay (module docs, "The drive"): the current loop's fast pair at the
/// plant's armature and the device's PI and rates, and from it the deadline.
#[must_use]
pub fn drive_expectation(
    sc: &Scenario,
    rt: &RuntimeConfig,
    p: &MonitorParams,
    delay_ticks: usize,
) -> DriveReport {
    let mut d = DriveReport {
        expect: "none",
        l_a_h: sc.params.l_a,
        delay_ticks,
        ..DriveReport::default()
    };
    if !rt.control.traction_enabled || !sc.drive {
        return d;
    }
    let arm = wheelset_plant::sampled::armature(sc.params.l_a, sc.params.r_a);
    let Ok(mode) = wheelset_plant::sampled::current_loop_mode(&arm, &rt.control, delay_ticks)
    else {
        return d;
    };
    let f_b = f64::from(rt.control.base_rate_hz.max(1));
    let f_t = f_b / f64::from(rt.control.traction_divisor.max(1));
    let sigma = f_b * mode.radius.ln();
    d.current_radius = Some(mode.radius);
    d.mode_hz = Some(mode.freq_hz);
    d.sigma_per_s = Some(sigma);
    if mode.radius >= 1.0 && sigma.is_finite() {
        let a0 = wheelset_proto::units::CURRENT_LSB_A;
        let (n, persist) = (
            f64::from(p.drive_window_steps),
            f64::from(p.drive_persist_steps),
        );
        let tau = n / f_t;
        let grow = if sigma > 0.0 {
            ((p.drive_ripple_a / a0).ln() + 0.5 * (1.0 + 2.0 * sigma * tau).ln()) / sigma
        } else {
            f64::INFINITY
        };
        d.expect = "alarm";
        d.deadline_s = Some(grow + (persist + n) / f_t);
    }
    d
}

/// Judges the drive alarms of `r` (made by [`judge`]) against `drive`
/// ([`drive_expectation`]), the run ending at `end_s`: fills `r.drive` and fails `r`
/// (keeping an earlier failure's reason) on a missing, late or false drive alarm.
pub fn judge_drive(r: &mut MonitorReport, mut drive: DriveReport, end_s: f64) {
    let first_drive = r.alarms.iter().find(|a| a.kind == "drive").map(|a| a.t_s);
    drive.first_alarm_s = first_drive;
    drive.device_first_alarm_tick = r.drive.device_first_alarm_tick;
    match (drive.expect, drive.deadline_s) {
        ("alarm", Some(due)) => {
            let first = r.alarms.first();
            match first_drive {
                Some(t) if t <= due => {
                    if let Some(a) = first.filter(|a| a.kind != "drive") {
                        let why = format!(
                            "the first alarm is the {}'s at {:.3} s, not the drive's (at {t:.3} s): \
                             the current loop is unstable (radius {:.3} per tick)",
                            a.kind,
                            a.t_s,
                            drive.current_radius.unwrap_or(f64::NAN)
                        );
                        r.fail(why);
                    }
                }
                Some(t) => r.fail(format!(
                    "the drive alarm at {t:.3} s is after its deadline {due:.3} s"
                )),
                None if due > end_s => {}
                None => r.fail(format!(
                    "no drive alarm by {due:.3} s: the current loop is unstable (radius \
                         {:.3} per tick, {:.0} Hz, l_a = {:.3e} H)",
                    drive.current_radius.unwrap_or(f64::NAN),
                    drive.mode_hz.unwrap_or(f64::NAN),
                    drive.l_a_h
                )),
            }
        }
        _ => {
            if let Some(t) = first_drive {
                r.fail(format!(
                    "a drive alarm at {t:.3} s on a drive whose current loop is stable \
                         (radius {:.3} per tick)",
                    drive.current_radius.unwrap_or(f64::NAN)
                ));
            }
        }
    }
    r.drive = drive;
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rising_edges_become_alarms() {
        let (h, a, d) = (Flags::HUNTING, Flags::ACTUATOR_FAULT, Flags::DRIVE_OSC);
        let s = [
            (0, 0),
            (1_000_000_000, a),
            (1_100_000_000, h | a | d),
            (1_200_000_000, a | d),
            (1_300_000_000, h),
        ];
        let a = alarms(s.map(|(t, f)| (t, Flags(f))));
        let kinds: Vec<_> = a.iter().map(|a| (a.kind, a.t_s)).collect();
        assert_eq!(
            kinds,
            [
                ("actuator", 1.0),
                ("drive", 1.1),
                ("hunting", 1.1),
                ("hunting", 1.3)
            ]
        );
    }
}
