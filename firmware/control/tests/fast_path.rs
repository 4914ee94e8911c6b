//! The fast path of `Controller::tick` against the general path alone
//! (`set_fast_path(false)`): outputs, counters and every state bit for bit, in
//! fixed point, f32 and f64, over random and edge inputs (the clamp limits and one LSB
//! either side, the type's extremes, NaN for floats) and the supervisory changes
//! (safe state, law changes, traction off/on, presets) between ticks.

use proptest::prelude::*;
use wheelset_control::{Config, Controller, Counters, Fx, Inputs, Sample, YawMode};

/// One step of a scenario.
#[derive(Clone, Copy, Debug)]
enum Op {
    /// A tick with inputs picked by index from the edge table (or random, see `value`).
    Tick([u32; 4]),
    /// The same demand for `n` ticks with small random y' and current (the settled ramp).
    Hold(u32, u32),
    Safe(bool),
    Mode(u8),
    Traction(bool),
    ContinueFrom(u32),
    Preset(u32),
    /// The reference speed (`set_v_ref`): near the held speed, an edge or random value.
    VRef(u32),
    /// The wheel-slip protection on/off.
    Wsp(bool),
}

fn op() -> impl Strategy<Value = Op> {
    prop_oneof![
        8 => any::<[u32; 4]>().prop_map(Op::Tick),
        3 => (1u32..200, any::<u32>()).prop_map(|(n, s)| Op::Hold(n, s)),
        1 => any::<bool>().prop_map(Op::Safe),
        1 => (0u8..3).prop_map(Op::Mode),
        1 => any::<bool>().prop_map(Op::Traction),
        1 => any::<u32>().prop_map(Op::ContinueFrom),
        1 => any::<u32>().prop_map(Op::Preset),
        1 => any::<u32>().prop_map(Op::VRef),
        1 => any::<bool>().prop_map(Op::Wsp),
    ]
}

/// An input value in pu: the limits `lims` and one LSB-ish either side, 0, the type's
/// extremes, NaN, or a random value within +-2.5 pu (`r` picks).
fn value<T: Sample>(r: u32, lims: &[f64]) -> T {
    let k = r % 16;
    let frac = f64::from(r >> 4) / f64::from(u32::MAX >> 4);
    let lsb = 1.0 / (1u64 << 28) as f64;
    match k {
        0 => T::ZERO,
        1 => T::from_f64(f64::NAN),
        2 => T::from_f64(1e9),
        3 => T::from_f64(-1e9),
        4..=9 => {
            let l = lims[(r as usize >> 4) % lims.len()];
            let s = if k.is_multiple_of(2) { 1.0 } else { -1.0 };
            T::from_f64(s * l + [0.0, lsb, -lsb][(k as usize - 4) / 2])
        }
        _ => T::from_f64((frac * 2.0 - 1.0) * 2.5 * if k > 12 { 0.01 } else { 1.0 }),
    }
}

/// Everything observable and every state, exactly (`{:?}` of floats is exact and tells
/// -0 from +0).
fn snapshot<T: Sample>(c: &Controller<T>, out: &wheelset_control::Outputs<T>) -> String {
    format!(
        "{:?} {:?} {:?} {:?} {:?} {:?} {:?} {} {:?} {}",
        out,
        c.counters(),
        c.tick_events(),
        c.lead_state(),
        c.pi_state(),
        c.current_ref(),
        c.outputs(),
        c.is_safe(),
        c.wsp_state(),
        c.wheel_slip()
    )
}

/// The tick's event word is exactly what moved in the counters from `before` to `c`'s.
fn check_events<T: Sample>(before: &Counters, c: &Controller<T>) {
    let (a, ev) = (c.counters(), c.tick_events());
    let inputs = |k: &Counters| {
        [k.y_dot, k.current, k.speed, k.demand]
            .iter()
            .map(|s| u64::from(s.clamped) + u64::from(s.invalid))
            .sum::<u64>()
    };
    assert_eq!(
        ev.yaw_saturated(),
        a.yaw_torque.clamped != before.yaw_torque.clamped
    );
    assert_eq!(
        ev.traction_saturated(),
        a.voltage.clamped != before.voltage.clamped
    );
    assert_eq!(u64::from(ev.inputs()), inputs(a) - inputs(before));
    assert_eq!(ev.wsp_acting(), a.wsp_ticks != before.wsp_ticks);
    assert_eq!(ev.wsp_started(), a.wsp_events != before.wsp_events);
    let wsp_moved = a.wsp_ticks != before.wsp_ticks || a.wsp_events != before.wsp_events;
    let outputs_moved = (a.yaw_torque, a.voltage, a.integrator)
        != (before.yaw_torque, before.voltage, before.integrator);
    let clamps_moved = inputs(a) != inputs(before) || outputs_moved;
    assert_eq!(ev.any(), clamps_moved || wsp_moved);
}

fn run<T: Sample>(ops: &[Op]) -> usize {
    run_with::<T>(&Config::default(), ops)
}

/// [`run`] from the configuration `cfg` (e.g. the wheel-slip protection on at start).
fn run_with<T: Sample>(cfg: &Config, ops: &[Op]) -> usize {
    let mut fast = Controller::<T>::try_new(cfg).expect("valid config");
    let mut general = fast.clone();
    general.set_fast_path(false);
    assert!(!general.fast_path_armed());
    let lims = [1.0, 2.0, 0.02, 1.0, 0.6, 0.5, 2.0 / 4.28];
    let mut armed = 0;
    let mut step = |a: &mut Controller<T>, b: &mut Controller<T>, i: &Inputs<T>| {
        armed += usize::from(a.fast_path_armed());
        let (ka, kb) = (*a.counters(), *b.counters());
        let (oa, ob) = (a.tick(i), b.tick(i));
        check_events(&ka, a);
        check_events(&kb, b);
        assert_eq!(snapshot(a, &oa), snapshot(b, &ob), "inputs {i:?}");
    };
    for op in ops {
        match *op {
            Op::Tick(r) => {
                let i = Inputs {
                    y_dot: value(r[0], &lims),
                    current: value(r[1], &lims),
                    speed: value(r[2], &lims),
                    demand: value(r[3], &lims),
                };
                step(&mut fast, &mut general, &i);
            }
            Op::Hold(n, seed) => {
                let mut s = u64::from(seed) | 1;
                let demand = T::from_f64(f64::from(seed % 2000) / 1000.0 - 1.0);
                for _ in 0..n {
                    s ^= s << 13;
                    s ^= s >> 7;
                    s ^= s << 17;
                    let small = |v: u64| T::from_f64(((v % 20_001) as f64 - 10_000.0) * 1e-5);
                    let i = Inputs {
                        y_dot: small(s),
                        current: small(s >> 20),
                        speed: T::from_f64(0.9),
                        demand,
                    };
                    step(&mut fast, &mut general, &i);
                }
            }
            Op::Safe(on) => {
                fast.set_safe(on);
                general.set_safe(on);
            }
            Op::Mode(m) => {
                let m = [YawMode::Passive, YawMode::Gain, YawMode::Lead][usize::from(m)];
                fast.set_mode(m);
                general.set_mode(m);
            }
            Op::Traction(on) => {
                fast.set_traction(on);
                general.set_traction(on);
            }
            Op::ContinueFrom(r) => {
                let t = value::<T>(r, &lims);
                fast.continue_from(t);
                general.continue_from(t);
            }
            Op::Preset(r) => {
                let w = value::<T>(r, &lims);
                fast.preset_back_emf(w);
                general.preset_back_emf(w);
            }
            Op::VRef(r) => {
                // Near the held speed (0.9 pu): quiet, slipping by less or more than
                // the detection thresholds; else an edge or random value.
                let v = match r % 4 {
                    0 => T::from_f64(0.9),
                    1 => T::from_f64(0.9 - f64::from(r >> 2) / f64::from(u32::MAX >> 2) * 0.05),
                    _ => value::<T>(r >> 2, &lims),
                };
                fast.set_v_ref(v);
                general.set_v_ref(v);
            }
            Op::Wsp(on) => {
                fast.set_wsp(on);
                general.set_wsp(on);
            }
        }
    }
    armed
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]
    #[test]
    fn fixed_point_fast_path_is_the_general_path(ops in prop::collection::vec(op(), 1..60)) {
        run::<Fx>(&ops);
    }
    #[test]
    fn f32_fast_path_is_the_general_path(ops in prop::collection::vec(op(), 1..60)) {
        run::<f32>(&ops);
    }
    #[test]
    fn f64_fast_path_is_the_general_path(ops in prop::collection::vec(op(), 1..60)) {
        run::<f64>(&ops);
    }
    #[test]
    fn with_the_wheel_slip_protection_fixed_point_fast_path_is_the_general_path(
        ops in prop::collection::vec(op(), 1..60)
    ) {
        run_with::<Fx>(&wsp_config(), &ops);
    }
    #[test]
    fn with_the_wheel_slip_protection_f32_fast_path_is_the_general_path(
        ops in prop::collection::vec(op(), 1..60)
    ) {
        run_with::<f32>(&wsp_config(), &ops);
    }
}

/// The default configuration with the wheel-slip protection on at start.
fn wsp_config() -> Config {
    let mut cfg = Config::default();
    cfg.wsp.enabled = true;
    cfg
}

/// Normal running takes the fast path (so the tests above compare something): after the
/// first tick (the bumpless preset) every tick of a quiet run is armed for it.
#[test]
fn normal_running_arms_the_fast_path() {
    let ops = [Op::Hold(500, 7)];
    assert_eq!(run::<Fx>(&ops), 499);
    assert_eq!(run::<f32>(&ops), 499);
    let mut c = Controller::<Fx>::try_new(&Config::default()).expect("default config");
    c.tick(&Inputs::default());
    assert!(c.fast_path_armed());
    c.set_safe(true);
    assert!(!c.fast_path_armed(), "the safe state runs the general path");
}

/// With the wheel-slip protection on, a quiet run (reference speed at the wheel's) takes
/// the fast path, and a slip detected on it sends the ticks to the general path while
/// the protection acts (so the tests above compare both).
#[test]
fn with_the_protection_on_quiet_running_is_fast_and_a_slip_is_general() {
    let quiet = [Op::VRef(0), Op::Hold(500, 7)];
    assert_eq!(run_with::<Fx>(&wsp_config(), &quiet), 499);
    assert_eq!(run_with::<f32>(&wsp_config(), &quiet), 499);
    let mut c = Controller::<Fx>::try_new(&wsp_config()).expect("valid config");
    c.set_v_ref(Fx::from_f64(0.9));
    let i = |speed: f64| Inputs {
        y_dot: Fx::ZERO,
        current: Fx::ZERO,
        speed: Fx::from_f64(speed),
        demand: Fx::from_f64(0.5),
    };
    for _ in 0..50 {
        c.tick(&i(0.9));
    }
    assert!(c.fast_path_armed());
    assert!(!c.wheel_slip());
    // The wheel runs away from the reference: detected, acting, general path.
    c.tick(&i(1.2));
    assert!(c.wheel_slip() && c.wsp_state().active);
    assert!(
        !c.fast_path_armed(),
        "the acting protection runs the general path"
    );
}
