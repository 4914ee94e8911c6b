//! The gains designed per base rate and delay: the criteria every point of
//! `wheelset_control::design::DESIGNED` meets, the search for each point's lead gain, and
//! the verdict on every candidate (`docs/closed-loop.md`, "Choosing the rates").

use super::*;
use crate::params::Params;
use wheelset_control::design::LEAD_GAIN_STEPS;
use wheelset_control::Config;

/// Candidate base rates of the design, Hz: whole microseconds per period that the
/// scenarios' 100 us step divides, from 500 Hz.
pub const CANDIDATE_RATES: [u32; 6] = [500, 1_000, 2_000, 2_500, 5_000, 10_000];

/// Candidate delays, ticks.
pub const CANDIDATE_DELAYS: [u8; 3] = [1, 2, 3];

/// Minimum traction gain margin, dB.
pub const TRACTION_GAIN_DB: f64 = 6.0;
/// Minimum traction phase margin, degrees.
pub const TRACTION_PHASE_DEG: f64 = 45.0;
/// Largest contraction of the current loop's fast pair per `max(tau, tau_0 = 300 us)`:
/// `0.75^1.5`, i.e. 0.75 per tick with one tick of delay at or below 5 kHz.
pub const CURRENT_DECAY: f64 = 0.649_519_052_838_329;
/// How far the yaw gain margins may fall below the paper's lead at 5 kHz, dB.
pub const YAW_GAIN_SLACK_DB: f64 = 1.0;
/// How far the yaw phase margin may fall below the paper's lead at 5 kHz, degrees.
pub const YAW_PHASE_SLACK_DEG: f64 = 5.0;

/// One candidate judged.
#[derive(Debug, Clone)]
pub struct DesignRow {
    /// Base rate, Hz.
    pub base_rate_hz: u32,
    /// Delay, ticks.
    pub delay_ticks: u8,
    /// The lead gain factor judged (the largest step that passes, or the last tried).
    pub lead_gain: f64,
    /// The traction `Kp`, V/A.
    pub kp: f64,
    /// Yaw loop margins.
    pub yaw: Margins,
    /// Traction loop margins.
    pub traction: Margins,
    /// Current loop fast pair: contraction per tick.
    pub current_radius: f64,
    /// The same per `max(tau, tau_0)` ([`decay_of`]).
    pub current_decay: f64,
    /// Grid points held by the paper's continuous loop and lost by this sampled loop.
    pub newly_unstable: usize,
    /// `None`: every criterion met; else the first one failed.
    pub failed: Option<String>,
    /// The traction criteria hold (the point is accepted, with the passive yaw law alone
    /// if `failed` names the yaw loop or the grid).
    pub traction_ok: bool,
}

/// The paper's lead at 5 kHz with one tick on `p`: the yaw reference margins.
pub fn reference_yaw(p: &Params) -> Result<Margins, String> {
    margins(p, &Config::default(), 1, Loop::Yaw)
}

/// A per-tick contraction as the criterion judges it (module docs).
pub fn decay_of(radius: f64, base_rate_hz: u32, delay_ticks: u8) -> f64 {
    let t = 1.0 / f64::from(base_rate_hz);
    let tau = wheelset_control::design::effective_delay_s(base_rate_hz, delay_ticks);
    radius.powf(tau.max(wheelset_control::design::TAU_0_S) / t)
}

/// Judge `base` redesigned for one rate, delay and lead gain (module docs).
pub fn judge(
    p: &Params,
    base: &Config,
    base_rate_hz: u32,
    delay_ticks: u8,
    lead_gain: f64,
    reference: &Margins,
) -> Result<DesignRow, String> {
    let cfg = base.with_design(base_rate_hz, delay_ticks, lead_gain);
    let d = usize::from(delay_ticks);
    let yaw = margins(p, &cfg, d, Loop::Yaw)?;
    let traction = margins(p, &cfg, d, Loop::Traction)?;
    let current_radius = current_loop_mode(&armature(p.l_a, p.r_a), &cfg, d)?.radius;
    let current_decay = decay_of(current_radius, base_rate_hz, delay_ticks);
    let val = |a: Option<At>| a.map(|a| a.value);
    let (ry_up, ry_down, ry_ph) = (
        val(reference.gain_up).unwrap_or(f64::INFINITY),
        val(reference.gain_down).unwrap_or(f64::NEG_INFINITY),
        val(reference.phase).unwrap_or(180.0),
    );
    let first =
        |checks: Vec<(bool, String)>| checks.into_iter().find_map(|(f, why)| f.then_some(why));
    let traction_failed = first(vec![
        (!traction.stable, "traction loop unstable".into()),
        (
            val(traction.gain_up).unwrap_or(f64::INFINITY) < TRACTION_GAIN_DB,
            format!("traction gain margin below {TRACTION_GAIN_DB} dB"),
        ),
        (
            val(traction.phase).unwrap_or(180.0) < TRACTION_PHASE_DEG,
            format!("traction phase margin below {TRACTION_PHASE_DEG} deg"),
        ),
        (
            current_decay > CURRENT_DECAY,
            format!("current loop contracts by {current_decay:.3} > {CURRENT_DECAY:.3} per max(tau, 300 us)"),
        ),
    ]);
    let traction_ok = traction_failed.is_none();
    let mut failed = traction_failed.or_else(|| {
        first(vec![
            (!yaw.stable, "yaw loop unstable".into()),
            (
                val(yaw.gain_up).unwrap_or(f64::INFINITY) < ry_up - YAW_GAIN_SLACK_DB,
                format!("yaw gain margin (up) more than {YAW_GAIN_SLACK_DB} dB below the paper's {ry_up:.2} dB"),
            ),
            (
                val(yaw.gain_down).unwrap_or(f64::NEG_INFINITY) > ry_down + YAW_GAIN_SLACK_DB,
                format!("yaw gain margin (down) more than {YAW_GAIN_SLACK_DB} dB below the paper's {:.2} dB", -ry_down),
            ),
            (
                val(yaw.phase).unwrap_or(180.0) < ry_ph - YAW_PHASE_SLACK_DEG,
                format!("yaw phase margin more than {YAW_PHASE_SLACK_DEG} deg below the paper's {ry_ph:.1} deg"),
            ),
        ])
    });
    let mut newly_unstable = 0;
    if failed.is_none() {
        for &creep in &CREEP_GRID {
            for &lambda in &CONICITY_GRID {
                let plant = Model::Full.plant(p, creep, lambda, false);
                let held = continuous_closed_loop(&plant, base)
                    .iter()
                    .all(|e| e.re < 0.0);
                newly_unstable += usize::from(held && !closed_loop(&plant, &cfg, d)?.stable());
            }
        }
        failed = (newly_unstable > 0).then(|| {
            format!("{newly_unstable} grid point(s) held in continuous time lost by sampling")
        });
    }
    Ok(DesignRow {
        base_rate_hz,
        delay_ticks,
        lead_gain,
        kp: cfg.pi.kp,
        yaw,
        traction,
        current_radius,
        current_decay,
        newly_unstable,
        failed,
        traction_ok,
    })
}

/// One candidate's design: the largest lead gain step meeting every criterion, else the last.
pub fn design_point(
    p: &Params,
    base: &Config,
    base_rate_hz: u32,
    delay_ticks: u8,
    reference: &Margins,
) -> Result<DesignRow, String> {
    let mut last = None;
    for g in LEAD_GAIN_STEPS {
        let row = judge(p, base, base_rate_hz, delay_ticks, g, reference)?;
        // A traction failure does not depend on the lead: no other step can mend it.
        if row.failed.is_none() || !row.traction_ok {
            return Ok(row);
        }
        last = Some(row);
    }
    last.ok_or_else(|| "no lead gain steps".to_string())
}

/// Every candidate rate and delay judged, in order of rate then delay.
pub fn design_table(p: &Params, base: &Config) -> Result<Vec<DesignRow>, String> {
    let reference = reference_yaw(p)?;
    let mut rows = Vec::new();
    for &r in &CANDIDATE_RATES {
        for &d in &CANDIDATE_DELAYS {
            rows.push(design_point(p, base, r, d, &reference)?);
        }
    }
    Ok(rows)
}

/// The design table as text, one row per candidate.
pub fn render_design(rows: &[DesignRow], reference: &Margins) -> String {
    use std::fmt::Write as _;
    let f = |a: Option<At>, w: usize| {
        a.map_or(format!("{:>w$}", "-"), |a| {
            format!("{:>w$}", format!("{:.2}@{:.0}", a.value, a.hz))
        })
    };
    let val = |a: Option<At>| a.map_or(f64::NAN, |a| a.value);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "== gains designed per base rate and delay (both loops every tick; what a device accepts)"
    );
    let _ = writeln!(
        s,
        "criteria: traction GM >= {TRACTION_GAIN_DB} dB, PM >= {TRACTION_PHASE_DEG} deg, \
         contraction <= {CURRENT_DECAY:.3} per max(tau, 300 us); yaw within \
         {YAW_GAIN_SLACK_DB} dB / {YAW_PHASE_SLACK_DEG} deg of the paper's lead at 5 kHz \
         (up {:.2} dB, down {:.2} dB, {:.2} deg); no grid point lost to sampling",
        val(reference.gain_up),
        val(reference.gain_down),
        val(reference.phase)
    );
    let _ = writeln!(
        s,
        "   base  d  lead K    Kp V/A | yaw GM up dB@Hz GM down dB@Hz  PM deg@Hz | traction GM dB@Hz  PM deg@Hz  decay | verdict"
    );
    for r in rows {
        let verdict = match (r.failed.as_deref(), r.traction_ok) {
            (None, _) => "accepted".to_string(),
            (Some(f), true) => format!("passive yaw only: {f}"),
            (Some(f), false) => format!("refused: {f}"),
        };
        let _ = writeln!(
            s,
            "  {:>5} {:>2}  {:>6.2} {:>9.4} | {} {} {} | {} {} {:>6.3} | {verdict}",
            r.base_rate_hz,
            r.delay_ticks,
            r.lead_gain,
            r.kp,
            f(r.yaw.gain_up, 15),
            f(r.yaw.gain_down, 13),
            f(r.yaw.phase, 10),
            f(r.traction.gain_up, 17),
            f(r.traction.phase, 10),
            r.current_decay,
        );
    }
    let _ = writeln!(
        s,
        "columns: d = ticks of delay; lead K = the design's factor on the paper's lead gain \
         (the largest that meets the criteria, the last tried when none does); decay = the \
         current loop's contraction per max(tau, 300 us), tau = (d + 1/2) T; passive yaw \
         only = the traction loop holds, the yaw loop does not: a device takes the point \
         with the passive law alone"
    );
    s
}

/// The design table as JSON.
pub fn design_json(rows: &[DesignRow]) -> serde_json::Value {
    use serde_json::json;
    let at = |a: Option<At>| a.map(|a| json!({"value": a.value, "hz": a.hz}));
    let m = |x: &Margins| {
        json!({
            "stable": x.stable,
            "gain_up_db": at(x.gain_up),
            "gain_down_db": at(x.gain_down),
            "phase_deg": at(x.phase),
        })
    };
    serde_json::Value::Array(
        rows.iter()
            .map(|r| {
                json!({
                    "base_rate_hz": r.base_rate_hz,
                    "delay_ticks": r.delay_ticks,
                    "lead_gain": r.lead_gain,
                    "kp_v_per_a": r.kp,
                    "yaw": m(&r.yaw),
                    "traction": m(&r.traction),
                    "current_radius_per_tick": r.current_radius,
                    "current_decay": r.current_decay,
                    "accepted": r.traction_ok,
                    "yaw_designed": r.failed.is_none(),
                    "refused_because": r.failed,
                })
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use wheelset_control::design::DesignPoint;

    /// The accepted points of a design table (as `DESIGNED` holds them): traction holds,
    /// the yaw law designed where it holds too.
    fn accepted(rows: &[DesignRow]) -> Vec<DesignPoint> {
        rows.iter()
            .filter(|r| r.traction_ok)
            .map(|r| {
                let yaw = r.failed.is_none();
                DesignPoint {
                    base_rate_hz: r.base_rate_hz,
                    delay_ticks: r.delay_ticks,
                    lead_gain: if yaw { r.lead_gain } else { 1.0 },
                    yaw,
                }
            })
            .collect()
    }

    /// The device's table is what the design finds, every other candidate fails a named
    /// criterion, and the paper's point is the paper's lead and PI.
    #[test]
    fn the_device_table_is_the_design() {
        let p = Params::default();
        let rows = design_table(&p, &Config::default()).expect("design");
        let found = accepted(&rows);
        assert_eq!(found, wheelset_control::design::DESIGNED.to_vec());
        for r in &rows {
            if r.traction_ok {
                // No crossing: no gain (phase) rotation turns the loop unstable.
                let at_least = |a: Option<At>, min: f64| a.is_none_or(|a| a.value >= min);
                assert!(at_least(r.traction.gain_up, TRACTION_GAIN_DB), "{r:?}");
                assert!(at_least(r.traction.phase, TRACTION_PHASE_DEG), "{r:?}");
                assert!(r.current_decay <= CURRENT_DECAY, "{r:?}");
                assert!(r.traction.stable);
            }
            if r.failed.is_none() {
                assert!(r.yaw.stable && r.newly_unstable == 0, "{r:?}");
            }
        }
        let paper = rows
            .iter()
            .find(|r| (r.base_rate_hz, r.delay_ticks) == (5_000, 1))
            .expect("the paper's point");
        assert_eq!((paper.lead_gain, paper.kp), (1.0, Config::default().pi.kp));
        // At 500 Hz nothing holds the yaw loop: passive only, with the loop named.
        assert!(rows
            .iter()
            .filter(|r| r.base_rate_hz == 500)
            .all(|r| r.traction_ok && r.failed.as_deref().is_some_and(|f| f.contains("yaw"))));
    }

    /// The margins of the paper's loops at 5 kHz with one tick, each loop alone (the
    /// design's reference), and the classical reading of the yaw loop's critical gains.
    #[test]
    fn the_paper_margins() {
        let p = Params::default();
        let y = reference_yaw(&p).expect("margins");
        assert!(y.stable && y.open_loop_unstable > 0);
        let up = y.gain_up.expect("up");
        let down = y.gain_down.expect("down");
        assert!(
            (up.value - 2.51).abs() < 0.01 && (up.hz - 42.0).abs() < 0.5,
            "{up:?}"
        );
        assert!(down.value < -7.0 && down.value > -7.7, "{down:?}");
        let ph = y.phase.expect("phase");
        assert!((ph.value - 15.96).abs() < 0.05, "{ph:?}");
        // Scaling the lead by the critical gain factors crosses stability.
        for (db, stable) in [
            (up.value - 0.2, true),
            (up.value + 0.2, false),
            (down.value + 0.2, true),
            (down.value - 0.2, false),
        ] {
            let mut c = Config::default();
            c.lead.k *= 10f64.powf(db / 20.0);
            c.traction_enabled = false;
            let plant = Model::Full.plant(&p, p.f11, p.lambda, false);
            assert_eq!(
                closed_loop(&plant, &c, 1).expect("loop").stable(),
                stable,
                "{db} dB"
            );
        }
        let t = margins(&p, &Config::default(), 1, Loop::Traction).expect("margins");
        assert!((t.gain_up.expect("gm").value - 6.10).abs() < 0.01);
        assert!((t.phase.expect("pm").value - 48.74).abs() < 0.05);
    }
}
