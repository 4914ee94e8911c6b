//! An active yaw law is taken only where it is designed
//! (`wheelset_control::design::DesignPoint::yaw`): at rates whose design has the passive
//! law only, a later Config without rates that asks for the lead or the gain law is
//! refused (`YawNotDesigned`), the passive one taken; back at a rate whose yaw law is
//! designed, an active law is taken again without new rates.

use wheelset_control::design::DESIGNED;
use wheelset_control::Fx;
use wheelset_proto::*;
use wheelset_runtime::*;

mod common;
use common::{act, frame, vel};

/// A Config in `mode`, with the rates of the design at `point` (or none: the rates kept).
fn config(mode: YawMode, point: Option<(u32, u8)>) -> Vec<u8> {
    let rates = point.map(|(hz, d)| {
        let cfg = RuntimeConfig::default()
            .designed(hz, d)
            .expect("a design point");
        rates_for::<Fx>(&cfg).expect("valid")
    });
    frame(&Message::Config(Config {
        mode,
        traction: true,
        enable: true,
        hold_ticks: 2,
        wsp: false,
        monitor_safe: false,
        rates,
    }))
}

/// Applies `bytes`, ticks once; the refusal flag and reason after it.
fn verdict(r: &mut Runtime<Fx>, seq: u16, bytes: &[u8]) -> (bool, RefuseReason) {
    r.receive(bytes);
    r.receive(&vel(seq, 0));
    let a = act(r.tick(0));
    (a.flags.has(Flags::CMD_REFUSED), r.refuse_reason())
}

#[test]
fn an_active_law_is_refused_where_only_the_passive_one_is_designed() {
    let passive_only = DESIGNED
        .iter()
        .find(|p| !p.yaw)
        .map(|p| (p.base_rate_hz, p.delay_ticks))
        .expect("a design with the passive law only");
    let mut r = Runtime::<Fx>::try_new(RuntimeConfig::default()).expect("the default runs");
    // At the boot rates (designed with the yaw law) an active law is taken.
    assert_eq!(
        verdict(&mut r, 1, &config(YawMode::Gain, None)),
        (false, RefuseReason::None)
    );
    // To the passive-only design: taken with the passive law.
    assert_eq!(
        verdict(&mut r, 2, &config(YawMode::Passive, Some(passive_only))),
        (false, RefuseReason::None)
    );
    assert_eq!(r.base_rate_hz(), passive_only.0);
    // Then, without rates: an active law is refused, the passive one taken.
    for (k, mode) in [YawMode::Lead, YawMode::Gain].into_iter().enumerate() {
        let seq = 3 + 2 * k as u16;
        assert_eq!(
            verdict(&mut r, seq, &config(mode, None)),
            (true, RefuseReason::YawNotDesigned),
            "{mode:?}"
        );
        assert_eq!(r.core().mode(), YawMode::Passive, "nothing changed");
        assert_eq!(
            verdict(&mut r, seq + 1, &config(YawMode::Passive, None)),
            (false, RefuseReason::YawNotDesigned),
            "the passive law is taken (the reason stays until the next refusal)"
        );
    }
    assert_eq!(r.counters().cmd_refused, 2);
    // Back at the paper's point with the passive law: an active law without rates again.
    assert!(!verdict(&mut r, 7, &config(YawMode::Passive, Some((5_000, 1)))).0);
    assert!(!verdict(&mut r, 8, &config(YawMode::Lead, None)).0);
    assert_eq!(r.core().mode(), YawMode::Lead);
    assert_eq!(r.counters().cmd_refused, 2);
}
