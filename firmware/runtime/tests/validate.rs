//! The device applies only what it can honour (issue 20): every implausible Config is
//! refused (counted, flagged, the reason reported, the old configuration kept), for both
//! sample types, and every plausible one is applied.

use wheelset_control::{Fx, SampleBits};
use wheelset_proto::*;
use wheelset_runtime::*;

mod common;
use common::{frames, vel};

fn sensor(seq: u16) -> Vec<u8> {
    vel(seq, 2_000)
}

fn at_rates(base_rate_hz: u32, yaw_div: u16, traction_div: u16) -> RuntimeConfig {
    let mut c = RuntimeConfig::default();
    c.control.base_rate_hz = base_rate_hz;
    c.control.yaw_divisor = yaw_div;
    c.control.traction_divisor = traction_div;
    // The rate table's matched compensation: 1 + yaw_div/2 ticks.
    c.control.yaw_predict_ticks = 1.0 + f64::from(yaw_div) / 2.0;
    c
}

/// A Config with the default mode and switches and these rates.
fn config(hold_ticks: u16, rates: Option<Rates>) -> Config {
    Config {
        mode: YawMode::Lead,
        traction: true,
        enable: true,
        hold_ticks,
        rates,
        monitor_safe: false,
        wsp: false,
    }
}

/// `bits` (a coefficient or signal of sample type `numeric`) times `k`.
fn scaled(numeric: u8, bits: u32, k: f64) -> u32 {
    match numeric {
        0 => (f64::from(bits as i32) * k).round() as i32 as u32,
        _ => ((f64::from(f32::from_bits(bits)) * k) as f32).to_bits(),
    }
}

/// Sends `cfg` to a runtime at the default rates that has run a few ticks; returns the
/// runtime, the flags of the next tick and the Status after it.
fn send<T: SampleBits>(cfg: &Config) -> (Runtime<T>, Flags, Status) {
    let mut rt = Runtime::<T>::try_new(RuntimeConfig::default()).expect("default");
    for k in 1..=5 {
        rt.receive(&sensor(k));
        rt.tick(0);
    }
    rt.receive(&encode_vec(&Message::Config(*cfg)).expect("fits"));
    rt.receive(&sensor(6));
    rt.receive(&encode_vec(&Message::Command(Command::RequestStatus)).expect("fits"));
    let out = frames(rt.tick(0));
    let (Some(Message::Actuation(a)), Some(Message::Status(s))) = (out.first(), out.get(1)) else {
        panic!("{out:?}")
    };
    (rt, a.flags, *s)
}

fn refused<T: SampleBits>(what: &str, cfg: &Config, why: RefuseReason) {
    let (rt, flags, status) = send::<T>(cfg);
    let name = core::any::type_name::<T>();
    assert!(flags.has(Flags::CMD_REFUSED), "{name} {what}: not flagged");
    assert_eq!(status.cmd_refused, 1, "{name} {what}: not counted");
    assert_eq!(rt.refuse_reason(), why, "{name} {what}: the field");
    // The old configuration stays.
    assert_eq!(rt.base_rate_hz(), 5_000, "{name} {what}");
    assert_eq!(rt.hold_ticks(), DEFAULT_HOLD_TICKS, "{name} {what}");
    let fresh = Runtime::<T>::try_new(RuntimeConfig::default()).expect("default");
    assert_eq!(
        rt.core().compiled(),
        fresh.core().compiled(),
        "{name} {what}"
    );
}

fn accepted<T: SampleBits>(what: &str, cfg: &Config) -> Runtime<T> {
    let (rt, flags, status) = send::<T>(cfg);
    let name = core::any::type_name::<T>();
    assert!(
        !flags.has(Flags::CMD_REFUSED),
        "{name} {what}: refused ({:?})",
        rt.refuse_reason()
    );
    assert_eq!(status.cmd_refused, 0, "{name} {what}");
    rt
}

fn every_case<T: SampleBits>() {
    let n = T::NUMERIC;
    let good = rates_for::<T>(&RuntimeConfig::default()).expect("valid");
    let with = |r: Rates| config(DEFAULT_HOLD_TICKS, Some(r));
    use RefuseReason as R;
    // Accepted today, and must be refused (issue 20).
    let r3k = rates_for::<T>(&at_rates(3_000, 1, 1)).expect("the host computes it");
    let r7k = rates_for::<T>(&at_rates(7_000, 1, 1)).expect("the host computes it");
    let cases: Vec<(&str, Config, RefuseReason)> = vec![
        ("3 kHz: 333.3 us", with(r3k), R::Period),
        ("7 kHz: 142.9 us", with(r7k), R::Period),
        (
            "hold_ticks 65535 (13 s)",
            config(u16::MAX, None),
            R::HoldTicks,
        ),
        (
            "hold_ticks 65535 with rates",
            config(u16::MAX, Some(good)),
            R::HoldTicks,
        ),
        ("kappa 1 LSB", with(Rates { kappa: 1, ..good }), R::Kappa),
        (
            "kappa 4x",
            with(Rates {
                kappa: scaled(n, good.kappa, 4.0),
                ..good
            }),
            R::Kappa,
        ),
        ("ki 1 LSB", with(Rates { ki: 1, ..good }), R::Ki),
        (
            "ki 100x",
            with(Rates {
                ki: scaled(n, good.ki, 100.0),
                ..good
            }),
            R::Ki,
        ),
        (
            "iref_step 1 LSB",
            with(Rates {
                iref_step: 1,
                ..good
            }),
            R::IrefStep,
        ),
        (
            "acc_gain_q32 2x",
            with(Rates {
                acc_gain_q32: 2 * good.acc_gain_q32,
                ..good
            }),
            R::AccGain,
        ),
        // Refused today, and must stay so.
        ("kappa 0", with(Rates { kappa: 0, ..good }), R::Kappa),
        (
            "zero safe ramp (traction)",
            with(Rates {
                iref_safe_step: 0,
                ..good
            }),
            R::IrefSafeStep,
        ),
        (
            "zero safe ramp (yaw)",
            with(Rates {
                torque_step: 0,
                ..good
            }),
            R::TorqueStep,
        ),
        (
            "predict_half 10x",
            with(Rates {
                predict_half: scaled(n, good.predict_half, 10.0),
                ..good
            }),
            R::PredictHalf,
        ),
        // And the other fields.
        (
            "another sample type",
            with(Rates {
                numeric: 1 - n,
                ..good
            }),
            R::Numeric,
        ),
        (
            "another core",
            with(Rates {
                fingerprint: !good.fingerprint,
                ..good
            }),
            R::Fingerprint,
        ),
        (
            "base rate 400 Hz",
            with(Rates {
                base_rate_hz: 400,
                ..good
            }),
            R::BaseRate,
        ),
        (
            "base rate 25 kHz",
            with(Rates {
                base_rate_hz: 25_000,
                ..good
            }),
            R::BaseRate,
        ),
        (
            "yaw loop at 250 Hz",
            with(Rates {
                yaw_div: 20,
                ..good
            }),
            R::YawDiv,
        ),
        (
            "traction divisor 0",
            with(Rates {
                traction_div: 0,
                ..good
            }),
            R::TractionDiv,
        ),
        (
            "acc_leak 2x",
            with(Rates {
                acc_leak_q32: 2 * good.acc_leak_q32,
                ..good
            }),
            R::AccLeak,
        ),
        (
            "iref_step 1.01x",
            with(Rates {
                iref_step: scaled(n, good.iref_step, 1.01),
                ..good
            }),
            R::IrefStep,
        ),
    ];
    for (what, cfg, why) in &cases {
        refused::<T>(what, cfg, *why);
    }
    // Rates computed for another rate but sent for this one: the coefficients are not
    // what the core yields at the requested rate.
    let r10k = rates_for::<T>(&at_rates(10_000, 1, 1)).expect("valid");
    refused::<T>(
        "10 kHz coefficients at 5 kHz",
        &with(Rates {
            base_rate_hz: 5_000,
            ..r10k
        }),
        R::Kappa,
    );
    // Plausible ones are applied, bit for bit what the host computed.
    for (hz, yd, td) in [
        (1_000, 1, 1),
        (2_000, 1, 1),
        (4_000, 1, 1),
        (5_000, 1, 1),
        (8_000, 2, 1),
        (10_000, 2, 1),
        (10_000, 4, 2),
        (20_000, 1, 1),
        (20_000, 10, 4),
    ] {
        let cfg = at_rates(hz, yd, td);
        let r = rates_for::<T>(&cfg).expect("valid");
        let hold = u16::try_from(hz / 50).expect("fits"); // 20 ms: the longest plausible
        let rt = accepted::<T>(&format!("{hz} Hz / {yd} / {td}"), &config(hold, Some(r)));
        assert_eq!((rt.base_rate_hz(), rt.hold_ticks()), (hz, hold));
        let host = Runtime::<T>::try_new(cfg).expect("valid");
        assert_eq!(rt.core().compiled(), host.core().compiled(), "{hz} Hz");
    }
    // Predictor off is plausible.
    let off = {
        let mut c = at_rates(5_000, 1, 1);
        c.control.yaw_predict_ticks = 0.0;
        rates_for::<T>(&c).expect("valid")
    };
    accepted::<T>("predictor off", &with(off));
}

#[test]
fn implausible_configs_are_refused_naming_the_field_fixed_point() {
    every_case::<Fx>();
}

#[test]
fn implausible_configs_are_refused_naming_the_field_f32() {
    every_case::<f32>();
    let good = rates_for::<f32>(&RuntimeConfig::default()).expect("valid");
    let with = |r: Rates| config(DEFAULT_HOLD_TICKS, Some(r));
    let sub = (f32::MIN_POSITIVE / 4.0).to_bits();
    for (what, r, why) in [
        ("ki subnormal", Rates { ki: sub, ..good }, RefuseReason::Ki),
        (
            "kappa subnormal",
            Rates { kappa: sub, ..good },
            RefuseReason::Kappa,
        ),
        (
            "torque_step subnormal",
            Rates {
                torque_step: sub,
                ..good
            },
            RefuseReason::TorqueStep,
        ),
        (
            "predict_half subnormal",
            Rates {
                predict_half: sub,
                ..good
            },
            RefuseReason::PredictHalf,
        ),
        (
            "kappa NaN",
            Rates {
                kappa: f32::NAN.to_bits(),
                ..good
            },
            RefuseReason::Kappa,
        ),
        (
            "ki -Ki",
            Rates {
                ki: (-f32::from_bits(good.ki)).to_bits(),
                ..good
            },
            RefuseReason::Ki,
        ),
        (
            "iref_step inf",
            Rates {
                iref_step: f32::INFINITY.to_bits(),
                ..good
            },
            RefuseReason::IrefStep,
        ),
    ] {
        refused::<f32>(what, &with(r), why);
    }
}

/// The largest deviation the quantisation itself makes is far inside the tolerance: a
/// coefficient off by a hair more than the tolerance is refused, one within it accepted.
#[test]
fn the_tolerance_is_two_to_the_minus_ten() {
    let good = rates_for::<f32>(&RuntimeConfig::default()).expect("valid");
    let with = |r: Rates| config(DEFAULT_HOLD_TICKS, Some(r));
    let tol = wheelset_proto::plausible::RATE_TOLERANCE;
    let ki = |k: f64| Rates {
        ki: scaled(1, good.ki, k),
        ..good
    };
    accepted::<f32>("ki within", &with(ki(1.0 + 0.9 * tol)));
    accepted::<f32>("ki within, low", &with(ki(1.0 - 0.9 * tol)));
    refused::<f32>("ki beyond", &with(ki(1.0 + 1.1 * tol)), RefuseReason::Ki);
    refused::<f32>(
        "ki beyond, low",
        &with(ki(1.0 - 1.1 * tol)),
        RefuseReason::Ki,
    );
}
