//! The fault policy, on the host: holds, safe state, recovery, bad frames, commands.

use proptest::prelude::*;
use wheelset_control::Fx;
use wheelset_proto::*;
use wheelset_runtime::*;

mod common;
use common::{act, frames, vel};

fn rt() -> Runtime<Fx> {
    Runtime::try_new(RuntimeConfig::default()).expect("default config is valid")
}

const BASE_HZ: u32 = wheelset_control::DEFAULT_BASE_RATE_HZ;

#[test]
fn no_sample_yet_drives_the_safe_outputs() {
    let mut r = rt();
    let a = act(r.tick(0));
    assert!(a.flags.has(Flags::NO_SAMPLE | Flags::ENABLED));
    let s = SAFE_ACTUATION;
    assert_eq!((a.t_psi_dnm, a.u_a_cv), (s.t_psi_dnm, s.u_a_cv));
    assert_eq!((s.t_psi_dnm, s.u_a_cv), (0, 0));
}

#[test]
fn fresh_samples_are_echoed_and_exec_reported() {
    let mut r = rt();
    for k in 1..=50u16 {
        r.receive(&vel(k, 500));
        let a = act(r.tick(u32::from(k) * 3));
        assert_eq!(a.seq_echo, k);
        assert_eq!(a.tick, k);
        assert_eq!(a.exec, u32::from(k) * 3);
        assert!(!a.flags.has(Flags::HOLDING) && !a.flags.has(Flags::SAFE));
        assert!(!a.flags.has(Flags::NO_SAMPLE));
    }
    let c = r.counters();
    assert_eq!(
        (c.rx_ok, c.held_ticks, c.seq_gaps, c.safe_entries),
        (50, 0, 0, 0)
    );
}

#[test]
fn the_first_sample_starts_traction_bumpless_from_the_back_emf() {
    let mut r = rt();
    let s = Sensor {
        seq: 7,
        lateral: Lateral::Velocity(1_000),
        omega_m_mrad_s: 925_600,
        ..Sensor::ZERO
    };
    r.receive(&encode_vec(&Message::Sensor(s)).expect("fits"));
    let a = act(r.tick(0));
    assert_eq!(a.seq_echo, 7);
    assert!(a.flags.has(Flags::ENABLED) && !a.flags.has(Flags::HOLDING));
    // No current, no demand: u_a = K_m omega = 4.28 x 925.6 = 3961.57 V (codes of 10 mV).
    assert!((a.u_a_cv - 396_157).abs() <= 1, "{}", a.u_a_cv);
}

#[test]
fn hold_then_safe_then_recover() {
    let hold = 4u16;
    let mut r: Runtime<Fx> = Runtime::try_new(RuntimeConfig {
        hold_ticks: hold,
        ..RuntimeConfig::default()
    })
    .expect("valid");
    // Run with a lateral velocity so that the yaw torque is clearly non-zero.
    let mut seq = 0u16;
    let mut last = None;
    for _ in 0..200 {
        seq += 1;
        r.receive(&vel(seq, 5_000));
        last = Some(act(r.tick(0)));
    }
    let last = last.expect("ran");
    assert!(last.t_psi_dnm > 1_000, "lead on 5 mm/s: {}", last.t_psi_dnm);
    let torque0 = last.t_psi_dnm;
    // Frames stop: `hold` ticks on the held sample.
    for k in 1..=hold {
        let a = act(r.tick(0));
        assert!(a.flags.has(Flags::HOLDING), "tick {k}");
        assert!(!a.flags.has(Flags::SAFE), "tick {k}");
        assert_eq!(a.seq_echo, seq);
    }
    // Then the safe state: torque ramps monotonically to zero within the 0.1 s ramp,
    // voltage at the back-EMF of the held speed (4.28 V s/rad x 925.6 rad/s).
    let ramp_ticks = (0.1 * f64::from(BASE_HZ)) as usize + 2;
    let mut prev = torque0.abs();
    let mut t_zero = None;
    for k in 0..ramp_ticks + 50 {
        let a = act(r.tick(0));
        assert!(a.flags.has(Flags::SAFE | Flags::HOLDING));
        assert!(
            a.t_psi_dnm.abs() <= prev,
            "tick {k}: {} after {prev}",
            a.t_psi_dnm
        );
        prev = a.t_psi_dnm.abs();
        if prev == 0 && t_zero.is_none() {
            t_zero = Some(k);
        }
        let back_emf_cv = 4.28 * 925.6 * 100.0;
        assert!(
            (f64::from(a.u_a_cv) - back_emf_cv).abs() <= 2.0,
            "u_a {}",
            a.u_a_cv
        );
    }
    assert!(
        t_zero.is_some_and(|k| k <= ramp_ticks),
        "torque zero at {t_zero:?}"
    );
    let c = *r.counters();
    // Every tick on the held sample is counted, in the safe state or not (as HOLDING).
    assert_eq!(
        (c.safe_entries, c.safe_exits, c.held_ticks as usize),
        (1, 0, usize::from(hold) + ramp_ticks + 50)
    );
    assert_eq!(c.safe_ticks as usize, ramp_ticks + 50);
    // Frames return: the safe state is left at once, the voltage restarts from the
    // back-EMF (bumpless) and the torque limit ramps back up.
    seq += 1;
    r.receive(&vel(seq, 5_000));
    let a = act(r.tick(0));
    assert!(!a.flags.has(Flags::SAFE) && !a.flags.has(Flags::HOLDING));
    assert_eq!(a.seq_echo, seq);
    // e = i_ref(first ramp step, 4 A at 20 kA/s and 5 kHz) - 115 A: Kp e ~ -111 V.
    assert!(
        (f64::from(a.u_a_cv) / 100.0 - 3961.6).abs() < 120.0,
        "u_a {}",
        a.u_a_cv
    );
    let mut torque = 0;
    for _ in 0..(0.2 * f64::from(BASE_HZ)) as usize {
        seq += 1;
        r.receive(&vel(seq, 5_000));
        torque = act(r.tick(0)).t_psi_dnm;
    }
    assert!(
        (torque - torque0).abs() <= torque0 / 50,
        "{torque} vs {torque0}"
    );
    let c = r.counters();
    assert_eq!((c.safe_entries, c.safe_exits), (1, 1));
}

#[test]
fn bad_frames_counted_by_kind_and_flagged_once() {
    let mut r = rt();
    r.receive(&vel(1, 0));
    let _ = r.tick(0);
    // A CRC error: flip a data bit (not into a zero).
    let mut f = vel(2, 0);
    f[5] ^= if f[5] == 0x01 { 0x02 } else { 0x01 };
    r.receive(&f);
    // A COBS error: a code byte pointing past the end.
    r.receive(&[0x30, 1, 2, 0]);
    // A length error: an over-long run.
    r.receive(&[0x11; 300]);
    r.receive(&[0]);
    // Garbage split over calls, then a valid frame in two chunks.
    let good = vel(3, 0);
    r.receive(&good[..4]);
    r.receive(&good[4..]);
    let a = act(r.tick(0));
    assert!(a.flags.has(Flags::RX_ERROR));
    assert_eq!(a.seq_echo, 3);
    let c = r.counters();
    assert_eq!((c.rx_crc, c.rx_cobs, c.rx_length, c.rx_ok), (1, 1, 1, 2));
    assert_eq!(c.seq_gaps, 1, "2 never arrived");
    r.receive(&vel(4, 0));
    assert!(!act(r.tick(0)).flags.has(Flags::RX_ERROR));
}

#[test]
fn config_and_commands() {
    let mut r = rt();
    for k in 1..=20 {
        r.receive(&vel(k, 5_000));
        let _ = r.tick(0);
    }
    let cfg = Config {
        mode: YawMode::Passive,
        traction: true,
        enable: true,
        hold_ticks: 3,
        rates: None,
        monitor_safe: false,
        wsp: false,
    };
    r.receive(&encode_vec(&Message::Config(cfg)).expect("fits"));
    r.receive(&vel(21, 5_000));
    let a = act(r.tick(0));
    assert_eq!(r.hold_ticks(), 3);
    // Passive: no device torque, reached bumpless at the torque slew (40 N m per tick).
    let mut prev = a.t_psi_dnm;
    assert!(prev > 0, "slewing from the lead's output");
    let mut seq = 21;
    while prev != 0 {
        seq += 1;
        assert!(seq < 100, "the torque does not reach 0: {prev}");
        r.receive(&vel(seq, 5_000));
        let t = act(r.tick(0)).t_psi_dnm;
        assert!(
            (prev - t).abs() <= 400 && t.abs() < prev.abs(),
            "{prev} -> {t}"
        );
        prev = t;
    }
    let base = r.counters().ticks;
    // Invalid rates are refused and the old configuration stays.
    let mut rates = rates_for::<Fx>(&RuntimeConfig::default()).expect("valid");
    rates.base_rate_hz = 0;
    let bad = Config {
        rates: Some(rates),
        hold_ticks: 7,
        ..cfg
    };
    r.receive(&encode_vec(&Message::Config(bad)).expect("fits"));
    seq += 1;
    r.receive(&vel(seq, 5_000));
    let a = act(r.tick(0));
    assert!(a.flags.has(Flags::CMD_REFUSED));
    assert_eq!(r.counters().cmd_refused, 1);
    assert_eq!(r.base_rate_hz(), BASE_HZ);
    assert_eq!(r.hold_ticks(), 3, "a refused Config applies nothing");
    assert_eq!(r.refuse_reason(), RefuseReason::BaseRate);
    // Disabled: zero torque and zero current: the back-EMF of the latest speed, not 0 V
    // (4.28 V s/rad x 925.6 rad/s).
    r.receive(
        &encode_vec(&Message::Config(Config {
            enable: false,
            ..cfg
        }))
        .expect("fits"),
    );
    seq += 1;
    r.receive(&vel(seq, 5_000));
    let a = act(r.tick(0));
    assert!(!a.flags.has(Flags::ENABLED));
    assert_eq!(a.t_psi_dnm, 0);
    assert!(
        (f64::from(a.u_a_cv) - 4.28 * 925.6 * 100.0).abs() <= 2.0,
        "{}",
        a.u_a_cv
    );
    // Status on request, after the actuation frame; reset zeroes the counters.
    r.receive(&encode_vec(&Message::Command(Command::RequestStatus)).expect("fits"));
    let out = frames(r.tick(0));
    assert_eq!(out.len(), 2);
    let Message::Status(st) = out[1] else {
        panic!("{out:?}")
    };
    assert_eq!(st.ticks, base + 3);
    assert_eq!(st.rx_ok, u32::from(seq) + 3 + 1);
    assert_eq!(st.cmd_refused, 1);
    r.receive(&encode_vec(&Message::Command(Command::ResetCounters)).expect("fits"));
    let _ = r.tick(0);
    assert_eq!(r.counters().ticks, 1);
    assert_eq!(r.counters().rx_ok, 0);
    // A frame the device does not take: counted there only (sent = rx_ok + rx_*).
    r.receive(&encode_vec(&Message::Status(Status::default())).expect("fits"));
    assert_eq!((r.counters().rx_unexpected, r.counters().rx_ok), (1, 0));
}

#[test]
fn f32_and_fixed_builds_agree() {
    let mut a: Runtime<Fx> = rt();
    let mut b: Runtime<f32> = Runtime::try_new(RuntimeConfig::default()).expect("valid");
    for k in 1..=500u16 {
        let y = (f64::from(k) * 0.05).sin() * 3_000.0;
        let f = vel(k, y as i32);
        a.receive(&f);
        b.receive(&f);
        let (x, z) = (act(a.tick(0)), act(b.tick(0)));
        // 0.1 N m and 10 mV codes: within a few LSB plus f32's 2^-24 relative.
        assert!((x.t_psi_dnm - z.t_psi_dnm).abs() <= 3, "{x:?} {z:?}");
        assert!((x.u_a_cv - z.u_a_cv).abs() <= 8, "{x:?} {z:?}");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(300))]

    /// Whatever arrives, every tick returns one valid actuation frame.
    #[test]
    fn arbitrary_input_never_panics(chunks in proptest::collection::vec(proptest::collection::vec(any::<u8>(), 0..80), 1..40)) {
        let mut r = rt();
        for (k, ch) in chunks.iter().enumerate() {
            r.receive(ch);
            if k % 3 == 0 {
                r.receive(&vel(k as u16, (k as i32 - 20) * 10_000));
            }
            let out = frames(r.tick(k as u32));
            prop_assert!(matches!(out.first(), Some(Message::Actuation(_))));
        }
    }
}

fn accel(seq: u16, a_dmm_s2: i32) -> Vec<u8> {
    encode_vec(&Message::Sensor(Sensor {
        seq,
        t_us: 0,
        lateral: Lateral::Acceleration(a_dmm_s2),
        i_a_ma: 0,
        omega_m_mrad_s: 925_600,
        demand_nm: 0,
        v_ref_mm_s: 0,
    }))
    .expect("fits")
    .to_vec()
}

#[test]
fn acceleration_frames_are_integrated_with_washout() {
    // Passive yaw output would hide y'; use pure gain: T_psi = K y', K = 1.05e5 N m s/m,
    // so the torque code (0.1 N m) is 1.05 x y' in um/s.
    let mut cfg = RuntimeConfig::default();
    cfg.control.yaw_mode = wheelset_control::YawMode::Gain;
    cfg.acc_washout_s = 0.0;
    // Without the y' predictor, which would add 1.5 ticks of the ramp's slope.
    cfg.control.yaw_predict_ticks = 0.0;
    let mut r: Runtime<Fx> = Runtime::try_new(cfg).expect("valid");
    // A constant y'' = 0.1 m/s^2 (1000 codes) for 0.1 s: y' = 10 mm/s at the end.
    let ticks = (0.1 * f64::from(BASE_HZ)) as u16;
    let mut last = 0;
    for k in 1..=ticks {
        r.receive(&accel(k, 1000));
        last = act(r.tick(0)).t_psi_dnm;
    }
    let expect = 1.05 * 10_000.0;
    assert!(
        (f64::from(last) - expect).abs() < 0.002 * expect,
        "{last} vs {expect}"
    );
    // A velocity frame re-seeds the estimate.
    r.receive(&vel(ticks + 1, 2_000));
    let t = act(r.tick(0)).t_psi_dnm;
    assert!((f64::from(t) - 1.05 * 2_000.0).abs() < 5.0, "{t}");
    assert_eq!(r.counters().rx_unexpected, 0);

    // With the wash-out, a constant y'' settles at a T tau instead of growing.
    let mut cfg = RuntimeConfig::default();
    cfg.control.yaw_mode = wheelset_control::YawMode::Gain;
    cfg.acc_washout_s = 0.05;
    let mut r: Runtime<Fx> = Runtime::try_new(cfg).expect("valid");
    for k in 1..=2_000u16 {
        r.receive(&accel(k, 1000));
        last = act(r.tick(0)).t_psi_dnm;
    }
    // a tau = 0.1 m/s^2 x 0.05 s = 5 mm/s.
    let settled = 1.05 * 5_000.0;
    assert!(
        (f64::from(last) - settled).abs() < 0.01 * settled,
        "{last} vs {settled}"
    );
    // Invalid wash-out is refused.
    let bad = RuntimeConfig {
        acc_washout_s: -1.0,
        ..RuntimeConfig::default()
    };
    assert!(matches!(
        Runtime::<Fx>::try_new(bad),
        Err(RuntimeError::Washout)
    ));
}

/// The `y''`-only estimate reaches the control core floored to whole um/s (crate docs,
/// fault policy item 1): `y''` = -1 code (-0.1 mm/s^2) integrates to -0.02 um/s per tick
/// at 5 kHz, so the core sees -1 um/s from the first tick (a rounding would give 0 for
/// 25 ticks, a truncation towards zero for 50): the outputs of a device sent `y'` = -1
/// um/s, tick for tick; +1 code stays at 0 (the outputs of `y'` = 0).
#[test]
fn the_integrated_velocity_reaches_the_core_floored_to_whole_um_s() {
    for (a, y) in [(-1, -1), (1, 0)] {
        let (mut acc, mut v) = (rt(), rt());
        // The same seed for both: `y'` = 0, then the integrator starts from 0.
        for k in 1..=10u16 {
            acc.receive(&vel(k, 0));
            v.receive(&vel(k, 0));
            assert_eq!(act(acc.tick(0)), act(v.tick(0)));
        }
        for k in 11..=30u16 {
            acc.receive(&accel(k, a));
            v.receive(&vel(k, y));
            let (p, q) = (act(acc.tick(0)), act(v.tick(0)));
            assert_eq!(p.t_psi_dnm, q.t_psi_dnm, "y'' {a}, tick {k}");
        }
    }
    // And the two cases differ: one um/s moves the lead's torque.
    let (mut a, mut b) = (rt(), rt());
    a.receive(&vel(1, 0));
    b.receive(&vel(1, -1));
    assert_ne!(act(a.tick(0)).t_psi_dnm, act(b.tick(0)).t_psi_dnm);
}

/// The Config of a rate change: the coefficients computed on the host for `cfg`.
fn rate_change<T: wheelset_control::SampleBits>(cfg: &RuntimeConfig) -> Config {
    Config {
        mode: YawMode::Lead,
        traction: true,
        enable: true,
        hold_ticks: 20,
        wsp: false,
        monitor_safe: false,
        rates: Some(rates_for::<T>(cfg).expect("valid")),
    }
}

fn designed(base_rate_hz: u32, delay_ticks: u8) -> RuntimeConfig {
    RuntimeConfig::default()
        .designed(base_rate_hz, delay_ticks)
        .expect("a design point")
}

#[test]
fn a_valid_rate_change_rebuilds_the_core() {
    let mut r = rt();
    r.receive(&vel(1, 1_000));
    let before = act(r.tick(0));
    let host = designed(10_000, 1);
    r.receive(&encode_vec(&Message::Config(rate_change::<Fx>(&host))).expect("fits"));
    r.receive(&vel(2, 1_000));
    let a = act(r.tick(0));
    assert!(!a.flags.has(Flags::CMD_REFUSED));
    assert_eq!((r.base_rate_hz(), r.hold_ticks()), (10_000, 20));
    assert_eq!(r.counters().cmd_refused, 0);
    // The device now runs exactly the host's compilation at the new rates.
    let reference = Runtime::<Fx>::try_new(host).expect("valid");
    let (mut got, want) = (*r.core().compiled(), *reference.core().compiled());
    assert_eq!(got.to_bits().schedule, want.to_bits().schedule);
    assert_eq!(got.pi().quantised().kp, want.pi().quantised().kp);
    // (The start mode is the only difference: the Config set it.)
    got = got.with_schedule(&want.schedule()).expect("valid");
    assert_eq!(got, want);
    // The rebuilt core starts bumpless on the traction side again (back-EMF).
    assert!(
        (a.u_a_cv - before.u_a_cv).abs() < 200,
        "{} vs {}",
        a.u_a_cv,
        before.u_a_cv
    );
    // Back at the default rates: the same outputs as a fresh runtime on the same frames.
    r.receive(
        &encode_vec(&Message::Config(rate_change::<Fx>(
            &RuntimeConfig::default(),
        )))
        .expect("fits"),
    );
    let mut fresh = rt();
    r.receive(
        &encode_vec(&Message::Config(Config {
            rates: None,
            hold_ticks: DEFAULT_HOLD_TICKS,
            ..rate_change::<Fx>(&RuntimeConfig::default())
        }))
        .expect("fits"),
    );
    // (The rebuilt core continues from the old core's torque and slews to its own
    // output at 40 N m per tick; the fresh one starts from 0: the same once caught up.)
    for k in 3..200u16 {
        let f = vel(k, 3_000);
        r.receive(&f);
        fresh.receive(&f);
        let (x, y) = (act(r.tick(0)), act(fresh.tick(0)));
        assert_eq!(x.u_a_cv, y.u_a_cv, "tick {k}");
        if k >= 100 {
            assert_eq!(x.t_psi_dnm, y.t_psi_dnm, "tick {k}");
        }
    }
}

#[test]
fn rates_for_another_controller_or_out_of_range_are_refused() {
    let good = rates_for::<Fx>(&designed(10_000, 1)).expect("valid");
    let mut other = designed(10_000, 1);
    other.control.limits.torque = 1.0e4;
    let foreign = rates_for::<Fx>(&other).expect("valid");
    assert_ne!(foreign.fingerprint, good.fingerprint);
    let f32_rates = rates_for::<f32>(&designed(10_000, 1)).expect("valid");
    let bad: [(&str, Rates); 9] = [
        ("another controller", foreign),
        ("another sample type", f32_rates),
        (
            "rate",
            Rates {
                base_rate_hz: 99,
                ..good
            },
        ),
        ("divisor", Rates { yaw_div: 0, ..good }),
        (
            "divisor",
            Rates {
                traction_div: 0,
                ..good
            },
        ),
        ("kappa <= 0", Rates { kappa: 0, ..good }),
        (
            "Ki < 0",
            Rates {
                ki: (-5i32) as u32,
                ..good
            },
        ),
        (
            "step above 2 pu",
            Rates {
                torque_step: (3 << 28) as u32,
                ..good
            },
        ),
        (
            "integrator gain",
            Rates {
                acc_gain_q32: (1 << 32) + 1,
                ..good
            },
        ),
    ];
    for (why, rates) in bad {
        let mut r = rt();
        r.receive(&vel(1, 1_000));
        let _ = r.tick(0);
        let c = Config {
            rates: Some(rates),
            ..rate_change::<Fx>(&RuntimeConfig::default())
        };
        r.receive(&encode_vec(&Message::Config(c)).expect("fits"));
        r.receive(&vel(2, 1_000));
        let a = act(r.tick(0));
        assert!(a.flags.has(Flags::CMD_REFUSED), "{why}");
        assert_eq!(r.counters().cmd_refused, 1, "{why}");
        assert_eq!(r.base_rate_hz(), BASE_HZ, "{why}: the old core stays");
        assert_eq!(r.hold_ticks(), DEFAULT_HOLD_TICKS, "{why}: nothing applied");
    }
    // The good one is taken, also by an f32 device when computed for f32.
    let mut r: Runtime<f32> = Runtime::try_new(RuntimeConfig::default()).expect("valid");
    let c = Config {
        rates: Some(f32_rates),
        ..rate_change::<f32>(&RuntimeConfig::default())
    };
    r.receive(&encode_vec(&Message::Config(c)).expect("fits"));
    r.receive(&vel(1, 1_000));
    assert!(!act(r.tick(0)).flags.has(Flags::CMD_REFUSED));
    assert_eq!(r.base_rate_hz(), 10_000);
    // The host reference type has no 32-bit wire form.
    assert!(rates_for::<f64>(&RuntimeConfig::default()).is_err());
}
