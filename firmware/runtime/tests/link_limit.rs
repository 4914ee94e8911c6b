//! The board's link limit (`Runtime::set_link_limit`): a Config whose base rate is above
//! what the board's link carries is refused and counted; the previous rates stay.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use wheelset_control::Fx;
use wheelset_proto::{encode_vec, Config, Flags, Message, YawMode};
use wheelset_runtime::{rates_for, Runtime, RuntimeConfig};

fn config_at(rate_hz: u32) -> Vec<u8> {
    let cfg = RuntimeConfig::default().designed(rate_hz, 1).unwrap();
    let m = Message::Config(Config {
        mode: YawMode::Lead,
        traction: true,
        enable: true,
        hold_ticks: cfg.hold_ticks,
        rates: Some(rates_for::<Fx>(&cfg).unwrap()),
        monitor_safe: false,
        wsp: false,
    });
    encode_vec(&m).unwrap().to_vec()
}

fn refused(rt: &mut Runtime<Fx>) -> bool {
    let out = rt.tick(0).to_vec();
    let mut d: wheelset_proto::Decoder = wheelset_proto::Decoder::new();
    match d.next_message(&out).0 {
        Some(Ok(Message::Actuation(a))) => a.flags.has(Flags::CMD_REFUSED),
        other => panic!("expected an actuation frame first, got {other:?}"),
    }
}

#[test]
fn a_rate_above_the_link_limit_is_refused_and_one_within_is_taken() {
    let mut rt = Runtime::<Fx>::try_new(RuntimeConfig::default()).unwrap();
    rt.set_link_limit(5_000);
    rt.receive(&config_at(10_000));
    assert!(refused(&mut rt));
    assert_eq!(rt.base_rate_hz(), 5_000);
    assert_eq!(rt.counters().cmd_refused, 1);
    rt.receive(&config_at(2_500));
    assert!(!refused(&mut rt));
    assert_eq!(rt.base_rate_hz(), 2_500);
    // At the limit itself: taken.
    rt.receive(&config_at(5_000));
    assert!(!refused(&mut rt));
    assert_eq!(rt.base_rate_hz(), 5_000);
}

#[test]
fn without_a_limit_any_designed_rate_is_taken() {
    let mut rt = Runtime::<Fx>::try_new(RuntimeConfig::default()).unwrap();
    rt.receive(&config_at(10_000));
    assert!(!refused(&mut rt));
    assert_eq!(rt.base_rate_hz(), 10_000);
}
