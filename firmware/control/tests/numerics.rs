//! Fixed point and f32 against the f64 reference on the same (quantised) inputs:
//! random, steps, chirps, full scale. Errors in output LSBs (Q4.28: 2^-28 pu) and in
//! physical units; bounds asserted. Extreme and invalid inputs. Determinism.

use proptest::prelude::*;
use wheelset_control::{
    Config, Controller, F32Controller, F64Controller, FixedController, Fx, InputCodes, Inputs,
    Sample, YawMode,
};

/// One Q4.28 LSB in pu.
const LSB: f64 = 1.0 / (1u64 << 28) as f64;

/// Yaw-torque bound, LSB of Q4.28 (3.7e-3 N m each): the lead's low-pass state
/// stops within `0.5 (1 + kappa)/kappa` LSB of rounding (10 at 5 kHz), times
/// `K_hf` = 0.79, plus the output rounding and coefficient quantisation.
const YAW_MAX_LSB: f64 = 16.0;
/// Voltage bound per traction step, LSB: the open-loop integrator sums one rounding
/// (0.5 LSB) and the `Ki` quantisation (<= 2^-32 x |e| <= 4 pu = 0.25 LSB) per step.
const PI_LSB_PER_STEP: f64 = 0.75;

#[derive(Clone, Copy, Debug)]
struct Err {
    yaw_max: f64,
    yaw_rms: f64,
    u_max: f64,
    u_rms: f64,
}

/// Run the fixed and the f64 controllers on the same inputs (the f64 one gets the
/// exactly quantised fixed inputs, so only arithmetic and coefficient quantisation
/// count). Returns errors in LSB.
fn compare(cfg: &Config, inputs: &[Inputs<f64>]) -> Err {
    let mut fx = FixedController::try_new(cfg).expect("valid");
    let mut fl = F64Controller::try_new(cfg).expect("valid");
    let (mut ym, mut ys, mut um, mut us) = (0.0f64, 0.0, 0.0f64, 0.0);
    for x in inputs {
        let q = Inputs::<Fx> {
            y_dot: Fx::from_f64(x.y_dot),
            current: Fx::from_f64(x.current),
            speed: Fx::from_f64(x.speed),
            demand: Fx::from_f64(x.demand),
        };
        let r = Inputs::<f64> {
            y_dot: q.y_dot.to_f64(),
            current: q.current.to_f64(),
            speed: q.speed.to_f64(),
            demand: q.demand.to_f64(),
        };
        let a = fx.tick(&q);
        let b = fl.tick(&r);
        let ey = (a.yaw_torque.to_f64() - b.yaw_torque) / LSB;
        let eu = (a.voltage.to_f64() - b.voltage) / LSB;
        ym = ym.max(ey.abs());
        um = um.max(eu.abs());
        ys += ey * ey;
        us += eu * eu;
    }
    let n = inputs.len().max(1) as f64;
    Err {
        yaw_max: ym,
        yaw_rms: (ys / n).sqrt(),
        u_max: um,
        u_rms: (us / n).sqrt(),
    }
}

fn check(cfg: &Config, inputs: &[Inputs<f64>]) -> Err {
    let e = compare(cfg, inputs);
    let n = inputs.len() as f64 / cfg.traction_divisor as f64;
    assert!(e.yaw_max <= YAW_MAX_LSB, "yaw {e:?}");
    assert!(
        e.u_max <= 4.0 + PI_LSB_PER_STEP * n,
        "voltage {e:?} over {n} steps"
    );
    e
}

fn chirp(n: usize, fs: f64, f0: f64, f1: f64, amp: f64) -> Vec<f64> {
    let t_end = n as f64 / fs;
    (0..n)
        .map(|k| {
            let t = k as f64 / fs;
            let ph = 2.0 * std::f64::consts::PI * (f0 * t + (f1 - f0) * t * t / (2.0 * t_end));
            amp * ph.sin()
        })
        .collect()
}

fn inputs_from(y: &[f64], i: &[f64], w: f64, d: f64) -> Vec<Inputs<f64>> {
    y.iter()
        .zip(i)
        .map(|(&y_dot, &current)| Inputs {
            y_dot,
            current,
            speed: w,
            demand: d,
        })
        .collect()
}

#[test]
fn fixed_matches_f64_on_steps_chirps_and_full_scale() {
    let cfg = Config::default();
    let fs = cfg.base_rate_hz as f64;
    let n = 5000;
    let mut report = Vec::new();
    // Steps: y' 1 mm/s .. full scale; current steps.
    for amp in [1e-3, 0.1, 1.0, -1.0] {
        let y = vec![amp; n];
        let i: Vec<f64> = (0..n)
            .map(|k| if k > n / 2 { 0.115 } else { 0.0 })
            .collect();
        report.push(("step", check(&cfg, &inputs_from(&y, &i, 0.9256, 0.246))));
    }
    // Chirps 0.1 Hz .. fs/2 on y' and the current.
    let y = chirp(n, fs, 0.1, fs / 2.0, 0.5);
    let i = chirp(n, fs, 0.1, fs / 2.0, 0.2);
    report.push(("chirp", check(&cfg, &inputs_from(&y, &i, 0.9256, 0.246))));
    // Full scale and beyond (clamped): alternating rails.
    let y: Vec<f64> = (0..n)
        .map(|k| if (k / 7) % 2 == 0 { 7.9 } else { -8.0 })
        .collect();
    let i: Vec<f64> = (0..n)
        .map(|k| if (k / 3) % 2 == 0 { 7.9 } else { -8.0 })
        .collect();
    report.push(("full scale", check(&cfg, &inputs_from(&y, &i, 7.9, -8.0))));
    for (name, e) in report {
        println!(
            "{name:>10}: T_psi max {:.2} LSB ({:.2e} N m) rms {:.2} LSB; u_a max {:.1} LSB \
             ({:.2e} V) rms {:.1} LSB",
            e.yaw_max,
            e.yaw_max * LSB * cfg.scales.torque,
            e.yaw_rms,
            e.u_max,
            e.u_max * LSB * cfg.scales.voltage,
            e.u_rms
        );
    }
}

#[test]
fn fixed_matches_f64_for_every_mode_and_rate() {
    for (base, yd, td) in [(2000, 1, 1), (5000, 1, 1), (10_000, 2, 1), (20_000, 4, 2)] {
        for mode in [YawMode::Passive, YawMode::Gain, YawMode::Lead] {
            let cfg = Config {
                base_rate_hz: base,
                yaw_divisor: yd,
                traction_divisor: td,
                yaw_mode: mode,
                ..Config::default()
            };
            let fs = base as f64;
            let y = chirp(4000, fs, 1.0, fs / 4.0, 0.3);
            let i = chirp(4000, fs, 1.0, fs / 4.0, 0.1);
            check(&cfg, &inputs_from(&y, &i, 0.9, 0.2));
        }
    }
}

fn arb_inputs() -> impl Strategy<Value = Vec<Inputs<f64>>> {
    let sample = (-8.0f64..8.0, -8.0f64..8.0, -8.0f64..8.0, -8.0f64..8.0);
    let small = (-0.01f64..0.01, -0.2f64..0.2, 0.8f64..1.0, -0.5f64..0.5);
    prop_oneof![
        prop::collection::vec(sample, 1..600),
        prop::collection::vec(small, 1..600),
    ]
    .prop_map(|v| {
        v.into_iter()
            .map(|(y_dot, current, speed, demand)| Inputs {
                y_dot,
                current,
                speed,
                demand,
            })
            .collect()
    })
}

proptest! {
    #![proptest_config(ProptestConfig {
        failure_persistence: None,
        ..ProptestConfig::with_cases(64)
    })]
    #[test]
    fn fixed_tracks_f64_on_random_sequences(inputs in arb_inputs(), hold in 1usize..50) {
        // Hold each random sample `hold` ticks: random steps of random length.
        let seq: Vec<Inputs<f64>> = inputs
            .iter()
            .flat_map(|x| std::iter::repeat_n(*x, hold))
            .take(20_000)
            .collect();
        let cfg = Config::default();
        let e = compare(&cfg, &seq);
        prop_assert!(e.yaw_max <= YAW_MAX_LSB, "{:?}", e);
        prop_assert!(e.u_max <= 4.0 + PI_LSB_PER_STEP * seq.len() as f64, "{:?}", e);
    }

    #[test]
    fn f32_tracks_f64(inputs in arb_inputs()) {
        let cfg = Config::default();
        let mut a = F32Controller::try_new(&cfg).expect("valid");
        let mut b = F64Controller::try_new(&cfg).expect("valid");
        for x in &inputs {
            let q = Inputs::<f32> {
                y_dot: x.y_dot as f32,
                current: x.current as f32,
                speed: x.speed as f32,
                demand: x.demand as f32,
            };
            let r = Inputs::<f64> {
                y_dot: q.y_dot as f64,
                current: q.current as f64,
                speed: q.speed as f64,
                demand: q.demand as f64,
            };
            let (oa, ob) = (a.tick(&q), b.tick(&r));
            // f32: 2^-24 relative per operation on values <= 2 pu: 1e-6 pu is 8 ulp.
            prop_assert!((oa.yaw_torque as f64 - ob.yaw_torque).abs() < 1e-6);
            prop_assert!((oa.voltage as f64 - ob.voltage).abs() < 1e-5);
        }
    }

    #[test]
    fn wire_codes_never_panic_and_are_deterministic(
        codes in prop::collection::vec(any::<(i32, i32, i32, i32)>(), 1..300)
    ) {
        let cfg = Config::default();
        let mut a = FixedController::try_new(&cfg).expect("valid");
        let mut b = a.clone();
        for (y_dot, current, speed, demand) in codes {
            let c = InputCodes { y_dot, current, speed, demand };
            let (oa, ob) = (a.tick_codes(&c), b.tick_codes(&c));
            prop_assert_eq!(oa, ob);
            prop_assert!(oa.yaw_torque.unsigned_abs() <= 200_000); // 2e4 N m / 0.1
            prop_assert!((-600_000..=600_000).contains(&oa.voltage));
        }
        prop_assert_eq!(a.counters(), b.counters());
    }
}

/// The same input sequence gives bit-identical fixed outputs, states and counters,
/// run after run (what later proves host == target with golden vectors).
#[test]
fn fixed_point_is_deterministic() {
    let cfg = Config::default();
    let fs = cfg.base_rate_hz as f64;
    let y = chirp(20_000, fs, 0.1, 500.0, 0.7);
    let i = chirp(20_000, fs, 3.0, 900.0, 0.4);
    let seq = inputs_from(&y, &i, 0.92, 0.3);
    let run = || {
        let mut c = FixedController::try_new(&cfg).expect("valid");
        let mut bits = Vec::with_capacity(seq.len());
        for x in &seq {
            let o = c.tick(&Inputs {
                y_dot: Fx::from_f64(x.y_dot),
                current: Fx::from_f64(x.current),
                speed: Fx::from_f64(x.speed),
                demand: Fx::from_f64(x.demand),
            });
            bits.push((o.yaw_torque.to_bits(), o.voltage.to_bits()));
        }
        (bits, *c.counters(), *c.lead_state(), *c.pi_state())
    };
    let a = run();
    let b = run();
    assert!(a == b);
    // Not trivially constant.
    assert!(a.0.iter().any(|o| o.0 != a.0[0].0) && a.0.iter().any(|o| o.1 != a.0[0].1));
}

fn extreme<T: Sample>(vals: &[T]) -> (Controller<T>, Vec<(f64, f64)>) {
    let cfg = Config::default();
    let mut c = Controller::<T>::try_new(&cfg).expect("valid");
    let mut outs = Vec::new();
    for &a in vals {
        for &b in vals {
            let o = c.tick(&Inputs {
                y_dot: a,
                current: b,
                speed: a,
                demand: b,
            });
            outs.push((o.yaw_torque.to_f64(), o.voltage.to_f64()));
        }
    }
    (c, outs)
}

#[test]
fn nan_and_inf_never_reach_the_outputs() {
    let cfg = Config::default();
    let lim_t = cfg.limits.torque / cfg.scales.torque;
    let lim_u = cfg.limits.voltage_max / cfg.scales.voltage;
    let v64 = [
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        f64::MAX,
        -f64::MAX,
        0.0,
        1e-300,
    ];
    let (c, outs) = extreme::<f64>(&v64);
    assert!(outs
        .iter()
        .all(|(t, u)| t.abs() <= lim_t + 1e-12 && u.abs() <= lim_u + 1e-12));
    let k = c.counters();
    assert!(k.y_dot.invalid > 0 && k.current.invalid > 0 && k.speed.invalid > 0);
    assert!(k.y_dot.clamped > 0 && k.current.clamped > 0 && k.demand.clamped > 0);
    let v32 = [
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        f32::MAX,
        f32::MIN,
        0.0,
    ];
    let (c, outs) = extreme::<f32>(&v32);
    assert!(outs.iter().all(|(t, u)| t.is_finite() && u.is_finite()));
    assert!(outs
        .iter()
        .all(|(t, u)| t.abs() <= lim_t + 1e-6 && u.abs() <= lim_u + 1e-6));
    assert!(c.counters().y_dot.invalid > 0);
    // Fixed point: the rails.
    let vfx = [
        Fx::MIN,
        Fx::MAX,
        Fx::ZERO,
        Fx::from_bits(-1),
        Fx::from_bits(1),
    ];
    let (c, outs) = extreme::<Fx>(&vfx);
    assert!(outs
        .iter()
        .all(|(t, u)| t.abs() <= lim_t + LSB && u.abs() <= lim_u + LSB));
    assert!(c.counters().y_dot.clamped > 0 && c.counters().current.clamped > 0);
    assert_eq!(c.counters().y_dot.invalid, 0);
}

/// At full scale (inputs at their clamps) no internal saturation engages: the fixed
/// outputs equal the f64 ones within the stated bound (a silent internal saturation
/// would be off by orders of magnitude).
#[test]
fn no_internal_saturation_at_full_scale() {
    let mut cfg = Config::default();
    cfg.limits.torque = 2.0e6; // 2 pu: let the lead's full output through
    let n = 2000;
    let y: Vec<f64> = (0..n)
        .map(|k| if (k / 50) % 2 == 0 { 1.0 } else { -1.0 })
        .collect();
    let i: Vec<f64> = (0..n)
        .map(|k| if (k / 50) % 2 == 0 { 2.0 } else { -2.0 })
        .collect();
    let e = check(&cfg, &inputs_from(&y, &i, 2.0, 2.0));
    assert!(e.yaw_max <= YAW_MAX_LSB);
}

#[test]
fn wire_codes_round_trip_and_fixed_codec_matches_float() {
    let cfg = Config::default();
    let fx = FixedController::try_new(&cfg).expect("valid");
    let fl = F64Controller::try_new(&cfg).expect("valid");
    for code in [
        0,
        1,
        -1,
        1000,
        -123_456,
        925_600,
        1_000_000,
        i32::MAX,
        i32::MIN,
    ] {
        let c = InputCodes {
            y_dot: code,
            current: code,
            speed: code,
            demand: code,
        };
        let a = fx.compiled().codec().decode(&c);
        let b = fl.compiled().codec().decode(&c);
        for (x, y) in [
            (a.y_dot, b.y_dot),
            (a.current, b.current),
            (a.speed, b.speed),
            (a.demand, b.demand),
        ] {
            let yq = y.clamp(-8.0, 8.0 - LSB);
            assert!(
                (x.to_f64() - yq).abs() <= LSB * (1.0 + 1e-6 * (yq / LSB).abs()),
                "{code}"
            );
        }
    }
    // Outputs: codes of the pu value, rounded.
    for t in [0.0, 0.01, -0.02, 1.5e-7, 1.99, -8.0] {
        let o = wheelset_control::Outputs {
            yaw_torque: Fx::from_f64(t),
            voltage: Fx::from_f64(t),
        };
        let c = fx.compiled().codec().encode(&o);
        let want_t = (o.yaw_torque.to_f64() * cfg.scales.torque / cfg.wire.torque).round();
        let want_u = (o.voltage.to_f64() * cfg.scales.voltage / cfg.wire.voltage).round();
        assert!((c.yaw_torque as f64 - want_t).abs() <= 1.0, "{t}: {c:?}");
        assert!((c.voltage as f64 - want_u).abs() <= 1.0, "{t}: {c:?}");
    }
}
