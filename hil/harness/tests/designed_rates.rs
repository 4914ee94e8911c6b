//! `hil run --rate-hz R [--delay-ticks D]` on `curve` at every designed point
//! (`wheelset_control::design::DESIGNED`), in process: the lead where its yaw law is
//! designed (longer delays over a link whose round trip needs them), the passive law
//! elsewhere; the device at the gains designed for the point, judged against the f64 core
//! at the same rate and delay with the harness's own tolerances. A rate without a design,
//! and a link that cannot carry a delay, refused before the run.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use hil::run::{run, RunOptions};
use wheelset_control::design::DESIGNED;
use wheelset_loop::sim_link::LinkConfig;
use wheelset_report::Verdict;

fn at(hz: u32) -> RunOptions {
    RunOptions {
        rate_hz: Some(hz),
        // 10 Mbaud carries 10 kHz within the link budget (the default 5 Mbaud does not).
        link: LinkConfig {
            baud: 10_000_000,
            ..LinkConfig::default()
        },
        ..RunOptions::default()
    }
}

/// A one-way latency whose round trip at 10 Mbaud needs all `d` ticks: `d - 1/2` of the
/// delay's 85 % share.
fn pipelined_latency_ns(hz: u32, d: u8) -> u64 {
    let period = 1e9 / f64::from(hz);
    let wire = wheelset_loop::sim_link::wire_ns(
        wheelset_proto::SENSOR_ONE_LATERAL_MAX_FRAME + wheelset_proto::ACTUATION_MAX_FRAME,
        10_000_000,
    ) as f64;
    ((0.85 * (f64::from(d) - 0.5) * period - wire) / 2.0) as u64
}

#[test]
fn every_designed_rate_passes_on_the_curve() {
    for p in DESIGNED.iter().filter(|p| p.delay_ticks == 1 && p.yaw) {
        let out = run(&at(p.base_rate_hz)).expect("the run is made");
        let r = &out.report;
        assert_eq!(
            r.verdict,
            Verdict::Pass,
            "{} Hz: {}",
            p.base_rate_hz,
            serde_json::to_string_pretty(r).unwrap()
        );
    }
}

#[test]
fn a_rate_without_a_design_is_refused_before_the_run() {
    for (hz, why) in [
        (4_000, "no gains are designed for 4000 Hz"),
        (500, "no lead or gain holds the yaw loop"),
    ] {
        let e = run(&at(hz)).err().expect("refused").to_string();
        assert!(e.contains(why), "{hz} Hz: {e}");
    }
}

#[test]
fn every_designed_longer_delay_passes_over_a_pipelined_link() {
    for p in DESIGNED.iter().filter(|p| p.delay_ticks > 1 && p.yaw) {
        let (hz, d) = (p.base_rate_hz, p.delay_ticks);
        let mut o = at(hz);
        o.delay_ticks = d;
        o.link.latency_ns = pipelined_latency_ns(hz, d);
        let out = run(&o).expect("the run is made");
        let r = &out.report;
        assert_eq!(
            r.verdict,
            Verdict::Pass,
            "{hz} Hz, {d} ticks: {}",
            serde_json::to_string_pretty(r).unwrap()
        );
        // The same link with one tick less is refused before the run, naming the budget.
        o.delay_ticks = d - 1;
        let e = run(&o).err().expect("refused").to_string();
        assert!(
            e.contains("link budget exceeded"),
            "{hz} Hz, {d} ticks: {e}"
        );
    }
}

#[test]
fn every_point_designed_for_the_passive_law_alone_passes_with_it() {
    for p in DESIGNED.iter().filter(|p| !p.yaw) {
        let (hz, d) = (p.base_rate_hz, p.delay_ticks);
        let mut o = at(hz);
        o.control = hil::run::Law::Passive;
        o.delay_ticks = d;
        if d > 1 {
            o.link.latency_ns = pipelined_latency_ns(hz, d);
        }
        let out = run(&o).expect("the run is made");
        assert_eq!(
            out.report.verdict,
            Verdict::Pass,
            "{hz} Hz, {d} ticks, passive: {}",
            serde_json::to_string_pretty(&out.report).unwrap()
        );
    }
}
