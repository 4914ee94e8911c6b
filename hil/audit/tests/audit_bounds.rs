//! `hil audit`'s proofs: no observed value exceeds its proven bound (ranges and rounding
//! errors, over every scenario including the closed-loop plant runs), the WCPGs agree
//! with independent sums, and the lead's range bound is attained by the worst-case
//! input (so it is tight, not vacuous).

#![allow(clippy::unwrap_used, clippy::expect_used)]

use wheelset_audit::bounds::{self, Quantised};
use wheelset_audit::wcpg::wcpg;
use wheelset_audit::{self as audit, AuditArgs};
use wheelset_control::{Config, Fx, Lead, LeadState, Sample};

fn args() -> AuditArgs {
    AuditArgs {
        no_sweep: true,
        no_target: true,
        quiet: true,
        ..AuditArgs::default()
    }
}

#[test]
fn no_observed_value_exceeds_its_proven_bound() {
    let a = audit::build(&args()).unwrap();
    assert!(a.overflow_free, "{}", a.proof_statement);
    assert!(a.proof_statement.starts_with("No overflow for any input"));
    // Every observed signal of the ranges table has a proven bound.
    for r in a.observed.signals.iter().filter(|r| r.samples > 0) {
        assert!(
            a.bounds.iter().any(|b| b.signal == r.name),
            "{} has no proven bound",
            r.name
        );
    }
    let mut compared = 0;
    for b in &a.bounds {
        assert!(b.proven_max.is_finite() && b.proven_max > 0.0, "{b:?}");
        assert!(b.margin_bits > 0.0, "{b:?}");
        if let Some(o) = b.observed_max {
            assert!(
                o <= b.proven_max,
                "{}: observed {o} > proven {}",
                b.signal,
                b.proven_max
            );
            compared += 1;
        }
    }
    assert!(compared >= 21, "{compared} signals compared");
    assert_eq!(a.error_bounds.len(), 4);
    for e in &a.error_bounds {
        assert!(e.observed > 0.0, "{} never rounded", e.output);
        assert!(
            e.observed <= e.proven,
            "{}: {} > {}",
            e.output,
            e.observed,
            e.proven
        );
        // The bound is the sum of its rounding points.
        let s: f64 = e.rounding_points.iter().map(|p| p.1).sum();
        assert!((s - e.proven).abs() <= 1e-12 * e.proven, "{}", e.output);
    }
    // The format proposals hold the proven bound.
    for r in &a.recommendations {
        assert!(2f64.powi(r.int_bits as i32 - 1) > r.proven_max_pu, "{r:?}");
        assert!(r.guarantee.contains("cannot overflow"));
    }
    // The report's JSON field names.
    let v = serde_json::to_value(&a).unwrap();
    for k in [
        "signal",
        "observed_max",
        "proven_max",
        "format",
        "margin_bits",
    ] {
        assert!(v["bounds"][0].get(k).is_some(), "bounds.{k}");
    }
    for k in ["output", "observed", "proven", "unit"] {
        assert!(v["error_bounds"][0].get(k).is_some(), "error_bounds.{k}");
    }
}

#[test]
fn lead_wcpgs_agree_with_independent_sums() {
    let cfg = Config::default();
    let k = Quantised::of::<Fx>(&cfg).unwrap();
    let l = k.lead;
    let kappa = l.kappa;
    let es = bounds::lead_error_systems(&l);
    // r1 -> dz: kappa sum (1 - kappa)^k = 1; r2 -> dz: 1/kappa.
    let w1 = wcpg(&es[0]).unwrap().value;
    let w2 = wcpg(&es[1]).unwrap().value;
    assert!(w1 >= 1.0 && w1 - 1.0 < 1e-9, "{w1}");
    assert!(w2 >= 1.0 / kappa && w2 - 1.0 / kappa < 1e-9 / kappa, "{w2}");
    // x -> x - z by simulating the impulse response directly (not the state space).
    let mut z = 0.0f64;
    let mut x1 = 0.0f64;
    let mut sum = 0.0;
    for n in 0..200_000 {
        let x = if n == 0 { 1.0 } else { 0.0 };
        z += kappa * (l.g_half * (x + x1) - z);
        x1 = x;
        sum += (x - z).abs();
    }
    let (_, s) = &bounds::lead_systems(&l)[4];
    let w = wcpg(s).unwrap().value;
    assert!(w >= sum && w - sum < 1e-9, "{w} vs {sum}");
}

#[test]
fn the_lead_range_bound_is_attained_by_the_worst_case_input() {
    let cfg = Config::default();
    let k = Quantised::of::<Fx>(&cfg).unwrap();
    let fmt = audit::qdyn::Formats::PRODUCTION.signal;
    let none = audit::ranges::observe::<Fx>(&cfg, &[], fmt, &|c| *c).unwrap();
    let p = bounds::prove(&cfg, &k, fmt, &none, [0.0; 4]);
    // A lead signal's proven bound, pu of y'.
    let pu =
        |n: &str| p.bounds.iter().find(|b| b.signal == n).unwrap().proven_max / cfg.scales.y_dot;
    // The lead's input bound X: the predicted y' clamped to `p_max`.
    let x_max = k.p_max.min(pu("predictor y' + 2d (before clamp)"));
    let (_, s) = &bounds::lead_systems(&k.lead)[4];
    let w = wcpg(s).unwrap().value;
    // Impulse response h of x -> x - z, then x[n] = X sign h[N - n] maximises the
    // output at n = N.
    let n = 4000usize;
    let (mut z, mut x1, mut h) = (0.0f64, 0.0f64, Vec::with_capacity(n));
    for i in 0..n {
        let x = if i == 0 { 1.0 } else { 0.0 };
        z += k.lead.kappa * (k.lead.g_half * (x + x1) - z);
        x1 = x;
        h.push(x - z);
    }
    let lead = Lead::<Fx>::new(&k.lead).unwrap();
    let mut st = LeadState::<Fx>::default();
    let mut last = 0.0;
    for i in 0..n {
        let x = Fx::from_f64(x_max * h[n - 1 - i].signum());
        let _ = lead.process(&mut st, x);
        last = x.to_f64() - st.z.to_f64();
    }
    let proven = pu("lead x - z");
    assert!(last.abs() <= proven, "{last} > {proven}");
    assert!(
        last.abs() >= 0.999 * w * x_max,
        "{last} vs WCPG X {}",
        w * x_max
    );
}

#[test]
fn the_closed_loop_section_measures_and_attributes_the_straight_track_cycle() {
    let a = audit::build(&args()).unwrap();
    let cl = a.closed_loop.as_ref().expect("closed loop ran");
    let lc = &cl.limit_cycle;
    // The core adapter with every source is the device: same torque figures.
    assert!(
        (lc.core_all_sources.torque_p2p_nm - lc.device.torque_p2p_nm).abs() <= 0.1 + 1e-9,
        "{:?} vs {:?}",
        lc.core_all_sources,
        lc.device
    );
    assert_eq!(lc.amplitude, lc.device.torque_p2p_nm);
    // One attribution per removed source, each the p2p of its run.
    assert_eq!(lc.attribution.len(), lc.removed.len());
    for (n, c) in &lc.removed {
        assert_eq!(lc.attribution[n], c.torque_p2p_nm);
    }
    // The classification follows the definition: self-sustained iff above twice the
    // proven rounding bound (or one wire LSB).
    let selfs = lc.amplitude > (2.0 * lc.dither_limit_nm).max(0.1);
    assert_eq!(lc.classification.starts_with("self-sustained"), selfs);
    if selfs {
        assert!(lc.freq_hz > 0.0);
        assert!(lc.reference.torque_p2p_nm < lc.amplitude);
    }
    // The JSON as the report spells it.
    let v = serde_json::to_value(&a).unwrap();
    let j = &v["closed_loop"];
    for k in ["amplitude", "unit", "freq_hz", "attribution"] {
        assert!(j["limit_cycle"].get(k).is_some(), "limit_cycle.{k}");
    }
    // The finding reads as what it is: the oscillation left with each source removed,
    // least first, and the source whose removal takes the most away named as its cause.
    let c = a
        .checks
        .iter()
        .find(|c| c.item.starts_with("closed-loop limit cycle"))
        .unwrap();
    let least = lc
        .removed
        .iter()
        .min_by(|x, y| x.1.torque_p2p_nm.total_cmp(&y.1.torque_p2p_nm))
        .unwrap();
    assert!(
        c.reason.contains(&format!(
            "without the {} {:.2} N m",
            least.0, least.1.torque_p2p_nm
        )),
        "{}",
        c.reason
    );
    if least.1.torque_p2p_nm < 0.5 * lc.core_all_sources.torque_p2p_nm {
        assert!(
            c.reason.contains(&format!("the {} sustains it", least.0)),
            "{}",
            c.reason
        );
    }
    assert!(c.remedy.contains("To remove it: ") && c.remedy.contains("To accept it: "));
    // The margins against the usual 6 dB / 30 deg: a warning exactly when below, and
    // the remedy of the yaw loop names the axle's torsion mode it crosses beside.
    for m in &cl.margins {
        for (item, value, usual) in [
            (
                "gain margin against the usual 6 dB",
                m.gain_db_quantised,
                6.0,
            ),
            (
                "phase margin against the usual 30 deg",
                m.phase_deg_quantised,
                30.0,
            ),
        ] {
            let c = a
                .checks
                .iter()
                .find(|c| c.controller == m.loop_name && c.item == item)
                .unwrap_or_else(|| panic!("{} {item}", m.loop_name));
            let below = value.unwrap() < usual;
            assert_eq!(c.status == audit::Status::Warn, below, "{c:?}");
            if m.loop_name.starts_with("yaw") {
                assert!(c.remedy.contains("torsion mode (40 Hz)"), "{}", c.remedy);
            }
        }
    }
    // Every check states what to do should it not pass.
    for c in &a.checks {
        assert!(!c.remedy.is_empty(), "no remedy: {c:?}");
    }
    assert_eq!(j["margins"].as_array().unwrap().len(), 2);
    for k in [
        "loop",
        "gain_db_ideal",
        "gain_db_quantised",
        "phase_deg_ideal",
        "phase_deg_quantised",
    ] {
        assert!(j["margins"][0].get(k).is_some(), "margins.{k}");
    }
}

#[test]
fn findings_are_attributed_by_experiment() {
    let a = audit::build(&args()).unwrap();
    let d = a.diagnosis.as_ref().expect("production formats: diagnosis");
    let p = d.pi.as_ref().expect("full-scale steps ran");
    // Each removal can only take error away, and the shares account for the baseline.
    assert!(p.with_quantised_ki_lsb < p.baseline_lsb);
    let sum: f64 = p.shares.iter().map(|s| s.1).sum();
    assert!((sum - p.baseline_lsb).abs() < 1e-9 * p.baseline_lsb);
    // The baseline is the audit's own u_a figure for that scenario.
    let n = a
        .observed
        .noise
        .iter()
        .find(|n| {
            n.output == "u_a"
                && n.scenario == p.scenario
                && n.yaw_mode == "lead"
                && n.phase == wheelset_audit::ranges::Phase::Normal
        })
        .unwrap();
    assert_eq!(n.max_lsb, p.baseline_lsb);
    // The remedy follows the largest share.
    if p.shares[0].0 == "quantisation of Ki" {
        assert!(p.remedy.starts_with("a finer representation of Ki"));
    }
    // The remedy is in place: Ki is held with its own shift, keeps more than 27
    // significant bits, and its quantisation is no longer a visible share (it was
    // 138.4 of 149.4 LSB with Ki in plain Q1.31, 16.4 significant bits).
    assert!(p.ki_shift >= 1, "{p:?}");
    assert!(p.ki_significant_bits > 27.0, "{p:?}");
    let ki_share = p
        .shares
        .iter()
        .find(|s| s.0 == "quantisation of Ki")
        .map(|s| s.1)
        .unwrap();
    assert!(ki_share.abs() < 1.0, "{p:?}");
    assert_ne!(p.shares[0].0, "quantisation of Ki", "{p:?}");
    // Amplitude sweep: descending, and the stated threshold is where the warn
    // tolerances stop holding.
    let la = &d.lead_amplitude;
    assert!(la
        .points
        .windows(2)
        .all(|w| w[0].amplitude_mps > w[1].amplitude_mps));
    let t = a.tolerances;
    if let Some(x) = la.within_tolerance_down_to_mps {
        for p in la.points.iter().filter(|p| p.amplitude_mps >= x) {
            assert!(p.gain_db <= t.fixed_gain_db.0 && p.phase_deg <= t.fixed_phase_deg.0);
        }
        if let Some(b) = la.points.iter().find(|p| p.amplitude_mps < x) {
            assert!(b.gain_db > t.fixed_gain_db.0 || b.phase_deg > t.fixed_phase_deg.0);
        }
    }
    // One limit-cycle definition: a dither moves by at most one LSB.
    for c in &a.controllers {
        for l in &c.limit_cycles {
            match l.classification.as_str() {
                "none" => assert!(!l.oscillates),
                "bounded dither" => assert!(l.p2p_lsb <= 1.0 + 1e-9),
                "self-sustained oscillation" => assert!(l.p2p_lsb > 1.0),
                other => panic!("unknown classification {other}"),
            }
        }
    }
}
