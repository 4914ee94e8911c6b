//! Wheel-slip protection: validation, exact bits, the law's phases (detect and cut,
//! regulate the slip to its set point, the scheduled lead, release), the switch and the
//! flag, an unknown reference (`v_ref = 0`: idle, a cap handed back), and the
//! fixed-point and f32 builds against the f64 reference on the same inputs.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use wheelset_control::{
    Compiled, Config, ConfigError, Controller, F32Controller, F64Controller, FixedController, Fx,
    Inputs, Sample, SampleBits, Wsp, WspBits, WspParams, WspState,
};

const N_R0: f64 = 5.0 / 0.45;

fn cfg() -> Config {
    let mut c = Config::default();
    c.wsp.enabled = true;
    c
}

/// Inputs for a wheel at `slip` m/s above the vehicle at 83.3 m/s, demand `demand` N m.
fn at<T: Sample>(c: &Config, slip: f64, demand: f64) -> (Inputs<T>, T) {
    let v = 83.3;
    let w = (v + slip) * N_R0;
    let s = &c.scales;
    (
        Inputs::from_si(s, 0.0, 0.0, w, demand),
        T::from_f64(v * N_R0 / s.speed),
    )
}

fn run<T: Sample>(c: &mut Controller<T>, cfg: &Config, slip: f64, demand: f64, ticks: u32) {
    let (inp, w_ref) = at::<T>(cfg, slip, demand);
    c.set_v_ref(w_ref);
    for _ in 0..ticks {
        let k = *c.counters();
        c.tick(&inp);
        // The tick's event word is what moved in the counters (the runtime counts by it).
        let ev = c.tick_events();
        assert_eq!(ev.wsp_acting(), c.counters().wsp_ticks != k.wsp_ticks);
        assert_eq!(ev.wsp_started(), c.counters().wsp_events != k.wsp_events);
    }
}

fn iref_a<T: Sample>(c: &Controller<T>) -> f64 {
    c.wsp_state().cap.to_f64() * 1000.0
}

#[test]
fn invalid_parameters_are_refused_with_the_field_named() {
    type Spoil = fn(&mut WspParams);
    let cases: [(&str, Spoil); 12] = [
        ("wsp.slip_accel_mps", |p| p.slip_accel_mps = p.slip_on_mps),
        ("wsp.slip_sp_mps", |p| p.slip_sp_mps = p.slip_on_mps),
        ("wsp.slip_sp_per_a", |p| p.slip_sp_per_a = -1e-4),
        ("wsp.cut_fraction", |p| p.cut_fraction = 1.0),
        ("wsp.kp_a_per_mps", |p| p.kp_a_per_mps = 0.0),
        ("wsp.ki_a_per_s_per_mps", |p| {
            p.ki_a_per_s_per_mps = f64::NAN
        }),
        ("wsp.lead_w1_rad_s", |p| p.lead_w1_rad_s = 274.0),
        ("wsp.lead_gain", |p| p.lead_gain = 0.0),
        ("wsp.accel_on_mps2", |p| p.accel_on_mps2 = f64::NAN),
        ("wsp.r0_m", |p| p.r0_m = 0.0),
        ("wsp.slip_on_mps", |p| p.slip_on_mps = 11.0),
        ("wsp.v_ref_lsb_m_per_s", |p| p.v_ref_lsb_m_per_s = 0.0),
    ];
    for (field, f) in cases {
        let mut c = cfg();
        f(&mut c.wsp);
        let e = F64Controller::try_new(&c).unwrap_err();
        let named = match e {
            ConfigError::Range { field: x, .. } | ConfigError::NotFinite { field: x } => x,
            ConfigError::Coefficient { name, .. } => name,
        };
        assert_eq!(named, field, "{e}");
        assert!(c.validate().is_err());
    }
}

#[test]
fn bits_round_trip_and_invalid_bits_are_refused() {
    let c = cfg();
    let law = Compiled::<Fx>::try_new(&c).unwrap();
    let b = law.to_bits();
    assert_eq!(Compiled::<Fx>::from_bits(&b).unwrap(), law);
    assert_eq!(Compiled::<Fx>::from_valid_bits(&b), law);
    type Spoil = fn(&mut WspBits);
    // Q4.28 bits of 2 pu (the largest limit) and of one LSB more.
    const TWO: u64 = 2 << 28;
    let cases: [(&str, Spoil); 10] = [
        ("wsp.slip_on", |w| w.slip_on = 0),
        ("wsp.slip_on", |w| w.slip_on = TWO + 1),
        ("wsp.slip_accel", |w| w.slip_accel = 0),
        ("wsp.sp_half", |w| w.sp_half = 0),
        ("wsp.sp_half", |w| w.sp_half = TWO + 1),
        ("wsp.slip_accel", |w| w.slip_accel = w.slip_on),
        ("wsp.sp_half", |w| w.sp_half = w.slip_on),
        ("wsp.cut", |w| w.cut = 0),
        ("wsp.kp_shift", |w| w.kp_shift = 17),
        ("wsp.ki_shift", |w| w.ki_shift = 17),
    ];
    for (field, f) in cases {
        let mut bad = b;
        f(&mut bad.wsp);
        assert_eq!(Compiled::<Fx>::from_bits(&bad).unwrap_err().field, field);
    }
    // The detection threshold may be as high as 2 pu.
    let mut top = b;
    top.wsp.slip_on = TWO;
    assert!(Compiled::<Fx>::from_bits(&top).is_ok());
    // The protection's parameters are part of the fingerprint.
    for f in [
        (|p: &mut WspParams| p.slip_on_mps = 0.5) as fn(&mut WspParams),
        |p| p.ki_a_per_s_per_mps = 2000.0,
        |p| p.lead_w1_rad_s = 20.0,
    ] {
        let mut other = c;
        f(&mut other.wsp);
        let b2 = Compiled::<Fx>::try_new(&other).unwrap().to_bits();
        assert_ne!(b.fingerprint(), b2.fingerprint());
    }
    let f = Compiled::<f32>::try_new(&c).unwrap();
    assert_eq!(Compiled::<f32>::from_bits(&f.to_bits()).unwrap(), f);
}

/// The set point `s_sp = slip_sp + slip_sp_per_a cap`, m/s, at the protection's cap.
fn set_point<T: Sample>(c: &Config, k: &Controller<T>) -> f64 {
    c.wsp.slip_sp_mps + c.wsp.slip_sp_per_a * iref_a(k)
}

#[test]
fn a_rolling_wheel_is_left_alone_and_a_slip_is_cut_at_once() {
    let c = cfg();
    let mut k = F64Controller::try_new(&c).unwrap();
    // 0.1 m/s of slip (dry rail at full demand needs 0.17): nothing happens.
    run(&mut k, &c, 0.1, 12_400.0, 500);
    assert!(!k.wheel_slip() && !k.wsp_state().sched);
    assert_eq!(k.counters().wsp_events, 0);
    let iref = k.current_ref().to_f64() * 1000.0;
    assert!(iref > 500.0, "reference {iref} A");
    // 0.4 m/s: detected on the first step, the cap is `cut_fraction` of the reference,
    // and the slip is above half the set point: the scheduled lead runs.
    run(&mut k, &c, 0.4, 12_400.0, 1);
    assert!(k.wheel_slip());
    assert_eq!(k.counters().wsp_events, 1);
    let cap = iref_a(&k);
    assert!(
        (cap - c.wsp.cut_fraction * iref).abs() < 1e-6,
        "cap {cap} A after the cut"
    );
    assert!(k.wsp_state().sched);
    // Held above the set point: the integral takes the cap down, at
    // ki (slip - s_sp) A/s, to zero in bounded time.
    let sp = set_point(&c, &k);
    run(&mut k, &c, 0.4, 12_400.0, 100);
    let fall = cap - iref_a(&k);
    let want = c.wsp.ki_a_per_s_per_mps * (0.4 - sp) * 100.0 * c.traction_period();
    assert!(
        (fall - want).abs() < 0.05 * want,
        "fell {fall} A, {want} A expected"
    );
    run(&mut k, &c, 0.4, 12_400.0, 5000);
    assert!(iref_a(&k) < 1e-6);
    assert_eq!(k.counters().wsp_events, 1, "one event, however long");
    assert_eq!(k.counters().wsp_ticks, 5101);
}

#[test]
fn the_proportional_term_answers_a_slip_step() {
    let c = cfg();
    let mut k = F64Controller::try_new(&c).unwrap();
    run(&mut k, &c, 0.0, 12_400.0, 500);
    run(&mut k, &c, 0.3, 12_400.0, 1);
    let before = iref_a(&k);
    let sp = set_point(&c, &k);
    // A step of +0.05 m/s: the cap drops by kp 0.05 A at once (plus one integral step).
    run(&mut k, &c, 0.35, 12_400.0, 1);
    let drop = before - iref_a(&k);
    let p = c.wsp.kp_a_per_mps * 0.05;
    let i = c.wsp.ki_a_per_s_per_mps * (0.35 - sp) * c.traction_period();
    assert!(
        (drop - p - i).abs() < 1e-3 * p,
        "dropped {drop} A, {} A expected",
        p + i
    );
}

/// A toy rail for the regulator: the wheel's slip velocity `s` rises with the current
/// the rail does not carry, `s' = 0.05 (cap - i_rail(s))` m/s^2 (A), the rail
/// carrying `i_rail(s) = 300 A s / (s + 0.1 m/s)` (a rising characteristic).
fn regulate<T: Sample>(c: &Config, ticks: u32) -> (Controller<T>, f64) {
    let mut k = Controller::<T>::try_new(c).unwrap();
    run(&mut k, c, 0.0, 12_400.0, 500);
    let mut s = 0.3;
    let dt = c.traction_period();
    for _ in 0..ticks {
        run(&mut k, c, s, 12_400.0, 1);
        let cap = if k.wheel_slip() {
            iref_a(&k)
        } else {
            k.current_ref().to_f64() * 1000.0
        };
        s = (s + dt * 0.05 * (cap - 300.0 * s / (s + 0.1))).max(0.0);
    }
    (k, s)
}

#[test]
fn the_regulator_holds_the_slip_at_its_set_point() {
    let c = cfg();
    let (k, s) = regulate::<f64>(&c, 20_000);
    assert!(k.wheel_slip());
    let sp = set_point(&c, &k);
    // The equilibrium: the slip on its set point, the cap what the rail carries there.
    assert!((s - sp).abs() < 2e-3, "slip {s} m/s, set point {sp} m/s");
    let carried = 300.0 * s / (s + 0.1);
    assert!((iref_a(&k) - carried).abs() < 2.0, "cap {} A", iref_a(&k));
    assert!(k.wsp_state().sched, "at the set point, above half of it");
}

#[test]
fn the_protection_releases_when_the_rail_carries_the_demand() {
    let c = cfg();
    let mut k = F64Controller::try_new(&c).unwrap();
    run(&mut k, &c, 0.0, 12_400.0, 500);
    run(&mut k, &c, 0.3, 12_400.0, 1);
    let iref = k.current_ref().to_f64() * 1000.0;
    // No slip: the integral raises the cap at ki s_sp, up to the reference, and releases.
    let mut ticks = 0u32;
    while k.wheel_slip() {
        run(&mut k, &c, 0.0, 12_400.0, 1);
        ticks += 1;
        assert!(ticks < 50_000, "no release");
        assert!(!k.wsp_state().sched, "below half the set point");
    }
    assert!(!k.wsp_state().active);
    assert_eq!(k.counters().wsp_events, 1);
    // From 0.3 of the reference, plus kp 0.3 m/s at the slip's fall to zero, at
    // ki (0.1 + 8e-4 cap) A/s: the time to release, as the solution of the linear ODE
    // cap' = ki (a + b cap).
    let (ki, a, b) = (
        c.wsp.ki_a_per_s_per_mps,
        c.wsp.slip_sp_mps,
        c.wsp.slip_sp_per_a,
    );
    let cut = c.wsp.cut_fraction * iref + c.wsp.kp_a_per_mps * 0.3;
    let t = ((a + b * iref) / (a + b * cut)).ln() / (ki * b);
    let got = ticks as f64 * c.traction_period();
    assert!(
        (got - t).abs() < 0.01 * t,
        "released after {got} s, {t} s expected"
    );
}

#[test]
fn the_switch_turns_it_off_and_braking_is_not_touched() {
    let mut c = cfg();
    let mut k = F64Controller::try_new(&c).unwrap();
    k.set_wsp(false);
    run(&mut k, &c, 2.0, 12_400.0, 100);
    assert!(!k.wheel_slip() && k.counters().wsp_events == 0);
    k.set_wsp(true);
    run(&mut k, &c, 2.0, 12_400.0, 1);
    assert!(k.wheel_slip());
    // Default configuration: on (the device's boot default).
    c.wsp = WspParams::default();
    assert!(F64Controller::try_new(&c).unwrap().wsp_enabled());
    // Braking demand: no protection (slide protection is not part of it).
    let c = cfg();
    let mut k = F64Controller::try_new(&c).unwrap();
    run(&mut k, &c, -2.0, -12_400.0, 100);
    run(&mut k, &c, 2.0, -12_400.0, 100);
    assert_eq!(k.counters().wsp_events, 0);
}

/// The same slip history through the fixed-point, f32 and f64 controllers: the same
/// decisions (the flag on the same ticks but for a threshold crossing landing a tick
/// apart), the same events, the same cap within `tol_a`.
fn agree<T: SampleBits>(tol_a: f64) {
    let c = cfg();
    let mut a = F64Controller::try_new(&c).unwrap();
    let mut b = Controller::<T>::try_new(&c).unwrap();
    let s = c.scales;
    let mut worst = 0.0f64;
    let (mut differ, mut sched_differ, mut sched) = (0u32, 0u32, 0u32);
    for k in 0..20_000u32 {
        let t = k as f64 / 5000.0;
        // Slip ramps through the thresholds and back: 0 .. 0.5 .. 0 m/s.
        let slip = 0.5 * (1.0 - (2.0 * t / 4.0 - 1.0).abs()).max(0.0);
        let (ia, wa) = at::<f64>(&c, slip, 12_400.0);
        let (ib, wb) = at::<T>(&c, slip, 12_400.0);
        a.set_v_ref(wa);
        b.set_v_ref(wb);
        a.tick(&ia);
        b.tick(&ib);
        differ += u32::from(a.wheel_slip() != b.wheel_slip());
        sched += u32::from(a.wsp_state().sched);
        sched_differ += u32::from(a.wsp_state().sched != b.wsp_state().sched);
        // Mean difference of the cap over the run (the mean shows any drift).
        worst += (iref_a(&a) - iref_a(&b)) * s.current / 1000.0 / 20_000.0;
    }
    assert!(
        differ <= 4,
        "{}: the flag differs on {differ} ticks",
        T::NAME
    );
    assert!(sched > 1000, "{sched} ticks on the scheduled lead");
    assert!(
        sched_differ <= 4,
        "{}: the lead switch differs on {sched_differ} ticks",
        T::NAME
    );
    assert!(a.counters().wsp_events >= 1);
    assert_eq!(a.counters().wsp_events, b.counters().wsp_events);
    assert!(
        worst.abs() < tol_a,
        "{}: the cap differs by {worst} A on average",
        T::NAME
    );
}

#[test]
fn fixed_point_and_f32_take_the_f64_decisions() {
    agree::<Fx>(1.0);
    agree::<f32>(1.0);
    // The FixedController alias is the production type.
    let _ = FixedController::try_new(&cfg()).unwrap();
    let _ = F32Controller::try_new(&cfg()).unwrap();
}

/// The tick (counted from the detection) on which the protection releases with no slip.
fn release_tick<T: Sample>(c: &Config) -> u32 {
    let mut ctl = Controller::<T>::try_new(c).unwrap();
    run(&mut ctl, c, 0.0, 12_400.0, 5_000);
    run(&mut ctl, c, 0.3, 12_400.0, 1);
    assert!(ctl.wheel_slip());
    let (inp, w_ref) = at::<T>(c, 0.0, 12_400.0);
    ctl.set_v_ref(w_ref);
    for k in 1..=50_000u32 {
        ctl.tick(&inp);
        if !ctl.wheel_slip() {
            return k;
        }
    }
    panic!("{}: no release after 10 s of adhesion", T::NAME);
}

#[test]
fn every_build_releases_on_the_same_tick() {
    // The cap rises by the integral's products, not by whole steps onto a lattice, so
    // `cap >= i_ref` falls between the builds' roundings only by chance; on these inputs
    // they release on the same tick.
    let c = cfg();
    let f64_tick = release_tick::<f64>(&c);
    assert!(f64_tick > 1000, "{f64_tick}");
    assert_eq!(release_tick::<Fx>(&c), f64_tick, "Q4.28 against f64");
    assert_eq!(release_tick::<f32>(&c), f64_tick, "f32 against f64");
}

/// The yaw torque after 2 s of a constant `y' = 0.01` m/s, the wheel at `slip` m/s.
fn yaw_dc<T: Sample>(c: &Config, slip: f64) -> f64 {
    let mut k = Controller::<T>::try_new(c).unwrap();
    let s = c.scales;
    let (mut inp, w_ref) = at::<T>(c, slip, 12_400.0);
    inp.y_dot = T::from_f64(0.01 / s.y_dot);
    k.set_v_ref(w_ref);
    for _ in 0..10_000 {
        k.tick(&inp);
    }
    assert_eq!(k.wsp_state().sched, slip > 0.2);
    k.outputs().yaw_torque.to_f64() * s.torque
}

#[test]
fn the_scheduled_lead_has_its_dc_gain() {
    // On the lead's state, `K_hf' (x - (1 + rho) z)` settles at
    // `lead_gain K a w1'/w2 x`: the DC gain of `0.3 K a (s + 15)/(s + 274)`, against the
    // lead's `K a 37/274 x` when the wheel does not slip; on the default scales and on a
    // y' scale other than 1 (the gain is `K a scales.y_dot / scales.torque` in pu).
    let mut c2 = cfg();
    c2.scales.y_dot = 0.5;
    for c in [cfg(), c2] {
        dc_gains(&c);
    }
}

fn dc_gains(c: &Config) {
    let l = c.lead;
    for (slip, want) in [
        (0.0, l.k * l.a * l.w1 / l.w2 * 0.01),
        (
            0.4,
            c.wsp.lead_gain * l.k * l.a * c.wsp.lead_w1_rad_s / l.w2 * 0.01,
        ),
    ] {
        for got in [yaw_dc::<f64>(c, slip), yaw_dc::<Fx>(c, slip)] {
            assert!(
                (got - want).abs() < 1e-3 * want,
                "slip {slip}: {got} N m, {want} N m"
            );
        }
    }
}

/// 925.6 rad/s at the motor (83.3 m/s at the rim), `demand` N m, the reference speed
/// `w_ref` (pu) for `ticks` ticks; whether the protection acted on any of them.
fn steady<T: Sample>(k: &mut Controller<T>, c: &Config, w_ref: T, demand: f64, ticks: u32) -> bool {
    let inp = Inputs::from_si(&c.scales, 0.0, 0.0, 925.6, demand);
    k.set_v_ref(w_ref);
    let mut acted = false;
    for _ in 0..ticks {
        k.tick(&inp);
        acted |= k.wheel_slip();
    }
    acted
}

/// An unknown reference (`v_ref = 0`) in build `T`: nothing detected, nothing cut (the
/// outputs those of the protection off); a known one at the vehicle's speed likewise,
/// and the same wheel against a vehicle known to stand detected at once.
fn unknown_is_idle<T: SampleBits>() {
    let c = cfg();
    let mut off = Controller::<T>::try_new(&c).unwrap();
    off.set_wsp(false);
    let w = |mps: f64| T::from_f64(mps * N_R0 / c.scales.speed);
    for (w_ref, what) in [(T::ZERO, "unknown"), (w(83.333), "83.333 m/s")] {
        let mut on = Controller::<T>::try_new(&c).unwrap();
        assert!(on.wsp_enabled());
        for _ in 0..10 {
            let acted = steady(&mut on, &c, w_ref, 5_000.0, 100);
            steady(&mut off, &c, w_ref, 5_000.0, 100);
            assert!(!acted, "{} {what}: WHEEL_SLIP", T::NAME);
            assert_eq!(on.outputs(), off.outputs(), "{} {what}", T::NAME);
        }
        assert_eq!(on.counters().wsp_events, 0, "{} {what}", T::NAME);
        assert_eq!(on.current_ref(), off.current_ref());
        off = Controller::<T>::try_new(&c).unwrap();
        off.set_wsp(false);
    }
    // Known, 1 mm/s (a vehicle known to stand): the wheel at 83.3 m/s slips.
    let mut on = Controller::<T>::try_new(&c).unwrap();
    steady(&mut on, &c, T::ZERO, 5_000.0, 100);
    assert!(steady(&mut on, &c, w(1e-3), 5_000.0, 1), "{}", T::NAME);
    assert_eq!(on.counters().wsp_events, 1);
}

#[test]
fn an_unknown_reference_leaves_the_protection_idle_in_every_build() {
    unknown_is_idle::<f64>();
    unknown_is_idle::<Fx>();
    unknown_is_idle::<f32>();
}

/// A cap in force when the reference drops out: handed back at the reference's slew.
/// Returns the traction steps from the drop-out to the release.
fn hand_back<T: Sample>(c: &Config) -> u32 {
    let mut k = Controller::<T>::try_new(c).unwrap();
    run(&mut k, c, 0.0, 12_400.0, 1_000);
    run(&mut k, c, 0.4, 12_400.0, 200);
    assert!(k.wheel_slip() && k.wsp_state().sched);
    let iref = k.current_ref().to_f64() * 1000.0;
    let slew = c.limits.current_ref_rate * c.traction_period();
    let (inp, _) = at::<T>(c, 0.4, 12_400.0);
    k.set_v_ref(T::ZERO);
    let mut cap = iref_a(&k);
    assert!(cap < 0.5 * iref, "cap {cap} A of {iref} A");
    for n in 1..=10_000u32 {
        k.tick(&inp);
        assert_eq!(k.counters().wsp_events, 1, "{}: no new event", T::NAME);
        assert!(!k.wsp_state().sched, "no scheduled lead without a slip");
        if !k.wsp_state().active {
            // Released where the next step would reach the reference.
            assert!(
                cap + slew >= iref - 1e-3,
                "{}: released at {cap} A",
                T::NAME
            );
            assert!(k.wheel_slip(), "the releasing step still reports");
            return n;
        }
        let now = iref_a(&k);
        assert!(
            (now - cap - slew).abs() < 1e-3,
            "{}: the cap rose {} A, the slew is {slew} A",
            T::NAME,
            now - cap
        );
        assert!(
            k.wheel_slip(),
            "{}: the cap still holds the reference",
            T::NAME
        );
        cap = now;
    }
    panic!("{}: not handed back", T::NAME)
}

#[test]
fn a_cap_in_force_is_handed_back_at_the_reference_slew_when_the_reference_drops_out() {
    let c = cfg();
    let n = hand_back::<f64>(&c);
    // From about 0.3 of 580 A to 580 A at 4 A per step: about 100 steps.
    assert!((50..200).contains(&n), "{n} steps");
    assert_eq!(hand_back::<Fx>(&c), n, "Q4.28 against f64");
    assert_eq!(hand_back::<f32>(&c), n, "f32 against f64");
}

#[test]
fn the_regulator_resumes_from_the_cap_when_the_reference_returns() {
    let c = cfg();
    let mut k = F64Controller::try_new(&c).unwrap();
    run(&mut k, &c, 0.0, 12_400.0, 1_000);
    run(&mut k, &c, 0.4, 12_400.0, 200);
    let (inp, w_ref) = at::<f64>(&c, 0.4, 12_400.0);
    k.set_v_ref(0.0);
    for _ in 0..10 {
        k.tick(&inp);
    }
    let cap = iref_a(&k);
    // Known again, the wheel still 0.4 m/s ahead: the regulator takes the cap from where
    // the hand-back left it, by its integral alone on this step (a proportional step
    // from the unknown steps' `w - 0` would be 300 A per m/s of 83 m/s).
    k.set_v_ref(w_ref);
    k.tick(&inp);
    assert!(k.wsp_state().active && k.wheel_slip());
    let step = c.wsp.ki_a_per_s_per_mps * 0.4 * c.traction_period();
    let moved = (iref_a(&k) - cap).abs();
    assert!(
        moved <= step,
        "the cap moved {moved} A, the integral's step {step} A"
    );
    assert!(k.wsp_state().sched);
    assert_eq!(k.counters().wsp_events, 1);
}

/// The reference speed from the Sensor frame's code is the motor speed `n v / r0` in pu,
/// 0 (unknown) stays 0; the protection's switch reads back.
#[test]
fn the_reference_speed_code_is_the_motor_speed_and_the_switch_reads_back() {
    let cfg = Config::default();
    let mut c = Controller::<f64>::try_new(&cfg).expect("valid");
    assert_eq!(c.wsp_enabled(), cfg.wsp.enabled);
    c.set_v_ref_code(25_000);
    let want = 25.0 * cfg.motor.n / cfg.wsp.r0_m / cfg.scales.speed;
    let got = c.wsp_state().w_ref;
    assert!((got - want).abs() < 1e-9 * want, "{got} vs {want}");
    c.set_v_ref_code(0);
    assert_eq!(c.wsp_state().w_ref, 0.0);
    c.set_wsp(false);
    assert!(!c.wsp_enabled());
    c.set_wsp(true);
    assert!(c.wsp_enabled());
    // A slip: the reference the PI follows is the protection's cap, below the ramped one.
    c.set_v_ref(0.9);
    let at = |speed: f64| wheelset_control::Inputs {
        y_dot: 0.0,
        current: 0.0,
        speed,
        demand: 0.5,
    };
    for _ in 0..50 {
        c.tick(&at(0.9));
    }
    assert_eq!(c.applied_ref(), c.current_ref());
    c.tick(&at(1.2));
    assert!(c.wsp_state().active);
    assert_eq!(c.applied_ref(), c.wsp_state().cap);
    assert!(c.applied_ref() < c.current_ref());
}

/// The protection's open range edges are refused by name: a wheel radius of 0.1 m, a
/// detection slip of 0 and an acceleration-test slip of 0.
#[test]
fn the_protections_open_edges_are_refused() {
    let d = Config::default();
    let field = |c: &Config| match Controller::<f64>::try_new(c) {
        Err(wheelset_control::ConfigError::Range { field, .. }) => field,
        other => panic!("{other:?}"),
    };
    let mut c = d;
    c.wsp.r0_m = 0.1;
    assert_eq!(field(&c), "wsp.r0_m");
    let mut c = d;
    c.wsp.slip_on_mps = 0.0;
    assert_eq!(field(&c), "wsp.slip_on_mps");
    let mut c = d;
    c.wsp.slip_accel_mps = 0.0;
    assert_eq!(field(&c), "wsp.slip_accel_mps");
    type Set = fn(&mut Config);
    let edges: [(Set, &str); 8] = [
        (|c| c.wsp.accel_on_mps2 = 0.0, "wsp.accel_on_mps2"),
        (|c| c.wsp.accel_on_mps2 = -1.0, "wsp.accel_on_mps2"),
        (|c| c.wsp.cut_fraction = 0.0, "wsp.cut_fraction"),
        (|c| c.wsp.cut_fraction = 1.0, "wsp.cut_fraction"),
        (|c| c.wsp.cut_fraction = -0.5, "wsp.cut_fraction"),
        (|c| c.wsp.slip_sp_mps = 0.0, "wsp.slip_sp_mps"),
        (|c| c.wsp.slip_sp_mps = c.wsp.slip_on_mps, "wsp.slip_sp_mps"),
        (|c| c.wsp.kp_a_per_mps = -1.0, "wsp.kp_a_per_mps"),
    ];
    for (set, name) in edges {
        let mut c = d;
        set(&mut c);
        assert_eq!(field(&c), name);
    }
    let edges: [(Set, &str); 5] = [
        (|c| c.wsp.ki_a_per_s_per_mps = 0.0, "wsp.ki_a_per_s_per_mps"),
        (|c| c.wsp.ki_a_per_s_per_mps = 2e5, "wsp.ki_a_per_s_per_mps"),
        (|c| c.wsp.kp_a_per_mps = 2e4, "wsp.kp_a_per_mps"),
        (|c| c.wsp.lead_w1_rad_s = 0.0, "wsp.lead_w1_rad_s"),
        (|c| c.wsp.lead_gain = 1.5, "wsp.lead_gain"),
    ];
    for (set, name) in edges {
        let mut c = d;
        set(&mut c);
        assert_eq!(field(&c), name);
    }
    // A coefficient must be below 1 in every build, floats too: the acceleration test's
    // ratio `accel_on n/r0 / current_ref_rate` (pu) at 1 or more is refused by name.
    let mut c = d;
    let pu = c.motor.n / (c.wsp.r0_m * c.scales.speed);
    c.limits.current_ref_rate = c.wsp.accel_on_mps2 * pu * c.scales.current / 1.5;
    match Controller::<f64>::try_new(&c) {
        Err(wheelset_control::ConfigError::Coefficient { name, value }) => {
            assert_eq!(name, "wsp accel_on n/r0 / current_ref_rate");
            assert!((value - 1.5).abs() < 1e-9, "{value}");
        }
        other => panic!("{other:?}"),
    }
    // At exactly 1 too (the rate chosen so the ratio rounds to 1.0).
    let mut c = d;
    c.limits.current_ref_rate = c.wsp.accel_on_mps2 * pu * c.scales.current;
    match Controller::<f64>::try_new(&c) {
        Err(wheelset_control::ConfigError::Coefficient { value, .. }) => assert_eq!(value, 1.0),
        other => panic!("{other:?}"),
    }
    // The set point's slope: up to 1 m/s per current full scale, accepted at the edge.
    let mut c = d;
    c.wsp.slip_sp_per_a = 1.0 / c.scales.current;
    assert!(Controller::<f64>::try_new(&c).is_ok());
    c.wsp.slip_sp_per_a = 1.01 / c.scales.current;
    assert_eq!(field(&c), "wsp.slip_sp_per_a");
}

/// The wire's motor-speed LSB must resolve the acceleration test's slip: one code at most
/// `slip_accel_mps` at the motor (`n/r0`, pu of the speed scale); 1 % under is accepted,
/// 1 % over refused by name.
#[test]
fn the_speed_code_must_resolve_the_acceleration_slip() {
    let d = Config::default();
    let limit = d.wsp.slip_accel_mps * d.motor.n / d.wsp.r0_m; // rad/s at the motor
    let with = |lsb: f64| {
        let mut c = d;
        c.wire.speed = lsb;
        Controller::<f64>::try_new(&c)
    };
    assert!(with(0.99 * limit).is_ok());
    match with(1.01 * limit) {
        Err(ConfigError::Range { field, .. }) => assert_eq!(field, "wire.speed"),
        other => panic!("{other:?}"),
    }
}

/// A gain is split as `c 2^s` with `s` at most 16: a protection integral gain that needs
/// a 17th halving is refused by name, one that needs 16 is accepted.
#[test]
fn a_gain_past_the_largest_shift_is_refused() {
    let d = Config::default();
    let pu = d.motor.n / (d.wsp.r0_m * d.scales.speed);
    // ki' = ki / (pu current_ref_rate): set the rate for ki' = 1.5 x 2^16, then 1.5 x 2^15.
    let with = |ki_pu: f64| {
        let mut c = d;
        c.limits.current_ref_rate = c.wsp.ki_a_per_s_per_mps / (pu * ki_pu);
        // The acceleration test's ratio scales with 1/current_ref_rate too: kept below 1.
        c.wsp.accel_on_mps2 /= 20.0;
        wsp_f64(&c)
    };
    match with(1.5 * 65536.0) {
        Err(ConfigError::Coefficient { name, .. }) => {
            assert_eq!(name, "wsp ki / (n/r0 current_ref_rate)");
        }
        other => panic!("{other:?}"),
    }
    let w = with(1.5 * 32768.0).expect("16 halvings fit");
    assert_eq!(w.to_bits().ki_shift, 16);
}

/// The scheduled yaw lead runs while the protection acts with the slip strictly above
/// half its set point: a slip exactly at half the set point does not schedule it, the
/// next value up does.
#[test]
fn the_scheduled_lead_needs_the_slip_above_half_the_set_point() {
    let mut c = cfg();
    c.wsp.slip_sp_per_a = 0.0; // a set point that does not move with the cap
    let w = wsp_f64(&c).unwrap();
    let h = w.half_set_point(0.0);
    // A reference of `h` itself: the slip `2h - h` is exactly `h` (no rounding).
    let (w_ref, iref, step) = (h, 0.8, 1e-4);
    let sched = |speed: f64| {
        let slip = speed - w_ref;
        let mut st = WspState {
            cap: 0.1,
            active: true,
            w_prev: speed,
            w_ref,
            slip_prev: slip,
            known: true,
            ..WspState::default()
        };
        let (r, acting, _) = w.process(&mut st, speed, iref, step);
        assert!(acting && r < iref, "still capping");
        (st.sched, slip)
    };
    assert_eq!(sched(2.0 * h), (false, h));
    let up = (2.0 * h).next_up();
    assert!(sched(up).1 > h);
    assert!(sched(up).0);
}

/// Every compiled quantity of the protection is its SI formula (the `f64` build holds it
/// exactly), on scales other than 1 and a set-point slope other than 0. With
/// `pu = n/(r0 scales.speed)` (m/s at the rim to motor-speed pu) and `half` half a
/// motor-speed code in pu: thresholds `slip_on pu + half`, `slip_accel pu + half`; the
/// acceleration ratio `accel_on pu / (current_ref_rate / scales.current)`; set point
/// halves `slip_sp pu / 2` and `slip_sp_per_a scales.current pu / 2`; gains as `c 2^s`,
/// `kp' = kp/(pu scales.current)`, `ki' = ki/(pu current_ref_rate)`; the lead's
/// `rho = (w1 - w1')/(w2 - w1)`; the reference code scale `v_ref_lsb pu`.
#[test]
fn every_compiled_quantity_is_its_formula() {
    let mut c = cfg();
    c.scales.speed = 1500.0;
    c.scales.current = 800.0;
    c.wsp.slip_sp_per_a = 2e-4;
    c.wire.speed = 0.01;
    let p = c.wsp;
    let w = Wsp::<f64>::try_new(&p, &c.motor, &c.scales, &c.limits, c.wire.speed, &c.lead)
        .unwrap()
        .to_bits();
    let pu = c.motor.n / (p.r0_m * c.scales.speed);
    let half = 0.5 * c.wire.speed / c.scales.speed;
    let split = |g: f64, s: u8| g / f64::from(1u32 << s);
    let close = |got: u64, want: f64, what: &str| {
        let got = f64::from_bits(got);
        assert!(
            (got - want).abs() <= 1e-12 * want.abs(),
            "{what}: {got} vs {want}"
        );
    };
    close(w.slip_on, p.slip_on_mps * pu + half, "slip_on");
    close(w.slip_accel, p.slip_accel_mps * pu + half, "slip_accel");
    let slew = c.limits.current_ref_rate / c.scales.current;
    close(w.accel_ratio, p.accel_on_mps2 * pu / slew, "accel_ratio");
    close(w.cut, p.cut_fraction, "cut");
    close(w.sp_half, 0.5 * p.slip_sp_mps * pu, "sp_half");
    let slope = 0.5 * p.slip_sp_per_a * c.scales.current * pu;
    close(w.sp_half_slope, slope, "sp_half_slope");
    let kp = p.kp_a_per_mps / (pu * c.scales.current);
    close(w.kp, split(kp, w.kp_shift), "kp");
    assert!(f64::from_bits(w.kp) < 1.0 && (w.kp_shift == 0 || f64::from_bits(w.kp) >= 0.5));
    let ki = p.ki_a_per_s_per_mps / (pu * c.limits.current_ref_rate);
    close(w.ki, split(ki, w.ki_shift), "ki");
    assert!(f64::from_bits(w.ki) < 1.0 && (w.ki_shift == 0 || f64::from_bits(w.ki) >= 0.5));
    let l = c.lead;
    close(
        w.lead_rho,
        (l.w1 - p.lead_w1_rad_s) / (l.w2 - l.w1),
        "lead_rho",
    );
    close(w.v_ref.mul, p.v_ref_lsb_m_per_s * pu, "v_ref");
}

/// The scheduled lead's `rho = (w1 - w1')/(w2 - w1)` must be below 1 in magnitude in every
/// build: with the lead's corners at 200 and 274 rad/s, `w1' = 126` gives exactly 1 and is
/// refused by name (a float build would hold it).
#[test]
fn a_scheduled_lead_rho_of_one_is_refused() {
    let mut c = cfg();
    c.lead.w1 = 200.0;
    c.wsp.lead_w1_rad_s = 126.0;
    match Controller::<f64>::try_new(&c) {
        Err(ConfigError::Coefficient { name, value }) => {
            assert_eq!((name, value), ("wsp lead rho = (w1 - w1')/(w2 - w1)", 1.0));
        }
        other => panic!("{other:?}"),
    }
    c.wsp.lead_w1_rad_s = 127.0;
    assert!(Controller::<f64>::try_new(&c).is_ok());
}

/// Detection is strictly above each threshold (a code-quantised slip never lands on one:
/// they sit half a code above; the `f64` build can be placed on them): a slip exactly at
/// `slip_on` with no acceleration, exactly at `slip_accel` with a fast acceleration, and
/// between them with the acceleration exactly at `accel_ratio x step`, are not detected;
/// the next value up is.
#[test]
fn detection_is_strictly_above_each_threshold() {
    let c = cfg();
    let w = wsp_f64(&c).unwrap();
    let b = w.to_bits();
    let (on, accel, ratio) = (
        f64::from_bits(b.slip_on),
        f64::from_bits(b.slip_accel),
        f64::from_bits(b.accel_ratio),
    );
    let iref = 0.5;
    // Idle, reference `w_ref`, speed `speed` after `prev`, slew `step`: detected?
    let detects = |w_ref: f64, speed: f64, prev: f64, step: f64| {
        let mut st = WspState {
            w_ref,
            w_prev: prev,
            ..WspState::default()
        };
        w.process(&mut st, speed, iref, step).1
    };
    // A reference equal to the slip: `2s - s` is `s` exactly.
    assert!(!detects(on, 2.0 * on, 2.0 * on, 1e-3));
    assert!(detects(
        on,
        (2.0 * on).next_up(),
        (2.0 * on).next_up(),
        1e-3
    ));
    let fast = 1.0; // an acceleration far above accel_ratio x step
    assert!(!detects(accel, 2.0 * accel, 2.0 * accel - fast, 1e-3));
    assert!(detects(
        accel,
        (2.0 * accel).next_up(),
        2.0 * accel - fast,
        1e-3
    ));
    // Between the thresholds, from rest (dw = speed): the step whose product with the
    // ratio is exactly the acceleration.
    let s = 0.5 * (on + accel);
    let speed = s + s;
    let mut step = speed / ratio;
    while step * ratio > speed {
        step = step.next_down();
    }
    while step * ratio < speed {
        step = step.next_up();
    }
    assert_eq!(step * ratio, speed, "no step lands on the acceleration");
    assert!(!detects(s, speed, 0.0, step));
    assert!(detects(s, speed, 0.0, step.next_down()));
    // No traction demand (a zero reference current): a slip is not the motor's to cut.
    let mut st = WspState {
        w_ref: on,
        w_prev: 4.0 * on,
        ..WspState::default()
    };
    assert!(!w.process(&mut st, 4.0 * on, 0.0, 1e-3).1);
}

/// A reference-speed LSB too fine for the fixed-point code scale is refused by name, with
/// the factor it needed (`v_ref_lsb n/(r0 scales.speed)`, pu per code).
#[test]
fn a_reference_lsb_the_code_scale_cannot_hold_is_refused() {
    let mut c = cfg();
    c.wsp.v_ref_lsb_m_per_s = 1e-30;
    let want = 1e-30 * c.motor.n / (c.wsp.r0_m * c.scales.speed);
    match Controller::<Fx>::try_new(&c) {
        Err(ConfigError::Coefficient { name, value }) => {
            assert_eq!(name, "wsp v_ref lsb n/(r0 scales.speed)");
            assert!((value - want).abs() <= 1e-12 * want, "{value} vs {want}");
        }
        other => panic!("{other:?}"),
    }
}

/// The set point's slope coefficient `slip_sp_per_a scales.current pu / 2` must be below
/// 1: scales chosen so it is exactly 1 (`pu = 5 / (0.5 x 1.25) = 8`, `2^-12 x 1024 x 8 /
/// 2`) are refused by name in a float build.
#[test]
fn a_set_point_slope_of_one_is_refused() {
    let mut c = cfg();
    c.motor.n = 5.0;
    c.wsp.r0_m = 0.5;
    c.scales.speed = 1.25;
    c.scales.current = 1024.0;
    c.wsp.slip_on_mps = 0.05;
    c.wsp.slip_accel_mps = 0.01;
    c.wsp.slip_sp_mps = 0.02;
    c.wsp.slip_sp_per_a = 1.0 / 4096.0;
    c.wire.speed = 0.01;
    match wsp_f64(&c) {
        Err(ConfigError::Coefficient { name, value }) => {
            assert_eq!(
                (name, value),
                ("wsp slip_sp_per_a scales.current n/r0 / 2", 1.0)
            );
        }
        other => panic!("{other:?}"),
    }
}

/// The protection compiled alone from `c`, in `f64`.
fn wsp_f64(c: &Config) -> Result<Wsp<f64>, ConfigError> {
    Wsp::try_new(
        &c.wsp,
        &c.motor,
        &c.scales,
        &c.limits,
        c.wire.speed,
        &c.lead,
    )
}
