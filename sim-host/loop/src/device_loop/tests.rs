//! Unit tests of the in-process device (`super`): moved out of `device.rs` unchanged.

use super::*;
use crate::exchange::DeviceController;
use wheelset_plant::control::{Measurements, SampledController};

/// `run` against `reference` record by record ([`DeviationAcc`]).
fn deviation(run: &Trajectory, reference: &Trajectory, windows: [(f64, f64); 2]) -> Deviation {
    let mut acc = DeviationAcc::new(windows);
    for (a, b) in run.records.iter().zip(&reference.records) {
        acc.push(a, b);
    }
    acc.finish()
}

fn sample(k: u64) -> Measurements {
    Measurements {
        yd_mps: 1e-3 * ((k as f64) * 0.01).sin(),
        w_m: 925.6,
        ..Measurements::default()
    }
}

/// `periods` exchanges of a synthetic sample through the in-process device, then the
/// status fetch; the link log and the report.
fn run_seeded(faults: &str, periods: u64, seed: u64) -> (Vec<LinkSample>, LinkReport) {
    let link = LinkConfig {
        faults: faults.parse().expect("valid spec"),
        seed,
        ..LinkConfig::default()
    };
    let mut d =
        InProc::<Fx>::try_new(RuntimeConfig::default(), &link, DeviceFault::None).expect("fits");
    let t = d.period_ns();
    let mut c = DeviceController::new(
        &mut d,
        4.28,
        LoopSetup {
            period_ns: t,
            ..LoopSetup::default()
        },
    );
    for k in 0..periods {
        let _ = c.step(k * t, &sample(k));
    }
    c.finish(periods * t);
    let rec = std::mem::take(&mut c.rec);
    drop(c);
    let r = LinkReport::of(&rec, d.accounting());
    (rec.log, r)
}

fn run(faults: &str, periods: u64) -> (Vec<LinkSample>, LinkReport) {
    run_seeded(faults, periods, 11)
}

#[test]
fn clean_link_echoes_every_sample_within_the_period() {
    let (log, r) = run("", 2000);
    assert!(log
        .iter()
        .all(|s| s.fresh && s.age == 0 && s.seq_echo == s.seq));
    // 2000 sensor frames + the status request; 2000 actuations, then the fetch's
    // three periods: 3 actuations and the status frame.
    assert_eq!((r.up.received, r.up.rejected, r.up.dropped), (2001, 0, 0));
    assert_eq!(
        (r.down.received, r.down.rejected, r.down.dropped),
        (2004, 0, 0)
    );
    let st = r.device.expect("status arrives on a clean link");
    assert_eq!(st.rx_ok, 2001);
    assert_eq!(st.safe_entries, 0);
    // Typical frames: within the proto's measured sizes.
    assert!(r.mean_bytes.0 <= 23.0 && r.mean_bytes.1 <= 20.5, "{r}");
}

#[test]
fn faults_are_accounted_and_the_outage_trips_the_safe_state() {
    for seed in 1..=10 {
        faults_seed(seed);
    }
}

fn faults_seed(seed: u64) {
    // 5 kHz: 2 s = 10 000 periods; the outage at 1 s for 50 ms.
    let (log, r) = run_seeded("ber=1e-3,drop=0.1,outage=1.0:0.05", 10_000, seed);
    println!("{r}");
    assert!(r.up.adds_up() && r.down.adds_up(), "{r}");
    // Nothing left up; down, at most the Actuation that arrived behind the Status in
    // its period (not counted: after the Status; a longer Status since wire
    // version 2).
    assert!(r.up.in_flight == 0 && r.down.in_flight <= 1, "{r}");
    assert!(
        r.up.rejected > 0 && r.up.dropped >= r.up.link_dropped_whole,
        "{r}"
    );
    // The outage cuts both directions, so whether an actuation frame flagged SAFE
    // reaches the host is down to the seed: the device's own counters (read back
    // after the run) are the evidence that it entered and left the safe state.
    let st = r.device.expect("status read back after the run");
    assert_eq!(u64::from(st.rx_ok), r.up.received, "{r}");
    assert!(st.safe_entries >= 1 && st.safe_exits >= 1, "{r}");
    assert!(st.safe_ticks >= 200, "{r}");
    // Frame age grows during the outage and returns to 0 after it.
    let max_age = log.iter().map(|s| s.age).max().unwrap_or(0);
    assert!(max_age >= 250, "max age {max_age}");
    // (Any single exchange may fail: 10 % drops and BER 1e-3 on ~200 bits each
    // way leave roughly (0.9 x 0.82)^2 = 54 % of round trips intact.) After the
    // outage, i.e. from 1.06 s on, fresh actuation is common again and no gap
    // comes near the outage's 250 periods.
    let after = &log[5300..];
    let fresh = after.iter().filter(|s| s.age == 0).count();
    assert!(fresh * 5 >= after.len() * 2, "{fresh} of {}", after.len());
    let worst = after.iter().map(|s| s.age).max().unwrap_or(0);
    assert!(worst < 50, "stale for {worst} periods after the outage");
}

#[test]
fn a_sensor_outage_puts_the_safe_outputs_on_the_plant() {
    // Only host -> device is cut: the device's safe state reaches the plant.
    let (log, r) = run("outage=1.0:0.05:up", 10_000);
    let hold = u64::from(wheelset_runtime::DEFAULT_HOLD_TICKS);
    // 250 periods without a sensor frame: `hold` on the held sample, the rest safe.
    assert_eq!(r.safe_periods, 250 - hold, "{r}");
    assert_eq!((r.safe_entries_seen, r.safe_exits_seen), (1, 1), "{r}");
    let st = r.device.expect("status");
    assert_eq!((st.safe_entries, st.safe_exits), (1, 1));
    // Every tick without a new sample runs on the held one, in the safe state too
    // (the runtime's HOLDING rule): the 250 of the outage, +1 for the tick that
    // answers the status request.
    assert_eq!(st.held_ticks as u64, 250 + 1);
    assert_eq!(r.up.dropped, 250, "{r}");
    assert_eq!(r.down.received, r.down.sent, "{r}");
    assert!(log.iter().filter(|s| s.age > 0).count() as u64 == 250);
}

#[test]
fn a_link_too_slow_is_refused() {
    let link = LinkConfig {
        baud: 115_200,
        ..LinkConfig::default()
    };
    let e = InProc::<Fx>::try_new(RuntimeConfig::default(), &link, DeviceFault::None)
        .err()
        .expect("refused");
    let msg = e.to_string();
    assert!(matches!(e, DeviceError::Budget(_)), "{msg}");
    assert!(
        msg.contains("115200 baud") && msg.contains("5000 Hz"),
        "{msg}"
    );
}

/// The reference streamed through [`DeviationAcc`] gives the deviation of the kept
/// trajectories, and its records are the kept run's.
#[test]
fn a_streamed_reference_deviates_as_the_kept_one() {
    use wheelset_plant::control::ContinuousController;
    use wheelset_plant::sim::{run_continuous, run_continuous_each};
    let mut sc = Scenario::load("curve", &wheelset_plant::params::Params::default())
        .expect("built-in scenario");
    sc.duration_ns = 6_000_000_000;
    let run = run_continuous(&sc, YawLaw::Passive);
    let kept = run_continuous(&sc, YawLaw::Lead);
    let windows = [(1.0, 2.0), (4.5, 5.5)];
    let expected = deviation(&run, &kept, windows);
    assert!(expected.f_max_abs_n > 0.0 && expected.windows[1].y_rel > 0.0);

    let mut acc = DeviationAcc::new(windows);
    let mut mine = run.records.iter();
    let mut streamed = Vec::new();
    let info = run_continuous_each(
        &sc,
        ContinuousController::new(&sc.params, YawLaw::Lead),
        |r| {
            if let Some(a) = mine.next() {
                acc.push(a, &r);
            }
            streamed.push(r);
        },
    );
    assert_eq!(acc.finish(), expected);
    assert_eq!(streamed, kept.records);
    assert_eq!(info.steps, kept.info.steps);
}

/// The default runtime runs; a rate below the monitor's and a rate without designed gains
/// are refused in words about the rate.
#[test]
fn a_refused_base_rate_is_named_by_the_rate() {
    let mut rt = RuntimeConfig::default();
    assert_eq!(base_rate_refusal(&rt), None);
    rt.control.base_rate_hz = 50;
    let why = base_rate_refusal(&rt).unwrap_or_default();
    assert!(why.contains("at least 500 Hz"), "{why}");
    rt.control.base_rate_hz = 4_000;
    let why = base_rate_refusal(&rt).unwrap_or_default();
    assert!(why.contains("no gains are designed for 4000 Hz"), "{why}");
}
