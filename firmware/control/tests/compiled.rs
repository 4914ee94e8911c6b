//! The compiled controller and its exact bits: round trips, validation, schedules.

use wheelset_control::{
    Compiled, CompiledBits, Config, Controller, Fx, InputCodes, SampleBits, ScheduleBits,
};

fn at(base_rate_hz: u32, yaw_divisor: u16, traction_divisor: u16) -> Config {
    Config {
        base_rate_hz,
        yaw_divisor,
        traction_divisor,
        yaw_predict_ticks: 1.5,
        ..Config::default()
    }
}

fn round_trip<T: SampleBits>() {
    for cfg in [Config::default(), at(10_000, 2, 1), at(2_000, 1, 4)] {
        let c = Compiled::<T>::try_new(&cfg).expect("valid");
        let b = c.to_bits();
        assert_eq!(b.numeric, T::NUMERIC);
        assert_eq!(Compiled::<T>::from_bits(&b), Ok(c), "{}", T::NAME);
    }
}

#[test]
fn bits_round_trip_exactly_for_every_sample_type() {
    round_trip::<Fx>();
    round_trip::<f32>();
    round_trip::<f64>();
}

/// A controller built from bits runs bit for bit like one built from the configuration.
#[test]
fn a_controller_from_bits_is_the_same_controller() {
    let cfg = at(5_000, 1, 1);
    let mut a = Controller::<Fx>::try_new(&cfg).expect("valid");
    let bits = Compiled::<Fx>::try_new(&cfg).expect("valid").to_bits();
    let mut b = Controller::new(&Compiled::<Fx>::from_bits(&bits).expect("valid"));
    for k in 0..2_000i32 {
        let inp = InputCodes {
            y_dot: (k * 7_919) % 40_001 - 20_000,
            current: 115_000 + (k % 13) * 1_000,
            speed: 925_600,
            demand: 2_460,
        };
        assert_eq!(a.tick_codes(&inp), b.tick_codes(&inp), "tick {k}");
    }
    assert_eq!(a.counters(), b.counters());
}

/// The schedule of another rate, applied to a compiled controller, gives exactly the
/// compilation at that rate: the rate-independent part depends neither on the rates nor
/// on the gains designed for them (`Kp`, the lead's `K`).
#[test]
fn a_schedule_is_all_that_depends_on_the_rates() {
    let base = Compiled::<Fx>::try_new(&at(5_000, 1, 1)).expect("valid");
    for (hz, yd, td) in [(10_000, 2, 1), (2_000, 1, 1), (4_000, 4, 2), (1_000, 1, 1)] {
        let other = Compiled::<Fx>::try_new(&at(hz, yd, td)).expect("valid");
        assert_eq!(
            base.to_bits().fingerprint(),
            other.to_bits().fingerprint(),
            "{hz}"
        );
        assert_eq!(base.with_schedule(&other.schedule()), Ok(other), "{hz}");
    }
    for p in wheelset_control::design::DESIGNED {
        let d = Config::default()
            .designed(p.base_rate_hz, p.delay_ticks)
            .expect("designed");
        let other = Compiled::<Fx>::try_new(&d).expect("valid");
        assert_eq!(base.to_bits().fingerprint(), other.to_bits().fingerprint());
        assert_eq!(base.with_schedule(&other.schedule()), Ok(other), "{p:?}");
    }
    // Another limit is another controller.
    let mut cfg = at(5_000, 1, 1);
    cfg.limits.torque = 1.0e4;
    let other = Compiled::<Fx>::try_new(&cfg).expect("valid");
    assert_ne!(base.to_bits().fingerprint(), other.to_bits().fingerprint());
    // Another sample type too.
    let f = Compiled::<f32>::try_new(&at(5_000, 1, 1)).expect("valid");
    assert_ne!(base.to_bits().fingerprint(), f.to_bits().fingerprint());
}

#[test]
fn invalid_bits_are_refused_by_name() {
    let good: CompiledBits = Compiled::<Fx>::try_new(&Config::default())
        .expect("valid")
        .to_bits();
    let two_pu = 2u64 << 28;
    let cases: Vec<(&str, CompiledBits)> = vec![
        ("numeric", CompiledBits { numeric: 1, ..good }),
        (
            "lead_k_hf",
            CompiledBits {
                schedule: ScheduleBits {
                    lead_k_hf: 1 << 32, // wider than 32 bits
                    ..good.schedule
                },
                ..good
            },
        ),
        (
            "kp",
            CompiledBits {
                schedule: ScheduleBits {
                    kp: 0, // not in (0, 1)
                    ..good.schedule
                },
                ..good
            },
        ),
        (
            "delay_ticks",
            CompiledBits {
                schedule: ScheduleBits {
                    delay_ticks: 0,
                    ..good.schedule
                },
                ..good
            },
        ),
        (
            "lead_g_half",
            CompiledBits {
                lead_g_half: 1 << 32, // wider than 32 bits
                ..good
            },
        ),
        (
            "clamps.torque",
            CompiledBits {
                clamps: [
                    good.clamps[0],
                    good.clamps[1],
                    good.clamps[2],
                    good.clamps[3],
                    0,
                ],
                ..good
            },
        ),
        (
            "clamps.y_dot",
            CompiledBits {
                clamps: [
                    two_pu + 1,
                    good.clamps[1],
                    good.clamps[2],
                    good.clamps[3],
                    good.clamps[4],
                ],
                ..good
            },
        ),
        (
            "u_min/u_max",
            CompiledBits {
                u_min: good.u_max,
                ..good
            },
        ),
        (
            "codec.voltage",
            CompiledBits {
                codec: {
                    let mut c = good.codec;
                    c[5].shift = 63;
                    c
                },
                ..good
            },
        ),
        (
            "ki_shift",
            CompiledBits {
                schedule: ScheduleBits {
                    ki_shift: 0, // fixed point shifts Ki by 1..=30
                    ..good.schedule
                },
                ..good
            },
        ),
        (
            "ki_shift",
            CompiledBits {
                schedule: ScheduleBits {
                    ki_shift: 31,
                    ..good.schedule
                },
                ..good
            },
        ),
        (
            "yaw_divisor",
            CompiledBits {
                schedule: ScheduleBits {
                    yaw_divisor: 0,
                    ..good.schedule
                },
                ..good
            },
        ),
        (
            "base_rate_hz",
            CompiledBits {
                schedule: ScheduleBits {
                    base_rate_hz: 100_001,
                    ..good.schedule
                },
                ..good
            },
        ),
        (
            "kappa",
            CompiledBits {
                schedule: ScheduleBits {
                    kappa: 0,
                    ..good.schedule
                },
                ..good
            },
        ),
        (
            "iref_step",
            CompiledBits {
                schedule: ScheduleBits {
                    iref_step: u64::from((-1i32) as u32),
                    ..good.schedule
                },
                ..good
            },
        ),
    ];
    for (field, bits) in cases {
        let e = Compiled::<Fx>::from_bits(&bits).expect_err(field);
        assert_eq!(e.field, field);
        // The message names the field.
        assert!(e.to_string().contains(&format!("`{field}`")), "{e}");
    }
    // Floats: non-finite values and coefficients of 1 or more are refused.
    let f: CompiledBits = Compiled::<f32>::try_new(&Config::default())
        .expect("valid")
        .to_bits();
    let nan = u64::from(f32::NAN.to_bits());
    let one = u64::from(1.0f32.to_bits());
    for (field, bits) in [
        ("gain", CompiledBits { gain: nan, ..f }),
        (
            "kappa",
            CompiledBits {
                schedule: ScheduleBits {
                    kappa: one,
                    ..f.schedule
                },
                ..f
            },
        ),
    ] {
        assert_eq!(
            Compiled::<f32>::from_bits(&bits).map_err(|e| e.field),
            Err(field)
        );
    }
}

/// `Ki` is held with its own shift, chosen for the gains' `Ki` at the slowest traction
/// rate (500 Hz): the same shift for the same gains at every rate, the most significant
/// bits that allows at the default rate, and the exact value it stands for in
/// `quantised`.
#[test]
fn ki_has_its_own_shift_for_its_gains() {
    let base = Compiled::<Fx>::try_new(&Config::default()).expect("valid");
    let s = base.pi().ki_shift();
    assert_eq!(u32::from(base.to_bits().schedule.ki_shift), s);
    let cfg = Config::default();
    let ki =
        cfg.pi.kp * cfg.traction_period() / cfg.pi.ti * cfg.scales.current / cfg.scales.voltage;
    let held = base.to_bits().schedule.ki as f64; // Ki 2^(31+s), Q1.31 bits of Ki 2^s
    assert!(held.log2() > 27.0, "{} significant bits", held.log2());
    let q = base.pi().quantised().ki;
    assert!(((q - ki) / ki).abs() < 2f64.powi(-27), "{q} vs {ki}");
    assert_eq!(q, held / 2f64.powi(31 + s as i32));
    // Ki at 500 Hz (the slowest traction rate accepted) fits the shift; one bit more
    // would not.
    let slow = Compiled::<Fx>::try_new(&at(1_000, 1, 2)).expect("valid");
    assert_eq!(slow.pi().ki_shift(), s);
    assert!(
        slow.schedule().ki >= 1 << 30,
        "normalised at the slowest rate"
    );
    for (hz, td) in [(20_000, 1), (1_000, 2), (10_000, 4)] {
        let c = Compiled::<Fx>::try_new(&at(hz, 1, td)).expect("valid");
        assert_eq!(c.pi().ki_shift(), s, "{hz}/{td}");
        assert_eq!(base.with_schedule(&c.schedule()), Ok(c), "{hz}/{td}");
    }
    // Floats need no shift.
    let f = Compiled::<f32>::try_new(&Config::default()).expect("valid");
    assert_eq!((f.pi().ki_shift(), f.to_bits().schedule.ki_shift), (0, 0));
    // A design with a smaller Kp (1 kHz) holds its smaller Ki with a larger shift.
    let slow = Compiled::<Fx>::try_new(&Config::default().designed(1_000, 1).expect("designed"))
        .expect("valid");
    assert!(slow.pi().ki_shift() > s);
    // A Ki of 0.5 pu per sample or more has no shift: refused by name.
    let mut big = Config::default();
    big.pi.ti = big.traction_period() * 0.05;
    match Compiled::<Fx>::try_new(&big) {
        Err(wheelset_control::ConfigError::Coefficient { name, .. }) => {
            assert_eq!(name, "pi.ki (pu)")
        }
        other => panic!("{other:?}"),
    }
}

/// Every limit, slew and conversion the controller is compiled with is its SI value over
/// its full scale (`pu = SI / scale`), and the rates are the configuration's: checked in
/// `f64`, where quantising is exact, on scales other than 1 so that a product in place of
/// a quotient shows.
#[test]
fn limits_and_slews_are_their_si_values_over_their_scales() {
    let mut cfg = at(2_000, 2, 4);
    cfg.scales.y_dot = 2.0;
    cfg.scales.torque = 4.0e4;
    cfg.scales.demand = 4.0e4;
    cfg.safe.yaw_s = 0.2;
    cfg.safe.traction_s = 0.4;
    let c = Compiled::<f64>::try_new(&cfg).expect("valid");
    let (s, l, m) = (&cfg.scales, &cfg.limits, &cfg.motor);
    let (t_yaw, t_tr) = (cfg.yaw_period(), cfg.traction_period());
    assert_eq!((t_yaw, t_tr), (1e-3, 2e-3));
    let b = c.to_bits();
    let sch = &b.schedule;
    assert_eq!(
        (c.base_rate_hz(), sch.yaw_divisor, sch.traction_divisor),
        (2_000, 2, 4)
    );
    let v = f64::from_bits;
    let close = |what: &str, got: u64, want: f64| {
        let got = v(got);
        assert!(
            (got - want).abs() <= 1e-12 * want.abs(),
            "{what}: {got} != {want}"
        );
    };
    for (i, (what, want)) in [
        ("y'", l.y_dot / s.y_dot),
        ("current", l.current / s.current),
        ("speed", l.speed / s.speed),
        ("demand", l.demand / s.demand),
        ("torque", l.torque / s.torque),
    ]
    .into_iter()
    .enumerate()
    {
        close(what, b.clamps[i], want);
    }
    close("u_min", b.u_min, l.voltage_min / s.voltage);
    close("u_max", b.u_max, l.voltage_max / s.voltage);
    close("gain", b.gain, cfg.gain_k * s.y_dot / s.torque);
    let iref_max = l.demand / (m.n * m.k_m) / s.current;
    close(
        "demand_to_iref",
        b.demand_to_iref,
        s.demand / (m.n * m.k_m * s.current),
    );
    close("back_emf", b.back_emf, m.k_m * s.speed / s.voltage);
    let sch = b.schedule;
    close(
        "iref_step",
        sch.iref_step,
        l.current_ref_rate * t_tr / s.current,
    );
    // The safe ramps take their configured times from the largest value to zero.
    close(
        "iref_safe_step",
        sch.iref_safe_step,
        iref_max * t_tr / cfg.safe.traction_s,
    );
    close(
        "torque_step",
        sch.torque_step,
        l.torque / s.torque * t_yaw / cfg.safe.yaw_s,
    );
    close(
        "predict_half",
        sch.predict_half,
        cfg.yaw_predict_ticks / (2.0 * 2.0),
    );
}

/// The fingerprint covers every bit of every constant outside the schedule: flipping the
/// lowest or the highest bit of any one changes it; the schedule, the start mode and the
/// traction switch leave it alone.
#[test]
fn the_fingerprint_sees_every_bit_of_every_constant() {
    let good = Compiled::<Fx>::try_new(&Config::default())
        .expect("valid")
        .to_bits();
    let fp = good.fingerprint();
    type Field = fn(&mut CompiledBits) -> &mut u64;
    let words: [Field; 19] = [
        |b| &mut b.lead_g_half,
        |b| &mut b.gain,
        |b| &mut b.u_min,
        |b| &mut b.u_max,
        |b| &mut b.demand_to_iref,
        |b| &mut b.back_emf,
        |b| &mut b.y_dot_pred_max,
        |b| &mut b.wsp.slip_on,
        |b| &mut b.wsp.slip_accel,
        |b| &mut b.wsp.accel_ratio,
        |b| &mut b.wsp.cut,
        |b| &mut b.wsp.sp_half,
        |b| &mut b.wsp.sp_half_slope,
        |b| &mut b.wsp.kp,
        |b| &mut b.wsp.ki,
        |b| &mut b.wsp.lead_rho,
        |b| &mut b.wsp.v_ref.mul,
        |b| &mut b.clamps[0],
        |b| &mut b.clamps[4],
    ];
    for (i, field) in words.iter().enumerate() {
        for bit in [0, 63] {
            let mut b = good;
            *field(&mut b) ^= 1 << bit;
            assert_ne!(b.fingerprint(), fp, "word {i}, bit {bit}");
        }
    }
    for i in 0..good.codec.len() {
        for bit in [0, 63] {
            let mut b = good;
            b.codec[i].mul ^= 1 << bit;
            assert_ne!(b.fingerprint(), fp, "codec {i}, bit {bit}");
        }
        let mut b = good;
        b.codec[i].shift ^= 1;
        assert_ne!(b.fingerprint(), fp, "codec {i} shift");
    }
    for flip in [
        |b: &mut CompiledBits| b.numeric ^= 1,
        |b: &mut CompiledBits| b.wsp.kp_shift ^= 1,
        |b: &mut CompiledBits| b.wsp.ki_shift ^= 1,
        |b: &mut CompiledBits| b.wsp.v_ref.shift ^= 1,
    ] {
        let mut b = good;
        flip(&mut b);
        assert_ne!(b.fingerprint(), fp);
    }
    let mut b = good;
    b.schedule.kp ^= 1;
    b.traction_enabled = !b.traction_enabled;
    b.yaw_mode = wheelset_control::YawMode::Passive;
    assert_eq!(b.fingerprint(), fp);
}

/// The `const` constructor the firmware starts from builds the controller `from_bits`
/// validates, also at the edges of a wire scale's range (shift 0 and 62).
#[test]
fn the_const_constructor_is_the_validated_one_at_the_scale_edges() {
    let good = Compiled::<Fx>::try_new(&Config::default())
        .expect("valid")
        .to_bits();
    for (mul, shift) in [(1024, 0), ((1 << 31) - 1, 62), (1 << 20, 1)] {
        let mut b = good;
        b.codec[0] = wheelset_control::ScaleBits { mul, shift };
        let checked = Compiled::<Fx>::from_bits(&b).expect("valid scale");
        assert_eq!(
            Compiled::<Fx>::from_valid_bits(&b),
            checked,
            "{mul} >> {shift}"
        );
    }
    // And in f32, whose bits are the floats'.
    let b = Compiled::<f32>::try_new(&Config::default())
        .expect("valid")
        .to_bits();
    assert_eq!(
        Compiled::<f32>::from_valid_bits(&b),
        Compiled::<f32>::from_bits(&b).expect("valid")
    );
}
