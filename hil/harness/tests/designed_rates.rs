//! `hil run --rate-hz R` on `curve` at every rate whose yaw law is designed with one
//! tick of delay (`wheelset_control::design::DESIGNED`), in process: the device at the
//! gains designed for the rate, judged against the f64 core at the same rate with the
//! harness's own tolerances; and a rate without a design refused before the run.

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
