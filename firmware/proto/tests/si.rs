//! `Sensor::from_si` / `Actuation::to_si`: the one SI <-> wire conversion of the host.
//! (Needs the `std` feature; the workspace's host crates turn it on.)
#![cfg(feature = "std")]
#![allow(clippy::unwrap_used)]

use proptest::prelude::*;
use wheelset_proto::units::{
    quantize, to_si, CURRENT_LSB_A, DEMAND_LSB_NM, LAT_ACC_LSB_M_PER_S2, LAT_VEL_LSB_M_PER_S,
    SPEED_LSB_RAD_PER_S, TORQUE_LSB_NM, VOLTAGE_LSB_V, V_REF_LSB_M_PER_S,
};
use wheelset_proto::{
    encode_vec, Actuation, Decoder, Flags, Lateral, LateralSensing, Message, Sensor, SensorSi,
};

/// The sample back in SI (`count * LSB`); a lateral quantity not carried is 0.
fn sensor_to_si(s: &Sensor) -> SensorSi {
    let (y_dot, y_ddot) = match s.lateral {
        Lateral::Velocity(v) => (to_si(v, LAT_VEL_LSB_M_PER_S), 0.0),
        Lateral::Acceleration(a) => (0.0, to_si(a, LAT_ACC_LSB_M_PER_S2)),
        Lateral::Both {
            vel_um_s,
            acc_dmm_s2,
        } => (
            to_si(vel_um_s, LAT_VEL_LSB_M_PER_S),
            to_si(acc_dmm_s2, LAT_ACC_LSB_M_PER_S2),
        ),
    };
    SensorSi {
        y_dot,
        y_ddot,
        i_a: to_si(s.i_a_ma, CURRENT_LSB_A),
        w_m: to_si(s.omega_m_mrad_s, SPEED_LSB_RAD_PER_S),
        demand_nm: to_si(s.demand_nm, DEMAND_LSB_NM),
        v_ref: to_si(s.v_ref_mm_s, V_REF_LSB_M_PER_S),
    }
}

/// Within half an LSB (plus the rounding of `x / lsb` itself, a few ulp of `x`).
fn within_half_lsb(back: f64, x: f64, lsb: f64) -> bool {
    (back - x).abs() <= 0.5 * lsb * (1.0 + 1e-9) + 4.0 * f64::EPSILON * x.abs()
}

proptest! {
    #[test]
    fn sensor_round_trip_is_within_half_an_lsb(
        y_dot in -2000.0f64..2000.0,
        y_ddot in -2e5f64..2e5,
        i_a in -2e6f64..2e6,
        w_m in -2e6f64..2e6,
        demand in -2e9f64..2e9,
        v_ref in -2e6f64..2e6,
        seq in any::<u16>(),
        t_ns in any::<u64>(),
    ) {
        let m = SensorSi { y_dot, y_ddot, i_a, w_m, demand_nm: demand, v_ref };
        for lat in [LateralSensing::Velocity, LateralSensing::Acceleration, LateralSensing::Both] {
            let q = Sensor::from_si(seq, t_ns, &m, lat);
            prop_assert_eq!(q.clamped, 0);
            prop_assert_eq!(q.msg.seq, seq);
            prop_assert_eq!(u64::from(q.msg.t_us), (t_ns / 1000) % 65_536);
            // Through the wire and back.
            let f = encode_vec(&Message::Sensor(q.msg)).unwrap();
            let Some(Ok(Message::Sensor(s))) = Decoder::new().next_message(&f).0 else {
                panic!("not a sensor frame");
            };
            prop_assert_eq!(s, q.msg);
            let b = sensor_to_si(&s);
            prop_assert!(within_half_lsb(b.i_a, i_a, CURRENT_LSB_A), "{} {}", b.i_a, i_a);
            prop_assert!(within_half_lsb(b.v_ref, v_ref, V_REF_LSB_M_PER_S), "{} {}", b.v_ref, v_ref);
            prop_assert!(within_half_lsb(b.w_m, w_m, SPEED_LSB_RAD_PER_S));
            prop_assert!(within_half_lsb(b.demand_nm, demand, DEMAND_LSB_NM));
            match lat {
                LateralSensing::Velocity => {
                    prop_assert!(within_half_lsb(b.y_dot, y_dot, LAT_VEL_LSB_M_PER_S));
                    prop_assert_eq!(b.y_ddot, 0.0);
                }
                LateralSensing::Acceleration => {
                    prop_assert!(within_half_lsb(b.y_ddot, y_ddot, LAT_ACC_LSB_M_PER_S2));
                    prop_assert_eq!(b.y_dot, 0.0);
                }
                LateralSensing::Both => {
                    prop_assert!(within_half_lsb(b.y_dot, y_dot, LAT_VEL_LSB_M_PER_S));
                    prop_assert!(within_half_lsb(b.y_ddot, y_ddot, LAT_ACC_LSB_M_PER_S2));
                }
            }
        }
    }

    #[test]
    fn actuation_to_si_inverts_the_quantisation(t in -2e8f64..2e8, u in -2e7f64..2e7) {
        let a = Actuation {
            seq_echo: 1,
            tick: 1,
            exec: 0,
            flags: Flags::default(),
            t_psi_dnm: quantize(t, TORQUE_LSB_NM).0,
            u_a_cv: quantize(u, VOLTAGE_LSB_V).0,
        };
        let s = a.to_si();
        prop_assert!(within_half_lsb(s.t_psi, t, TORQUE_LSB_NM));
        prop_assert!(within_half_lsb(s.u_a, u, VOLTAGE_LSB_V));
    }
}

#[test]
fn the_rounding_rule_is_half_away_from_zero() {
    let m = SensorSi {
        y_dot: 2.5e-6,
        i_a: -0.0025,
        w_m: 0.0004,
        demand_nm: -0.5,
        ..SensorSi::default()
    };
    let q = Sensor::from_si(1, 0, &m, LateralSensing::Velocity);
    assert_eq!(q.msg.lateral, Lateral::Velocity(3));
    assert_eq!(q.msg.i_a_ma, -3);
    assert_eq!(q.msg.omega_m_mrad_s, 0);
    assert_eq!(q.msg.demand_nm, -1);
}

#[test]
fn values_that_do_not_fit_are_clamped_and_counted() {
    let m = SensorSi {
        y_dot: 1e4,       // 1e10 um/s: beyond i32
        y_ddot: f64::NAN, // not a number: 0
        i_a: -1e7,        // -1e10 mA
        w_m: f64::INFINITY,
        demand_nm: 5.0,
        v_ref: f64::NEG_INFINITY,
    };
    let q = Sensor::from_si(1, 0, &m, LateralSensing::Both);
    assert_eq!(q.clamped, 5);
    assert_eq!(q.msg.v_ref_mm_s, i32::MIN);
    assert_eq!(
        q.msg.lateral,
        Lateral::Both {
            vel_um_s: i32::MAX,
            acc_dmm_s2: 0
        }
    );
    assert_eq!(q.msg.i_a_ma, i32::MIN);
    assert_eq!(q.msg.omega_m_mrad_s, i32::MAX);
    assert_eq!(q.msg.demand_nm, 5);
    // Velocity only: the NaN acceleration is not sent, so not counted.
    assert_eq!(
        Sensor::from_si(1, 0, &m, LateralSensing::Velocity).clamped,
        4
    );
}

#[test]
fn the_timestamp_wraps_every_65_536_ms() {
    let m = SensorSi::default();
    let t = |t_ns| {
        Sensor::from_si(0, t_ns, &m, LateralSensing::Velocity)
            .msg
            .t_us
    };
    assert_eq!(t(199_999), 199);
    assert_eq!(t(65_535_999), 65_535);
    assert_eq!(t(65_536_000), 0);
    assert_eq!(t(65_536_000 + 200_000), 200);
}
