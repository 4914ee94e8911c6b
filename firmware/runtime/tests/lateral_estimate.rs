//! The `y'` the control core is given from each kind of Sensor lateral (crate docs, fault
//! policy item 1 and `Lateral::Both`), stated as equivalences with a device sent the
//! plain velocity, tick for tick:
//!
//! - `Both` with `y''` = 0 and a constant `y'` is that `y'` exactly: the complementary
//!   filter starts from the measured `y'` and washes out towards it, with nothing to
//!   integrate;
//! - with the wash-out off (`acc_washout_s` = 0) `Both` is `y'` as it is, every frame;
//! - an acceleration-only frame continues from the latest measured `y'` (the velocity
//!   frame re-seeds the integrator): with `y''` = 0 and no wash-out it stays that `y'`.

use wheelset_control::{Fx, YawMode};
use wheelset_proto::*;
use wheelset_runtime::*;

mod common;
use common::{act, sample, sensor_frame};

/// Pure gain yaw law without the predictor: the torque is `K y'` of the `y'` the core was
/// given, so equal torques tick for tick mean equal `y'`.
fn gain(washout_s: f64) -> Runtime<Fx> {
    let mut cfg = RuntimeConfig::default();
    cfg.control.yaw_mode = YawMode::Gain;
    cfg.control.yaw_predict_ticks = 0.0;
    cfg.acc_washout_s = washout_s;
    Runtime::try_new(cfg).expect("valid")
}

fn sent(seq: u16, lateral: Lateral) -> Vec<u8> {
    sensor_frame(sample(seq, lateral))
}

/// The torques of `ticks` ticks, one frame a tick from `lateral(k)`.
fn torques(mut r: Runtime<Fx>, ticks: u16, lateral: impl Fn(u16) -> Lateral) -> Vec<i32> {
    (1..=ticks)
        .map(|k| {
            r.receive(&sent(k, lateral(k)));
            act(r.tick(0)).t_psi_dnm
        })
        .collect()
}

/// 3 mm/s: its torque (`K y'`, 1.05e5 N m s/m: 315 N m) is far from zero's.
const Y_UM_S: i32 = 3_000;

#[test]
fn both_with_no_acceleration_is_the_measured_velocity() {
    let velocity = torques(gain(DEFAULT_ACC_WASHOUT_S), 200, |_| {
        Lateral::Velocity(Y_UM_S)
    });
    let both = torques(gain(DEFAULT_ACC_WASHOUT_S), 200, |_| Lateral::Both {
        vel_um_s: Y_UM_S,
        acc_dmm_s2: 0,
    });
    assert_eq!(both, velocity);
    let still = torques(gain(DEFAULT_ACC_WASHOUT_S), 1, |_| Lateral::Velocity(0));
    assert_ne!(velocity[0], still[0], "the velocity moves the torque");
}

#[test]
fn without_the_washout_both_is_the_measured_velocity_as_it_is() {
    // A `y'` that changes every frame, and a `y''` that does not agree with it: without
    // a crossover, only `y'` counts.
    let y = |k: u16| Y_UM_S + 100 * i32::from(k % 7);
    let velocity = torques(gain(0.0), 50, |k| Lateral::Velocity(y(k)));
    let both = torques(gain(0.0), 50, |k| Lateral::Both {
        vel_um_s: y(k),
        acc_dmm_s2: 1_000,
    });
    assert_eq!(both, velocity);
}

#[test]
fn acceleration_frames_continue_from_the_measured_velocity() {
    // Five velocity frames, then frames with only `y''` = 0: no wash-out, nothing to
    // integrate, so the estimate is the last measured `y'` on every tick.
    let lateral = |k: u16| {
        if k <= 5 {
            Lateral::Velocity(Y_UM_S)
        } else {
            Lateral::Acceleration(0)
        }
    };
    let continued = torques(gain(0.0), 40, lateral);
    let velocity = torques(gain(0.0), 40, |_| Lateral::Velocity(Y_UM_S));
    assert_eq!(continued, velocity);
}
