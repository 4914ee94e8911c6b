//! The controller: multi-rate tick, modes, safe state, bumpless start, anti-windup,
//! extreme inputs, determinism, configuration errors, wire codes.

use wheelset_control::{
    Config, ConfigError, Counters, F32Controller, F64Controller, FixedController, Inputs, Pi,
    PiState, Sample, YawMode,
};

fn si<T: Sample>(c: &Config, y_dot: f64, i: f64, w: f64, d: f64) -> Inputs<T> {
    Inputs::from_si(&c.scales, y_dot, i, w, d)
}

#[test]
fn default_config_is_valid_and_builds_for_every_type() {
    let c = Config::default();
    c.validate().expect("default valid");
    FixedController::try_new(&c).expect("fixed");
    F32Controller::try_new(&c).expect("f32");
    F64Controller::try_new(&c).expect("f64");
}

#[test]
fn bad_configs_give_typed_errors_naming_the_field() {
    let base = Config::default();
    let cases: Vec<(Config, &str)> = vec![
        (
            Config {
                yaw_divisor: 0,
                ..base
            },
            "yaw_divisor",
        ),
        (
            Config {
                traction_divisor: 0,
                ..base
            },
            "traction_divisor",
        ),
        (
            Config {
                base_rate_hz: 0,
                ..base
            },
            "base_rate_hz",
        ),
        (
            Config {
                base_rate_hz: 120,
                ..base
            },
            "yaw rate",
        ),
        (
            Config {
                gain_k: f64::NAN,
                ..base
            },
            "gain_k",
        ),
        (
            Config {
                limits: wheelset_control::Limits {
                    y_dot: 5.0,
                    ..base.limits
                },
                ..base
            },
            "limits.y_dot",
        ),
        (
            Config {
                wire: wheelset_control::WireLsb {
                    torque: 0.0,
                    ..base.wire
                },
                ..base
            },
            "wire.torque",
        ),
    ];
    for (cfg, field) in cases {
        let e = F64Controller::try_new(&cfg).expect_err(field);
        let msg = format!("{e}");
        assert!(msg.contains(field), "{field}: {msg}");
    }
    // A coefficient that does not fit Q1.31 is refused for fixed point only.
    let big = Config {
        gain_k: 3.0e6,
        ..base
    };
    assert!(matches!(
        FixedController::try_new(&big),
        Err(ConfigError::Coefficient { .. })
    ));
    assert!(F64Controller::try_new(&big).is_ok());
}

#[test]
fn multi_rate_divisors_schedule_the_loops() {
    let cfg = Config {
        base_rate_hz: 10_000,
        yaw_divisor: 4,
        traction_divisor: 2,
        ..Config::default()
    };
    let mut c = F64Controller::try_new(&cfg).expect("valid");
    let inp = si::<f64>(&cfg, 0.01, 0.0, 925.6, 0.0);
    let mut prev = c.tick(&inp).yaw_torque;
    for n in 1..100u32 {
        let o = c.tick(&inp);
        // The yaw output only changes on ticks 0, 4, 8, ...
        if n % 4 != 0 {
            assert_eq!(o.yaw_torque, prev, "tick {n}");
        }
        prev = o.yaw_torque;
    }
    let k = c.counters();
    assert_eq!(k.ticks, 100);
    assert_eq!(k.yaw_steps, 25);
    assert_eq!(k.traction_steps, 50);
}

#[test]
fn modes_and_sign_convention() {
    let cfg = Config {
        yaw_predict_ticks: 0.0,
        ..Config::default()
    };
    let inp = si::<f64>(&cfg, 1e-3, 0.0, 0.0, 0.0); // 1 mm/s to the right
    let mut c = F64Controller::try_new(&Config {
        yaw_mode: YawMode::Gain,
        ..cfg
    })
    .expect("ok");
    let (t, _) = c.tick(&inp).to_si(&cfg.scales);
    assert!((t - 1.05e5 * 1e-3).abs() < 1e-9, "T_psi = +K y': {t}");
    // A law change slews from the old output at the torque slew (the safe ramp's rate,
    // 2e4 N m / 0.1 s = 40 N m per 200 us tick) until it has caught up.
    let slew = cfg.limits.torque / cfg.safe.yaw_s / f64::from(cfg.base_rate_hz);
    let settle = |c: &mut F64Controller, from: f64, to: f64| {
        let mut last = from;
        for k in 1..=10 {
            let (t, _) = c.tick(&inp).to_si(&cfg.scales);
            assert!(
                (t - last).abs() <= slew * (1.0 + 1e-9),
                "tick {k}: {last} -> {t}"
            );
            last = t;
            if (t - to).abs() < 1e-9 * to.abs().max(1.0) {
                return k;
            }
        }
        panic!("{from} -> {to}: not there after 10 ticks ({last})");
    };
    c.set_mode(YawMode::Passive);
    assert_eq!(settle(&mut c, t, 0.0), 3, "105 N m at 40 N m per tick");
    // Bumpless into the lead: it starts from its steady state (DC gain times y') and the
    // torque slews there from 0.
    c.set_mode(YawMode::Lead);
    let dc = 1.05e5 * 7.5 * 37.0 / 274.0 * 1e-3;
    assert_eq!(settle(&mut c, 0.0, dc), 3, "bumpless lead start at {dc}");
    // A fresh lead on a step starts near its high-frequency gain.
    let mut c = F64Controller::try_new(&cfg).expect("ok");
    let (t, _) = c.tick(&inp).to_si(&cfg.scales);
    assert!(t > 0.9 * 7.875e5 * 1e-3 && t < 7.875e5 * 1e-3, "{t}");
}

#[test]
fn bumpless_start_presets_the_back_emf() {
    let cfg = Config::default();
    let w = 5.0 * 83.3 / 0.45; // 925.6 rad/s
    let mut c = F64Controller::try_new(&cfg).expect("ok");
    let (_, u) = c.tick(&si(&cfg, 0.0, 0.0, w, 0.0)).to_si(&cfg.scales);
    assert!((u - 4.28 * w).abs() < 1e-9, "u = K_m w = {}: {u}", 4.28 * w);
    assert!((u - 3961.5).abs() < 1.0);
    // Traction off: zero current, so the back-EMF (not 0 V, a short circuit at speed);
    // on again: presets again.
    c.set_traction(false);
    let (_, u) = c.tick(&si(&cfg, 0.0, 0.0, w, 0.0)).to_si(&cfg.scales);
    assert!((u - 4.28 * w).abs() < 1e-9, "traction off: {u}");
    c.set_traction(true);
    let (_, u) = c.tick(&si(&cfg, 0.0, 0.0, w, 0.0)).to_si(&cfg.scales);
    assert!((u - 4.28 * w).abs() < 1e-9);
}

/// The reference ramps at `limits.current_ref_rate` to `demand/(n K_m)` = 115 A.
#[test]
fn current_reference_ramps() {
    let cfg = Config::default();
    let fs = cfg.base_rate_hz as f64;
    let mut c = F64Controller::try_new(&cfg).expect("ok");
    let demand = 2460.0;
    let target = demand / (5.0 * 4.28);
    let inp = si::<f64>(&cfg, 0.0, 0.0, 0.0, demand);
    let mut n = 0;
    while c.current_ref() * cfg.scales.current < target - 1e-9 && n < 100_000 {
        c.tick(&inp);
        n += 1;
        let r = c.current_ref() * cfg.scales.current;
        assert!(r <= cfg.limits.current_ref_rate * n as f64 / fs + 1e-9);
    }
    let t = n as f64 / fs;
    let want = target / cfg.limits.current_ref_rate;
    assert!(
        (t - want).abs() <= 1.0 / fs + 1e-12,
        "ramp took {t} s, want {want}"
    );
}

#[test]
fn safe_state_ramps_torque_and_reference_to_zero() {
    let cfg = Config::default();
    let fs = cfg.base_rate_hz as f64;
    for mode in [YawMode::Gain, YawMode::Lead] {
        let mut c = F64Controller::try_new(&Config {
            yaw_mode: mode,
            ..cfg
        })
        .expect("ok");
        let inp = si::<f64>(&cfg, 0.5, 0.0, 900.0, 2460.0); // saturates the torque
        for _ in 0..(0.1 * fs) as usize {
            c.tick(&inp);
        }
        let (t0, _) = c.outputs().to_si(&cfg.scales);
        assert!((t0 - cfg.limits.torque).abs() < 1e-6, "{t0}");
        assert!(c.current_ref() > 0.1);
        c.set_safe(true);
        let mut prev = t0;
        for n in 1..=(cfg.safe.traction_s * fs) as usize {
            let (t, _) = c.tick(&inp).to_si(&cfg.scales);
            assert!(t <= prev + 1e-9, "monotone ramp");
            let bound = cfg.limits.torque * (1.0 - n as f64 / (cfg.safe.yaw_s * fs)).max(0.0);
            assert!(t.abs() <= bound + 1e-6, "n={n}: {t} > {bound}");
            prev = t;
        }
        assert_eq!(c.outputs().yaw_torque, 0.0);
        assert!(c.current_ref().abs() < 1e-12);
        // Leaving the safe state ramps back up over the same time, not at once.
        c.set_safe(false);
        for n in 1..=(cfg.safe.yaw_s * fs) as usize + 1 {
            let (t, _) = c.tick(&inp).to_si(&cfg.scales);
            let bound = cfg.limits.torque * (n as f64 / (cfg.safe.yaw_s * fs)).min(1.0);
            assert!(t.abs() <= bound + 1e-6, "n={n}: {t} > {bound}");
        }
        let (t, _) = c.outputs().to_si(&cfg.scales);
        assert!((t - cfg.limits.torque).abs() < 1e-6);
    }
}

/// Anti-windup: the armature `L_a i' = u - R_a i - E` (exact ZOH, one period of
/// delay as on the target) under the PI with `u_max` only 20 V above the back-EMF, so
/// at most 500 A can flow; 934.6 A are demanded for 0.5 s (saturated), then 115 A.
/// With the clamped integrator (`I <= u_max`) the current undershoots the new
/// reference by no more than 2 % of the step beyond the unsaturated loop's own step
/// response (same step from steady state), never exceeds 500 A, and its excess over the reference 10 ms
/// after the step is at most `(u_max - u_ss)/Kp` + 1 A (the integrator's distance from
/// its new steady state `u_ss = E + R_a i_ref`): 4 % of the 385 A step. The same PI
/// with the integrator unclamped (output still clamped) overshoots the bound 5-fold.
#[test]
fn anti_windup_recovers_without_overshoot() {
    let mut cfg = Config::default();
    let (la, ra, e_b) = (4e-4, 0.04, 3961.0);
    cfg.limits.voltage_max = e_b + 20.0;
    cfg.limits.voltage_min = 0.0;
    cfg.limits.current_ref_rate = 1e9; // steps
    let fs = cfg.base_rate_hz as f64;
    let s = cfg.scales;
    let a = (-ra / la / fs).exp();
    let b = (1.0 - a) / ra;
    let i_hi = 2.0e4 / (5.0 * 4.28);
    let i_lo = 2460.0 / (5.0 * 4.28);
    let d = cfg
        .pi
        .discretise(1.0 / fs)
        .expect("ok")
        .to_pu(s.current, s.voltage);
    let (u_min, u_max) = (0.0, cfg.limits.voltage_max / s.voltage);
    // `wide`: the integrator's own limits opened to the whole Q range (no anti-windup).
    // `linear`: no saturation at all, starting in steady state at 500 A.
    let run = |wide: bool, linear: bool| -> (f64, f64, f64, u32) {
        let (lo, hi) = match (wide, linear) {
            (_, true) => (-2.0, 2.0),
            (true, false) => (-2.0, 2.0),
            (false, false) => (u_min, u_max),
        };
        let pi = Pi::<f64>::new(&d, lo, hi).expect("ok");
        let (u_min, u_max) = if linear { (lo, hi) } else { (u_min, u_max) };
        let i_hi = if linear { 500.0 } else { i_hi };
        let i0 = if linear { 500.0 } else { 0.0 };
        let mut st = PiState::new((e_b + ra * i0) / s.voltage);
        let (mut i, mut u_prev) = (i0, e_b + ra * i0);
        let (mut peak, mut low, mut late_excess) = (0.0f64, f64::INFINITY, 0.0f64);
        let mut sat = 0;
        for n in 0..fs as usize {
            let r = if n < (0.5 * fs) as usize { i_hi } else { i_lo };
            let (u, f) = pi.process_flags(&mut st, (r - i) / s.current);
            let u = u.clamp(u_min, u_max) * s.voltage;
            sat += f.output as u32;
            i = a * i + b * (u_prev - e_b);
            u_prev = u;
            if n >= (0.5 * fs) as usize {
                peak = peak.max(i);
                low = low.min(i);
                if n >= (0.51 * fs) as usize {
                    late_excess = late_excess.max(i - i_lo);
                }
            }
        }
        (peak, low, late_excess, sat)
    };
    let (peak, low, late, sat) = run(false, false);
    assert!(sat > 1000, "the run must saturate: {sat}");
    assert!(peak <= 500.0 + 1.0, "peak {peak}");
    let step = 500.0 - i_lo;
    // The loop's own step response (no saturation, same 385 A step) undershoots too:
    // crossover 398 Hz with ZOH + one period of delay. Windup must add at most 2 %.
    let (_, low_lin, _, sat_lin) = run(false, true);
    assert_eq!(sat_lin, 0);
    assert!(low_lin < i_lo, "the linear loop undershoots: {low_lin}");
    assert!(
        low >= low_lin - 0.02 * step,
        "undershoot: min {low} vs linear {low_lin}"
    );
    let bound = (cfg.limits.voltage_max - (e_b + ra * i_lo)) / cfg.pi.kp + 1.0;
    assert!(late <= bound, "excess {late} A > {bound} A");
    let (_, low_w, late_w, _) = run(true, false);
    assert!(
        late_w > 5.0 * bound || low_w < i_lo - 0.1 * step,
        "without anti-windup it must be much worse: {late_w} {low_w}"
    );
}

/// Every counter counts its own signal, once per step where it clamped.
#[test]
fn counters_count_per_signal() {
    let cfg = Config {
        yaw_mode: YawMode::Gain,
        yaw_predict_ticks: 0.0,
        ..Config::default()
    };
    let mut c = F64Controller::try_new(&cfg).expect("ok");
    // 10 ticks: y' beyond its clamp (1 m/s) -> y' clamped and torque saturated.
    for _ in 0..10 {
        c.tick(&si(&cfg, 3.0, 0.0, 900.0, 0.0));
    }
    // 7 ticks: torque saturated only (0.5 m/s * 1.05e5 > 2e4 N m).
    for _ in 0..7 {
        c.tick(&si(&cfg, 0.5, 0.0, 900.0, 0.0));
    }
    // 3 ticks: current and demand beyond their clamps, NaN y'.
    for _ in 0..3 {
        c.tick(&Inputs {
            y_dot: f64::NAN,
            current: 5.0,
            speed: 0.9,
            demand: -5.0,
        });
    }
    let k = *c.counters();
    assert_eq!(k.ticks, 20);
    assert_eq!((k.y_dot.clamped, k.y_dot.invalid), (10, 3));
    assert_eq!(k.yaw_torque.clamped, 17);
    assert_eq!(k.current.clamped, 3);
    assert_eq!(k.demand.clamped, 3);
    assert_eq!((k.speed.clamped, k.speed.invalid), (0, 0));
    // -2000 A error at Kp = 1 V/A on 3961 V: not clamped at +-6000 V.
    assert_eq!(k.voltage.clamped, 0);
    let all = [
        k.y_dot,
        k.current,
        k.speed,
        k.demand,
        k.yaw_torque,
        k.voltage,
        k.integrator,
    ];
    let total: u32 = all.iter().map(|s| s.invalid + s.clamped).sum();
    assert_eq!(total, 10 + 3 + 17 + 3 + 3);
    c.reset_counters();
    assert_eq!(*c.counters(), Counters::default());
}

/// The yaw loop's delay compensation: `x = y + alpha (y[n] - y[n-1])`,
/// `alpha = yaw_predict_ticks / yaw_divisor`; a constant input passes unchanged, a ramp
/// is extrapolated `alpha` samples ahead, and the prediction is clamped to 2 pu.
#[test]
fn yaw_predictor_extrapolates_linearly() {
    for (ticks, yd) in [(1.5, 1u16), (2.0, 2), (0.0, 1), (3.0, 2)] {
        let cfg = Config {
            yaw_mode: YawMode::Gain,
            yaw_predict_ticks: ticks,
            yaw_divisor: yd,
            ..Config::default()
        };
        let alpha = ticks / yd as f64;
        let k = cfg.gain_k;
        let mut c = F64Controller::try_new(&cfg).expect("ok");
        let mut prev = 0.0;
        for n in 0..40u32 {
            let y = 1e-4 * n as f64; // a ramp of y' (m/s)
            let (t, _) = c.tick(&si(&cfg, y, 0.0, 0.0, 0.0)).to_si(&cfg.scales);
            if n % yd as u32 == 0 {
                let want = k * (y + alpha * (y - prev));
                assert!((t - want).abs() < 1e-9, "{ticks}/{yd} n={n}: {t} vs {want}");
                prev = y;
            }
        }
        // Constant input: no change.
        for _ in 0..4 {
            c.tick(&si(&cfg, 0.01, 0.0, 0.0, 0.0));
        }
        let (t, _) = c.tick(&si(&cfg, 0.01, 0.0, 0.0, 0.0)).to_si(&cfg.scales);
        assert!((t - k * 0.01).abs() < 1e-9);
    }
    let bad = Config {
        yaw_predict_ticks: 2.0,
        ..Config::default()
    };
    assert!(F64Controller::try_new(&bad).is_err());
    // Clamp: from rest, -1 pu predicts -2.5 pu; then +1 pu predicts +4 pu: both clamped
    // to 2 pu and counted.
    let cfg = Config {
        yaw_mode: YawMode::Gain,
        yaw_predict_ticks: 1.5,
        ..Config::default()
    };
    let mut c = F64Controller::try_new(&cfg).expect("ok");
    c.tick(&si(&cfg, -1.0, 0.0, 0.0, 0.0));
    let (t, _) = c.tick(&si(&cfg, 1.0, 0.0, 0.0, 0.0)).to_si(&cfg.scales);
    assert!((t - cfg.limits.torque).abs() < 1e-6);
    assert_eq!(c.counters().y_dot.clamped, 2);
}

/// The validation's boundaries: a scale, a limit or a rate of exactly zero is refused, a
/// voltage range of zero width is refused, and a limit of exactly two full scales is
/// accepted; the periods are the divisors over the base rate.
#[test]
fn validation_boundaries_are_where_the_ranges_say() {
    let base = Config {
        base_rate_hz: 2_000,
        yaw_divisor: 2,
        traction_divisor: 4,
        yaw_predict_ticks: 1.5,
        ..Config::default()
    };
    assert_eq!(
        (
            base.base_period(),
            base.yaw_period(),
            base.traction_period()
        ),
        (5e-4, 1e-3, 2e-3)
    );
    let field_of = |c: &Config| match c.validate() {
        Err(ConfigError::Range { field, .. }) => Some(field),
        Err(e) => panic!("{e}"),
        Ok(()) => None,
    };
    let mut c = base;
    c.scales.speed = 0.0;
    assert_eq!(field_of(&c), Some("scales.speed"));
    let mut c = base;
    c.limits.y_dot = 0.0;
    assert_eq!(field_of(&c), Some("limits.y_dot"));
    let mut c = base;
    c.limits.current_ref_rate = 0.0;
    assert_eq!(field_of(&c), Some("limits.current_ref_rate"));
    let mut c = base;
    c.limits.voltage_min = c.limits.voltage_max;
    assert_eq!(field_of(&c), Some("limits.voltage_max"));
    let mut c = base;
    c.limits.voltage_max = 2.0 * c.scales.voltage + 1.0;
    assert_eq!(field_of(&c), Some("limits.voltage_max"));
    let mut c = base;
    c.limits.voltage_max = 2.0 * c.scales.voltage;
    c.limits.y_dot = 2.0 * c.scales.y_dot;
    assert_eq!(field_of(&c), None);
    type Set = fn(&mut Config);
    let zero: [(Set, &str); 5] = [
        (|c| c.motor.k_m = 0.0, "motor.k_m"),
        (|c| c.motor.n = 0.0, "motor.n"),
        (|c| c.safe.yaw_s = 0.0, "safe.yaw_s"),
        (|c| c.safe.traction_s = 0.0, "safe.traction_s"),
        (|c| c.wire.voltage = 0.0, "wire.voltage"),
    ];
    for (set, name) in zero {
        let mut c = base;
        set(&mut c);
        assert_eq!(field_of(&c), Some(name));
    }
    // The largest current reference `demand / (n K_m)` within 2 current full scales.
    let mut c = base;
    c.scales.demand = 1.0e5;
    let per_fs = c.motor.n * c.motor.k_m * c.scales.current;
    c.limits.demand = 2.01 * per_fs;
    assert_eq!(field_of(&c), Some("limits.demand"));
    c.limits.demand = 1.99 * per_fs;
    assert_eq!(field_of(&c), None);
}

/// Per unit is SI over the full scale, in and out, on scales other than 1.
#[test]
fn signals_convert_by_their_full_scales() {
    let s = wheelset_control::FullScales {
        y_dot: 2.0,
        torque: 4.0e4,
        current: 500.0,
        voltage: 8.0e3,
        speed: 250.0,
        demand: 3.0e4,
    };
    let i = Inputs::<f64>::from_si(&s, 0.5, 100.0, 50.0, 6.0e3);
    assert_eq!(
        (i.y_dot, i.current, i.speed, i.demand),
        (0.25, 0.2, 0.2, 0.2)
    );
    let o = wheelset_control::Outputs::<f64> {
        yaw_torque: 0.5,
        voltage: -0.25,
    };
    assert_eq!(o.to_si(&s), (2.0e4, -2.0e3));
}

/// Each clamp is counted on its own signal: a demand the armature cannot follow (no
/// current flows) winds the PI into its limits (100 V here), and the counts are the
/// voltage's and the integrator's clamps, one a tick once there, nothing invalid, nothing
/// for the protection.
#[test]
fn a_saturated_pi_counts_its_voltage_and_integrator_clamps() {
    let mut cfg = Config::default();
    cfg.limits.voltage_max = 100.0;
    cfg.limits.voltage_min = -100.0;
    let mut c = F64Controller::try_new(&cfg).expect("valid");
    let inp = si::<f64>(&cfg, 0.0, 0.0, 0.0, 2.0e4);
    for _ in 0..2_000 {
        c.tick(&inp);
    }
    let before = *c.counters();
    assert!(before.integrator.clamped > 0 && before.voltage.clamped > 0);
    c.tick(&inp);
    let after = *c.counters();
    assert_eq!(after.integrator.clamped, before.integrator.clamped + 1);
    assert_eq!(after.voltage.clamped, before.voltage.clamped + 1);
    assert_eq!(after.integrator.invalid + after.voltage.invalid, 0);
    assert_eq!((after.wsp_ticks, after.wsp_events), (0, 0));
}

/// The supervisory accessors say what was set: the safe state, the torque limit (full in
/// normal running, 0 once the safe ramp has run out) and the fast path's switch.
#[test]
fn the_supervisory_state_reads_back() {
    let cfg = Config::default();
    let mut c = F64Controller::try_new(&cfg).expect("valid");
    let full = cfg.limits.torque / cfg.scales.torque;
    c.tick(&Inputs::default());
    assert!(!c.is_safe());
    assert_eq!(c.torque_limit(), full);
    assert!(c.fast_path_armed());
    c.set_fast_path(false);
    assert!(!c.fast_path_armed(), "switched off");
    c.set_fast_path(true);
    assert!(c.fast_path_armed(), "switched back on");
    c.set_safe(true);
    assert!(c.is_safe());
    for _ in 0..(cfg.safe.yaw_s * cfg.base_rate_hz as f64) as usize + 1 {
        c.tick(&Inputs::default());
    }
    assert_eq!(c.torque_limit(), 0.0);
    c.set_safe(false);
    assert!(!c.is_safe());
}

/// The supervisory changes do what they say: a torque limit handed over (clamped, NaN as
/// 0), a law change to the lead starting from its steady state and a repeated one
/// changing nothing, a torque continued from another core slewing from there, the
/// back-EMF `K_m omega` in pu, and traction off driving the back-EMF (zero current).
#[test]
fn supervisory_changes_do_what_they_say() {
    let cfg = Config::default();
    let s = cfg.scales;
    let full = cfg.limits.torque / s.torque;
    let new = || F64Controller::try_new(&cfg).expect("valid");
    let mut c = new();
    for (given, held) in [
        (0.25 * full, 0.25 * full),
        (2.0 * full, full),
        (f64::NAN, 0.0),
    ] {
        c.set_safe_at(true, given);
        assert!(c.is_safe());
        assert_eq!(c.torque_limit(), held, "{given}");
    }
    // Gain, then the lead: it starts from its steady state for the held y', so 10 ticks
    // on (the slew run out) the torque is the lead's DC gain times y' (no transient).
    let y = 0.002;
    let inp = si::<f64>(&cfg, y, 0.0, 0.0, 0.0);
    let mut c = new();
    c.set_mode(YawMode::Gain);
    assert_eq!(c.mode(), YawMode::Gain);
    for _ in 0..5_000 {
        c.tick(&inp);
    }
    c.set_mode(YawMode::Lead);
    assert_eq!(c.mode(), YawMode::Lead);
    for _ in 0..10 {
        c.tick(&inp);
    }
    let dc = cfg.lead.dc_gain() * y / s.torque;
    let t = c.tick(&inp).yaw_torque;
    assert!((t - dc).abs() <= 1e-9 * dc.abs(), "{t} vs the DC {dc}");
    // Setting the lead again while it is in a transient changes nothing.
    let step = si::<f64>(&cfg, 0.02, 0.0, 0.0, 0.0);
    c.tick(&step);
    let mut again = c.clone();
    again.set_mode(YawMode::Lead);
    assert_eq!(again.tick(&step), c.tick(&step));
    // Continued from another core's torque: the first tick slews from it, not from 0.
    let mut c = new();
    c.set_mode(YawMode::Passive);
    c.tick(&Inputs::default());
    c.continue_from(0.5 * full);
    let t = c.tick(&Inputs::default()).yaw_torque;
    assert!(t > 0.4 * full && t < 0.5 * full, "{t}");
    // The back-EMF, and traction off drives it.
    let mut c = new();
    let w = 0.3;
    let e = cfg.motor.k_m * w * s.speed / s.voltage;
    assert!(
        (c.back_emf(w) - e).abs() < 1e-12,
        "{} vs {e}",
        c.back_emf(w)
    );
    assert!(c.traction_enabled());
    // A current with no demand winds the integrator down; setting traction on again while
    // on changes nothing; off, then on again with no error: the integrator starts from the
    // back-EMF, not from what it held.
    let at = |i: f64| si::<f64>(&cfg, 0.0, i, w * s.speed, 0.0);
    for _ in 0..100 {
        c.tick(&at(500.0));
    }
    let mut again = c.clone();
    again.set_traction(true);
    assert_eq!(again.tick(&at(0.0)), c.clone().tick(&at(0.0)));
    c.set_traction(false);
    assert!(!c.traction_enabled());
    let v = c.tick(&at(500.0)).voltage;
    assert!((v - e).abs() < 1e-12, "{v} vs {e}");
    c.set_traction(true);
    let v = c.tick(&at(0.0)).voltage;
    assert!((v - e).abs() < 1e-12, "{v} vs {e}");
}

/// The traction accessors: a preset puts the integrator at the back-EMF and the reference
/// at 0; the error is the reference less the current; the traction step runs one tick in
/// `traction_divisor`; the reference the PI follows is the ramped one until the protection
/// acts, then its cap.
#[test]
fn the_traction_accessors_say_what_the_loop_holds() {
    let cfg = Config {
        traction_divisor: 4,
        ..Config::default()
    };
    let s = cfg.scales;
    let mut c = F64Controller::try_new(&cfg).expect("valid");
    c.preset_back_emf(0.3);
    assert_eq!(c.pi_state().integ, c.back_emf(0.3));
    assert_eq!(c.current_ref(), 0.0);
    let inp = si::<f64>(&cfg, 0.0, 100.0, 0.0, 2460.0);
    let stepped: Vec<bool> = (0..8)
        .map(|_| {
            c.tick(&inp);
            c.traction_stepped()
        })
        .collect();
    assert_eq!(stepped.iter().filter(|&&b| b).count(), 2, "{stepped:?}");
    assert!(stepped
        .windows(4)
        .all(|w| w.iter().filter(|&&b| b).count() == 1));
    let e = c.current_error();
    assert!(e != 0.0);
    assert!((e - (c.current_ref() - 100.0 / s.current)).abs() < 1e-12);
    assert_eq!(c.applied_ref(), c.current_ref());
}

/// The wire codec's inputs are `code x LSB / full scale` and its outputs `pu x full scale
/// / LSB` rounded, each on its own signal's factor (the y' full scale other than 1).
#[test]
fn the_codec_decodes_by_lsb_over_full_scale() {
    let mut cfg = Config::default();
    cfg.scales.y_dot = 2.0;
    let c = F64Controller::try_new(&cfg).expect("valid");
    let i = c.compiled().codec().decode(&wheelset_control::InputCodes {
        y_dot: 100_000,
        current: 50_000,
        speed: 30_000,
        demand: 7_000,
    });
    let (w, s) = (cfg.wire, cfg.scales);
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs();
    for (got, want) in [
        (i.y_dot, 100_000.0 * w.y_dot / s.y_dot),
        (i.current, 50_000.0 * w.current / s.current),
        (i.speed, 30_000.0 * w.speed / s.speed),
        (i.demand, 7_000.0 * w.demand / s.demand),
    ] {
        assert!(close(got, want), "{got} vs {want}");
    }
    let o = c.compiled().codec().encode(&wheelset_control::Outputs {
        yaw_torque: 0.25,
        voltage: -0.5,
    });
    assert_eq!(o.yaw_torque, (0.25 * s.torque / w.torque).round() as i32);
    assert_eq!(o.voltage, (-0.5 * s.voltage / w.voltage).round() as i32);
}
