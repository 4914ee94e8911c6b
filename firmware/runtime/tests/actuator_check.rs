//! The stability monitor's actuator check on the device (`wheelset_control::monitor`):
//! it judges the lateral response only **while the yaw law is commanding** (an active
//! mode, outputs enabled, not in the safe state); an alarm it raises is counted as an
//! actuator alarm (not a hunting or drive one) and latches the fault; and a traction
//! change (the current reference the PI follows moving by more than the monitor's level
//! over a block) quiets it for its quiet blocks.
//!
//! The signal: a lateral velocity held at 30 mm/s, above the check's drift level
//! (`MonitorParams::act_drift_m_s`, 25 mm/s), which counts as growth at every block end
//! once the low-passed `y'` has settled there; as a constant it has no band-passed
//! energy, so the hunting alarm stays down.

use wheelset_control::{Fx, MonitorParams};
use wheelset_proto::*;
use wheelset_runtime::*;

mod common;
use common::{frame, frames, sample, sensor_frame};

const DRIFT_UM_S: i32 = 30_000;
/// 1 s at 5 kHz: ten blocks of the check.
const TICKS: u32 = 5_000;

fn config(mode: YawMode, enable: bool, wsp: bool) -> Vec<u8> {
    frame(&Message::Config(Config {
        mode,
        traction: true,
        enable,
        hold_ticks: DEFAULT_HOLD_TICKS,
        wsp,
        monitor_safe: false,
        rates: None,
    }))
}

/// A frame with `y'` at the drift level; `v_ref_mm_s` the reference speed (0: unknown),
/// `demand_nm` the traction demand.
fn drifting(k: u32, v_ref_mm_s: i32, demand_nm: i32) -> Vec<u8> {
    sensor_frame(Sensor {
        v_ref_mm_s,
        demand_nm,
        ..sample(k as u16, Lateral::Velocity(DRIFT_UM_S))
    })
}

/// What a run of `TICKS` ticks on drifting frames shows: the first tick flagged
/// `ACTUATOR_FAULT`, whether any was flagged `HUNTING`, the ticks flagged `WHEEL_SLIP`,
/// and the Status after it.
struct Seen {
    actuator_at: Option<u32>,
    hunting: bool,
    slipping_ticks: u32,
    status: Status,
    last: Option<Actuation>,
}

fn run(r: &mut Runtime<Fx>, v_ref_mm_s: i32) -> Seen {
    run_at(r, v_ref_mm_s, sample(0, Lateral::Velocity(0)).demand_nm)
}

/// As [`run`], with the traction demand `demand_nm`.
fn run_at(r: &mut Runtime<Fx>, v_ref_mm_s: i32, demand_nm: i32) -> Seen {
    let mut seen = Seen {
        actuator_at: None,
        hunting: false,
        slipping_ticks: 0,
        status: Status::default(),
        last: None,
    };
    for k in 1..=TICKS {
        if k == TICKS {
            r.receive(&frame(&Message::Command(Command::RequestStatus)));
        }
        r.receive(&drifting(k, v_ref_mm_s, demand_nm));
        let out = frames(r.tick(0));
        let a = match out.first() {
            Some(Message::Actuation(a)) => *a,
            other => panic!("expected an actuation frame, got {other:?}"),
        };
        if a.flags.has(Flags::ACTUATOR_FAULT) && seen.actuator_at.is_none() {
            seen.actuator_at = Some(k);
        }
        seen.hunting |= a.flags.has(Flags::HUNTING);
        seen.slipping_ticks += u32::from(a.flags.has(Flags::WHEEL_SLIP));
        if let Some(Message::Status(s)) = out.get(1) {
            seen.status = *s;
        }
        seen.last = Some(a);
    }
    seen
}

fn runtime() -> Runtime<Fx> {
    Runtime::try_new(RuntimeConfig::default()).expect("the default runs")
}

#[test]
fn a_drift_while_commanding_raises_the_actuator_alarm_alone() {
    let p = MonitorParams::default();
    assert!(f64::from(DRIFT_UM_S) * 1e-6 > p.act_drift_m_s);
    let mut r = runtime();
    let seen = run(&mut r, 0);
    let at = seen
        .actuator_at
        .expect("the drift raises the actuator alarm");
    // Not before the check's `act_blocks` blocks of growth have passed.
    let block_ticks = (p.act_block_s * 5_000.0) as u32;
    assert!(at > u32::from(p.act_blocks) * block_ticks, "{at}");
    assert!(!seen.hunting, "a constant has no band-passed energy");
    let s = seen.status;
    assert_eq!((s.act_alarms, s.hunt_alarms, s.drive_alarms), (1, 0, 0));
    assert_eq!(
        s.first_alarm_tick, at,
        "the runtime's tick count at the rise"
    );
    assert_eq!(s.first_drive_alarm_tick, 0, "no drive alarm: none recorded");
    assert!(seen.last.is_some_and(|a| a.flags.has(Flags::FAULT_LATCHED)));
}

#[test]
fn no_check_while_the_yaw_law_is_not_commanding() {
    // The passive law: the device commands no yaw torque.
    let mut passive = runtime();
    passive.receive(&config(YawMode::Passive, true, true));
    // Outputs disabled, in the active mode.
    let mut disabled = runtime();
    disabled.receive(&config(YawMode::Lead, false, true));
    // The safe state held by a boot after a watchdog reset, frames arriving.
    let mut safe = runtime();
    safe.set_boot(1, reset_cause::WATCHDOG);
    for (what, r) in [
        ("passive", &mut passive),
        ("disabled", &mut disabled),
        ("safe", &mut safe),
    ] {
        let seen = run(r, 0);
        assert_eq!(seen.actuator_at, None, "{what}");
        assert_eq!(seen.status.act_alarms, 0, "{what}");
    }
    // The same runtimes commanding again check again: the drift is caught.
    passive.receive(&config(YawMode::Lead, true, true));
    disabled.receive(&config(YawMode::Lead, true, true));
    for (what, r) in [("passive", &mut passive), ("disabled", &mut disabled)] {
        assert!(run(r, 0).actuator_at.is_some(), "{what}");
    }
}

/// The demand's reference ramps from 0 to 115 A (2 460 N m through `n K_m`) in the first
/// block: a traction change above the monitor's 50 A, so that block end and the next are
/// not judged and the alarm comes those blocks later than with no demand (no change).
#[test]
fn a_traction_change_quiets_the_check_for_its_blocks() {
    let p = MonitorParams::default();
    let block_ticks = (p.act_block_s * 5_000.0) as u32;
    let still = run_at(&mut runtime(), 0, 0).actuator_at.expect("raised");
    let stepped = run(&mut runtime(), 0).actuator_at.expect("raised after");
    let quiet = u32::from(wheelset_control::QUIET_BLOCKS);
    assert!(
        stepped > still && stepped <= still + quiet * block_ticks,
        "{stepped} vs {still}"
    );
    // A demand whose reference moves by less than the level in its block: judged.
    let small = run_at(&mut runtime(), 0, 800).actuator_at.expect("raised");
    assert_eq!(small, still);
}
