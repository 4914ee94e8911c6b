//! Wheel-slip protection: validation, exact bits, the law's phases (detect and cut,
//! working band, probe, release), the switch and the flag, and the fixed-point and f32
//! builds against the f64 reference on the same inputs.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use wheelset_control::{
    Compiled, Config, ConfigError, Controller, F32Controller, F64Controller, FixedController, Fx,
    Inputs, Sample, SampleBits, WspParams,
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
    let cases: [(&str, Spoil); 6] = [
        ("wsp.slip_hold_mps", |p| p.slip_hold_mps = p.slip_on_mps),
        ("wsp.slip_target_mps", |p| {
            p.slip_target_mps = p.slip_hold_mps
        }),
        ("wsp.reapply_a_per_s", |p| p.reapply_a_per_s = 3e4),
        ("wsp.accel_on_mps2", |p| p.accel_on_mps2 = f64::NAN),
        ("wsp.r0_m", |p| p.r0_m = 0.0),
        ("wsp.probe_after_s", |p| p.probe_after_s = 10.0),
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
    let mut c = cfg();
    c.wsp.cut_fraction = 1.0;
    assert!(matches!(
        F64Controller::try_new(&c),
        Err(ConfigError::Coefficient { .. })
    ));
}

#[test]
fn bits_round_trip_and_invalid_bits_are_refused() {
    let c = cfg();
    let law = Compiled::<Fx>::try_new(&c).unwrap();
    let b = law.to_bits();
    assert_eq!(Compiled::<Fx>::from_bits(&b).unwrap(), law);
    assert_eq!(Compiled::<Fx>::from_valid_bits(&b), law);
    let mut bad = b;
    bad.wsp.slip_target = bad.wsp.slip_hold;
    assert_eq!(
        Compiled::<Fx>::from_bits(&bad).unwrap_err().field,
        "wsp.slip_target"
    );
    let mut bad = b;
    bad.wsp.cut = 0;
    assert_eq!(
        Compiled::<Fx>::from_bits(&bad).unwrap_err().field,
        "wsp.cut"
    );
    // The protection's parameters are part of the fingerprint.
    let mut other = c;
    other.wsp.slip_on_mps = 0.5;
    let b2 = Compiled::<Fx>::try_new(&other).unwrap().to_bits();
    assert_ne!(b.fingerprint(), b2.fingerprint());
    let f = Compiled::<f32>::try_new(&c).unwrap();
    assert_eq!(Compiled::<f32>::from_bits(&f.to_bits()).unwrap(), f);
}

#[test]
fn a_rolling_wheel_is_left_alone_and_a_slip_is_cut_at_once() {
    let c = cfg();
    let mut k = F64Controller::try_new(&c).unwrap();
    // 0.1 m/s of slip (dry rail at full demand needs 0.17): nothing happens.
    run(&mut k, &c, 0.1, 12_400.0, 500);
    assert!(!k.wheel_slip());
    assert_eq!(k.counters().wsp_events, 0);
    let iref = k.current_ref().to_f64() * 1000.0;
    assert!(iref > 500.0, "reference {iref} A");
    // 0.4 m/s: detected on the first step, the cap is half the reference.
    run(&mut k, &c, 0.4, 12_400.0, 1);
    assert!(k.wheel_slip());
    assert_eq!(k.counters().wsp_events, 1);
    let cap = iref_a(&k);
    assert!(cap < 0.5 * iref + 10.0, "cap {cap} A after the cut");
    // Still above the band: cut at twice the slew, to zero in bounded time.
    run(&mut k, &c, 0.4, 12_400.0, 200);
    assert!(iref_a(&k) < 1e-6);
    assert_eq!(k.counters().wsp_events, 1, "one event, however long");
    assert_eq!(k.counters().wsp_ticks, 201);
}

#[test]
fn working_band_holds_reapplies_probes_and_releases() {
    let c = cfg();
    let mut k = F64Controller::try_new(&c).unwrap();
    run(&mut k, &c, 0.0, 12_400.0, 500);
    run(&mut k, &c, 0.4, 12_400.0, 1);
    let cap0 = iref_a(&k);
    // In the band (0.045 m/s): held, and after 0.8 s calm the probe starts.
    run(&mut k, &c, 0.045, 12_400.0, 100);
    assert!((iref_a(&k) - cap0).abs() < 1e-9, "held");
    // Below the target: re-applied at 1500 A/s (0.3 A per 5 kHz tick).
    run(&mut k, &c, 0.0, 12_400.0, 100);
    let up = iref_a(&k) - cap0;
    assert!((up - 30.0).abs() < 0.1, "re-applied {up} A in 100 ticks");
    // Calm for 0.8 s (4000 ticks with the 200 above): probing re-applies even inside
    // the band.
    run(&mut k, &c, 0.045, 12_400.0, 3700);
    assert!(!k.wsp_state().probing);
    let before = iref_a(&k);
    run(&mut k, &c, 0.045, 12_400.0, 200);
    assert!(k.wsp_state().probing);
    assert!(iref_a(&k) > before + 20.0, "probing");
    // A slip while probing: cut again, back to the band.
    run(&mut k, &c, 0.4, 12_400.0, 1);
    assert!(!k.wsp_state().probing && k.wsp_state().active);
    assert_eq!(k.counters().wsp_events, 1);
    // The rail carries the demand again: re-applied, released, the flag drops.
    run(&mut k, &c, 0.0, 12_400.0, 20_000);
    assert!(!k.wheel_slip());
    assert!(!k.wsp_state().active);
    assert_eq!(k.counters().wsp_events, 1);
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
    // Default configuration: off.
    c.wsp = WspParams::default();
    assert!(!F64Controller::try_new(&c).unwrap().wsp_enabled());
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
    let mut differ = 0u32;
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
        // Mean difference of the cap over the run (a crossing a tick apart makes one
        // tick differ by the cut, 290 A; the mean shows any drift).
        worst += (iref_a(&a) - iref_a(&b)) * s.current / 1000.0 / 20_000.0;
    }
    assert!(
        differ <= 4,
        "{}: the flag differs on {differ} ticks",
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
    // A threshold crossing can land one tick apart (the quantised slip against the
    // quantised threshold): one re-apply step is 0.3 A; allow a few.
    agree::<Fx>(1.0);
    agree::<f32>(1.0);
    // The FixedController alias is the production type.
    let _ = FixedController::try_new(&cfg()).unwrap();
    let _ = F32Controller::try_new(&cfg()).unwrap();
}

/// The tick (counted from the first calm one) on which the protection starts probing,
/// after a detection at 0.3 m/s and then a calm slip in the band (0.045 m/s).
fn probe_tick<T: Sample>(c: &Config) -> u32 {
    let mut ctl = Controller::<T>::try_new(c).unwrap();
    run(&mut ctl, c, 0.3, 12_400.0, 50);
    assert!(ctl.wheel_slip() && !ctl.wsp_state().probing);
    let (inp, w_ref) = at::<T>(c, 0.045, 12_400.0);
    ctl.set_v_ref(w_ref);
    for k in 1..=20_000u32 {
        ctl.tick(&inp);
        if ctl.wsp_state().probing {
            return k;
        }
    }
    panic!("{}: no probing after 4 s of calm", T::NAME);
}

#[test]
fn every_build_starts_probing_on_the_same_tick() {
    // The probe timer sums `probe_after / T` re-apply steps: an integer count (4 000 at
    // the 5 kHz traction rate), so the level `r_up probe_after` is where the sum lands
    // and the rounding of the sum decided the tick (Q4.28 one step before f64). The level
    // half a step below makes the count exact in every build.
    let c = cfg();
    let base = c.base_rate_hz as f64;
    let steps = (c.wsp.probe_after_s / c.traction_period()).round() as u32;
    assert!(steps > 100, "{steps}");
    // Ticks are base ticks; the traction step runs every `traction_divisor` of them.
    let per = (c.traction_period() * base).round() as u32;
    let f64_tick = probe_tick::<f64>(&c);
    assert_eq!(probe_tick::<Fx>(&c), f64_tick, "Q4.28 against f64");
    assert_eq!(probe_tick::<f32>(&c), f64_tick, "f32 against f64");
    // `probe_after` of calm: `steps` traction steps (within one step of the phase).
    assert!(
        f64_tick.abs_diff(steps * per) <= per,
        "{f64_tick} vs {}",
        steps * per
    );
}

/// The tick (counted from the first tick without slip) on which the protection releases,
/// after a detection at 0.3 m/s cut the cap to zero and the rail then carries the wheel
/// again (no slip: re-applied at `r_up` up to the reference), at demand `demand` N m.
fn release_tick<T: Sample>(c: &Config, demand: f64) -> u32 {
    let mut ctl = Controller::<T>::try_new(c).unwrap();
    run(&mut ctl, c, 0.0, demand, 5_000);
    run(&mut ctl, c, 0.3, demand, 100);
    assert!(ctl.wheel_slip() && ctl.wsp_state().cap.to_f64() == 0.0);
    let (inp, w_ref) = at::<T>(c, 0.0, demand);
    ctl.set_v_ref(w_ref);
    for k in 1..=20_000u32 {
        ctl.tick(&inp);
        if !ctl.wheel_slip() {
            return k;
        }
    }
    panic!("{}: no release after 4 s of adhesion", T::NAME);
}

#[test]
fn every_build_releases_on_the_same_tick() {
    // Re-applied from zero, the cap sums re-apply steps onto the reference. Where the
    // reference is a whole number of steps (on `low-adhesion` 579.6 A = 1 932 x 0.3 A,
    // released at 11.0 s) the sum lands on it, and the test `cap >= i_ref` was decided
    // by the rounding of the sum: on the same inputs Q4.28 released a step after f64.
    // The level half a step below makes the count exact in every build.
    let c = cfg();
    let up = c.wsp.reapply_a_per_s * c.traction_period();
    let mut k = F64Controller::try_new(&c).unwrap();
    run(&mut k, &c, 0.0, 12_400.0, 5_000);
    let iref = k.current_ref().to_f64() * c.scales.current;
    let steps = (iref / up).round();
    // The demand whose reference is `steps` re-apply steps.
    let demand = 12_400.0 * steps * up / iref;
    let f64_tick = release_tick::<f64>(&c, demand);
    assert_eq!(
        release_tick::<Fx>(&c, demand),
        f64_tick,
        "Q4.28 against f64"
    );
    assert_eq!(release_tick::<f32>(&c, demand), f64_tick, "f32 against f64");
    // Released on the step that reaches the reference (within one step of the phase).
    let per = (c.traction_period() * c.base_rate_hz as f64).round() as u32;
    let n = steps as u32 * per;
    assert!(
        f64_tick.abs_diff(n) <= per,
        "{f64_tick} vs {n} (i_ref {iref} A)"
    );
}
