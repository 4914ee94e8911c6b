//! The counters and flags say what the docs say: the accounting identity,
//! unknown requests, HOLDING vs `held_ticks`, YAW_SAT under the safe ramp; and the
//! behaviour behind them: bumpless law changes, zero current in every 0 V state, the
//! complementary filter of `Lateral::Both`.

use wheelset_control::Fx;
use wheelset_proto::*;
use wheelset_runtime::*;

mod common;
use common::{act, sample, sensor_frame, vel};

fn sensor(seq: u16, lateral: Lateral) -> Vec<u8> {
    sensor_frame(sample(seq, lateral))
}

/// A CRC- and version-valid frame of message type `ty` with body `body`.
fn raw_frame(ty: u8, body: &[u8]) -> Vec<u8> {
    let mut raw = vec![VERSION, ty];
    raw.extend_from_slice(body);
    let mut out = vec![0u8; MAX_FRAME];
    let n = frame_raw(&raw, &mut out).expect("fits");
    out.truncate(n);
    out
}

fn config(mode: YawMode, enable: bool) -> Config {
    Config {
        mode,
        traction: true,
        enable,
        hold_ticks: DEFAULT_HOLD_TICKS,
        rates: None,
        monitor_safe: false,
        wsp: false,
    }
}

fn send(rt: &mut Runtime<Fx>, m: Message) {
    rt.receive(&encode_vec(&m).expect("fits"));
}

#[test]
fn unknown_requests_are_refused_not_decoding_errors_and_every_frame_counts_once() {
    let mut rt: Runtime<Fx> = Runtime::try_new(RuntimeConfig::default()).expect("valid");
    let mut sent = 0u32;
    let mut feed = |rt: &mut Runtime<Fx>, f: &[u8]| {
        rt.receive(f);
        sent += 1;
    };
    feed(&mut rt, &vel(1, 0));
    rt.tick(0);
    // An undefined Command variant (5) and a Config with an undefined mode (7).
    feed(&mut rt, &raw_frame(3, &[5]));
    let a = act(rt.tick(0));
    assert!(a.flags.has(Flags::CMD_REFUSED));
    assert_eq!(rt.refuse_reason(), RefuseReason::UnknownRequest);
    feed(&mut rt, &raw_frame(2, &[7, 1, 1, 10, 0]));
    assert_eq!(rt.counters().cmd_refused, 2);
    // A malformed Command (no body at all) is a decoding error.
    feed(&mut rt, &raw_frame(3, &[]));
    // Device -> host types: only rx_unexpected.
    feed(
        &mut rt,
        &encode_vec(&Message::Status(Status::default())).expect("fits"),
    );
    feed(&mut rt, &raw_frame(1, &[0xff]));
    // A CRC error.
    let mut bad = vel(2, 0);
    bad[3] ^= if bad[3] == 1 { 2 } else { 1 };
    feed(&mut rt, &bad);
    feed(&mut rt, &vel(3, 0));
    // An accepted Config clears the flag.
    send(&mut rt, Message::Config(config(YawMode::Lead, true)));
    sent += 1;
    let a = act(rt.tick(0));
    assert!(!a.flags.has(Flags::CMD_REFUSED));
    let c = *rt.counters();
    assert_eq!(c.rx_postcard, 1, "only the malformed one");
    assert_eq!(c.rx_unexpected, 2);
    assert_eq!(c.rx_ok, 5, "2 sensors, 2 unknown requests, 1 Config");
    // The identity: every delimited frame counts exactly once.
    let counted = c.rx_ok
        + c.rx_unexpected
        + c.rx_crc
        + c.rx_cobs
        + c.rx_version
        + c.rx_length
        + c.rx_postcard;
    assert_eq!(counted, sent);
}

#[test]
fn holding_flags_and_held_ticks_agree_through_the_safe_state() {
    let mut rt: Runtime<Fx> = Runtime::try_new(RuntimeConfig::default()).expect("valid");
    let mut holding = 0u32;
    let mut seq = 0u16;
    // Frames with gaps of 1, 5, 30 (safe state) and 200 ticks.
    for gap in [1u32, 5, 30, 200, 0] {
        for _ in 0..20 {
            seq += 1;
            rt.receive(&vel(seq, 3_000));
            let a = act(rt.tick(0));
            holding += u32::from(a.flags.has(Flags::HOLDING));
        }
        for _ in 0..gap {
            let a = act(rt.tick(0));
            assert!(
                a.flags.has(Flags::HOLDING),
                "every tick without a frame is held"
            );
            holding += 1;
        }
    }
    let c = rt.counters();
    assert!(c.safe_ticks > 0, "the safe state was entered");
    assert_eq!(c.held_ticks, holding);
    assert_eq!(holding, 1 + 5 + 30 + 200);
}

#[test]
fn yaw_sat_reports_the_safe_ramp_limiting_the_torque() {
    let mut rt: Runtime<Fx> = Runtime::try_new(RuntimeConfig::default()).expect("valid");
    // 10 mm/s: the lead asks ~1.06 kN m (within the 20 kN m limit: no saturation).
    for k in 1..=500 {
        rt.receive(&vel(k, 10_000));
        let a = act(rt.tick(0));
        assert!(!a.flags.has(Flags::YAW_SAT), "tick {k}");
    }
    let before = rt.counters().yaw_sat;
    // Frames stop: after the hold the safe ramp (20 kN m to 0 in 0.1 s, 40 N m per tick)
    // takes the limit below the held demand after ~470 ticks, then to 0.
    let (mut safe, mut first_sat, mut sat) = (0u32, None, 0u32);
    for _ in 0..600 {
        let a = act(rt.tick(0));
        if !a.flags.has(Flags::SAFE) {
            continue;
        }
        safe += 1;
        if a.flags.has(Flags::YAW_SAT) {
            first_sat.get_or_insert(safe);
            sat += 1;
        } else {
            assert!(
                first_sat.is_none(),
                "limited once, limited until 0: tick {safe}"
            );
            assert!(a.t_psi_dnm > 10_000, "not limited yet: {}", a.t_psi_dnm);
        }
    }
    let first = first_sat.expect("the ramp limited the torque");
    assert!(
        (400..=500).contains(&first),
        "first limited safe tick {first}"
    );
    assert_eq!(rt.counters().yaw_sat - before, sat);
}

/// Lead -> gain on a 2 Hz, 20 mm/s lateral velocity stepped the torque by
/// 467 N m in one tick. The new law starts from the old output; the step is bounded by
/// the torque slew (40 N m per 200 us tick) plus the signal's own change.
#[test]
fn a_law_change_while_running_is_bumpless() {
    let y =
        |k: u16| (20_000.0 * (2.0 * std::f64::consts::PI * 2.0 * f64::from(k) / 5e3).sin()) as i32;
    let run = |switch_at: u16, to: YawMode| {
        let mut rt: Runtime<Fx> = Runtime::try_new(RuntimeConfig::default()).expect("valid");
        let mut out = Vec::new();
        for k in 1..=4_000u16 {
            if k == switch_at {
                send(&mut rt, Message::Config(config(to, true)));
            }
            rt.receive(&vel(k, y(k)));
            out.push(act(rt.tick(0)).t_psi_dnm);
        }
        out
    };
    let lead = run(u16::MAX, YawMode::Lead);
    let gain = run(1, YawMode::Gain);
    let step = |v: &[i32]| v.windows(2).map(|w| (w[1] - w[0]).abs()).max().unwrap_or(0);
    let natural = step(&lead[100..]).max(step(&gain[100..]));
    // Where the two laws differ most (after the start).
    let at = (2_000..3_000)
        .max_by_key(|&k| (lead[k] - gain[k]).abs())
        .expect("range");
    let jump = (lead[at] - gain[at]).abs();
    assert!(
        jump > 4_000,
        "the laws differ by {jump} dN m: the test would not see a bump"
    );
    let switched = run(at as u16 + 1, YawMode::Gain);
    let worst = step(&switched[at - 5..at + 200]);
    assert!(
        worst <= 400 + natural,
        "step {worst} dN m > slew 400 + natural {natural} (the jump was {jump})"
    );
    // It catches up with the gain law and is then exactly it.
    assert_eq!(&switched[at + 400..], &gain[at + 400..]);
}

/// Every 0 V state drives zero current instead: the back-EMF of the latest speed.
#[test]
fn traction_off_and_disabled_drive_the_back_emf() {
    let back_emf_cv = 4.28 * 925.6 * 100.0;
    for (what, cfg) in [
        (
            "traction off",
            Config {
                traction: false,
                ..config(YawMode::Lead, true)
            },
        ),
        ("outputs disabled", config(YawMode::Lead, false)),
    ] {
        let mut rt: Runtime<Fx> = Runtime::try_new(RuntimeConfig::default()).expect("valid");
        for k in 1..=50 {
            rt.receive(&vel(k, 1_000));
            rt.tick(0);
        }
        send(&mut rt, Message::Config(cfg));
        for k in 51..=60 {
            rt.receive(&vel(k, 1_000));
            let a = act(rt.tick(0));
            assert!(
                (f64::from(a.u_a_cv) - back_emf_cv).abs() <= 2.0,
                "{what}: {}",
                a.u_a_cv
            );
        }
        // Back on: no voltage step (the PI restarts from the back-EMF).
        send(&mut rt, Message::Config(config(YawMode::Lead, true)));
        rt.receive(&vel(61, 1_000));
        let a = act(rt.tick(0));
        assert!(
            (f64::from(a.u_a_cv) / 100.0 - 3961.6).abs() < 120.0,
            "{what}: {}",
            a.u_a_cv
        );
    }
}

/// `Lateral::Both`: the complementary filter
/// `v[n] = v[n-1] + T y''[n] - (T/tau)(v[n-1] - y'[n])`: y'' carries the high
/// frequencies, y' the low ones (crossover `1/(2 pi tau)`, 0.08 Hz): on consistent
/// signals it is y' itself, and it rejects noise on y' that y'' does not have.
#[test]
fn both_is_a_complementary_filter() {
    let cfg = {
        let mut c = RuntimeConfig::default();
        c.control.yaw_mode = wheelset_control::YawMode::Gain;
        c.control.yaw_predict_ticks = 0.0;
        c
    };
    let k_gain = 1.05e5; // T_psi = K y'
    let w = 2.0 * std::f64::consts::PI * 2.0;
    let t = |k: u16| f64::from(k) / 5e3;
    let clean = |k: u16| 0.02 * (w * t(k)).sin(); // m/s
    let acc = |k: u16| 0.02 * w * (w * t(k)).cos(); // m/s^2
                                                    // Noise on y' only: +-2 mm/s, alternating.
    let noise = |k: u16| if k.is_multiple_of(2) { 2e-3 } else { -2e-3 };
    let rms = |lat: &dyn Fn(u16) -> Lateral| {
        let mut rt: Runtime<Fx> = Runtime::try_new(cfg).expect("valid");
        let mut e2 = 0.0;
        let mut n = 0.0;
        // 12 s: the seed's error (the first, noisy y') decays with tau = 2 s.
        for k in 1..=60_000u16 {
            rt.receive(&sensor(k, lat(k)));
            let a = act(rt.tick(0));
            if k > 50_000 {
                let est = f64::from(a.t_psi_dnm) * 0.1 / k_gain;
                e2 += (est - clean(k)).powi(2);
                n += 1.0;
            }
        }
        (e2 / n).sqrt()
    };
    let um = |x: f64| (x * 1e6).round() as i32;
    let dmm = |x: f64| (x * 1e4).round() as i32;
    let velocity = rms(&|k| Lateral::Velocity(um(clean(k) + noise(k))));
    let both = rms(&|k| Lateral::Both {
        vel_um_s: um(clean(k) + noise(k)),
        acc_dmm_s2: dmm(acc(k)),
    });
    let consistent = rms(&|k| Lateral::Both {
        vel_um_s: um(clean(k)),
        acc_dmm_s2: dmm(acc(k)),
    });
    println!("y' error RMS: velocity only {velocity:.2e} m/s, both {both:.2e}, consistent {consistent:.2e}");
    assert!(velocity > 1.9e-3, "{velocity}");
    assert!(both < velocity / 20.0, "both {both} vs velocity {velocity}");
    assert!(consistent < 2e-5, "{consistent}");
}

/// The firmware's log source: every rejected frame and refused request is an
/// [`RxEvent`]; the first since the last take is held with its kind, the later ones are
/// counted, and valid accepted frames add none.
#[test]
fn rejected_frames_and_refusals_are_events_for_the_log() {
    let mut rt: Runtime<Fx> = Runtime::try_new(RuntimeConfig::default()).expect("valid");
    rt.receive(&vel(1, 0));
    send(&mut rt, Message::Config(config(YawMode::Lead, true)));
    rt.tick(0);
    assert_eq!(rt.take_rx_event(), None, "nothing rejected or refused");
    // A CRC error, then a Config the device cannot honour (3 kHz: 333.3 us), then an
    // unknown Command: the first is held, the two after it counted.
    let mut bad = vel(2, 0);
    bad[3] ^= if bad[3] == 1 { 2 } else { 1 };
    rt.receive(&bad);
    let mut cfg = RuntimeConfig::default();
    cfg.control.base_rate_hz = 3_000;
    let rates = rates_for::<Fx>(&cfg).expect("the host computes them");
    send(
        &mut rt,
        Message::Config(Config {
            rates: Some(rates),
            ..config(YawMode::Lead, true)
        }),
    );
    rt.receive(&raw_frame(3, &[5]));
    rt.tick(0);
    assert_eq!(
        rt.take_rx_event(),
        Some((RxEvent::Rejected(FrameError::Crc), 2))
    );
    assert_eq!(rt.take_rx_event(), None, "taken");
    let c = *rt.counters();
    assert_eq!(
        (c.rx_crc, c.cmd_refused),
        (1, 2),
        "the counters count every one"
    );
    // A refusal alone is held with its reason.
    send(
        &mut rt,
        Message::Config(Config {
            rates: Some(rates),
            ..config(YawMode::Lead, true)
        }),
    );
    assert_eq!(
        rt.take_rx_event(),
        Some((RxEvent::Refused(RefuseReason::Period), 0))
    );
}

#[test]
fn the_runtime_counts_what_the_core_counted_and_flags_it_on_that_tick() {
    // The runtime's saturation and input counters follow the core's event word; here
    // checked against the core's own counters over ticks that clamp y' (out of range),
    // the current and the torque, and normal ticks between them.
    let mut rt: Runtime<Fx> = Runtime::try_new(RuntimeConfig::default()).expect("valid");
    let inputs = |k: &wheelset_control::Counters| {
        [k.y_dot, k.current, k.speed, k.demand]
            .iter()
            .map(|s| s.clamped + s.invalid)
            .sum::<u32>()
    };
    let (mut flagged_yaw, mut flagged_tr) = (0u32, 0u32);
    for k in 1..=400u16 {
        let y = match k % 50 {
            0..=4 => 5_000_000,    // 5 m/s: y' clamped, torque at its limit
            10..=12 => -3_000_000, // the other way
            _ => 2_000,
        };
        let mut s = sample(k, Lateral::Velocity(y));
        if k % 97 == 0 {
            s.i_a_ma = 5_000_000; // current clamped
            s.demand_nm = -1_000_000; // demand clamped
        }
        rt.receive(&sensor_frame(s));
        let a = act(rt.tick(0));
        flagged_yaw += u32::from(a.flags.has(Flags::YAW_SAT));
        flagged_tr += u32::from(a.flags.has(Flags::TRACTION_SAT));
        let (c, core) = (rt.counters(), rt.core().counters());
        assert_eq!(c.yaw_sat, core.yaw_torque.clamped, "tick {k}");
        assert_eq!(c.traction_sat, core.voltage.clamped, "tick {k}");
        assert_eq!(c.input_clamped, inputs(core), "tick {k}");
    }
    let c = rt.counters();
    assert!(c.yaw_sat > 0 && c.input_clamped > 0, "{c:?}");
    assert_eq!((flagged_yaw, flagged_tr), (c.yaw_sat, c.traction_sat));
}
