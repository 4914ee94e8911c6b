//! Wire units: every physical quantity is an `i32` count of its LSB, `value_SI = count *
//! LSB`, each at least 100 times finer than the loops need.

/// `y'` LSB: 1 um/s, in m/s.
pub const LAT_VEL_LSB_M_PER_S: f64 = 1e-6;
/// `y''` LSB: 0.1 mm/s^2, in m/s^2.
pub const LAT_ACC_LSB_M_PER_S2: f64 = 1e-4;
/// Motor current LSB: 1 mA, in A.
pub const CURRENT_LSB_A: f64 = 1e-3;
/// Motor speed LSB: 1 mrad/s, in rad/s.
pub const SPEED_LSB_RAD_PER_S: f64 = 1e-3;
/// Traction demand (wheel torque `n K_m i_ref`) LSB: 1 N m.
pub const DEMAND_LSB_NM: f64 = 1.0;
/// Yaw torque LSB: 0.1 N m.
pub const TORQUE_LSB_NM: f64 = 0.1;
/// Motor voltage LSB: 10 mV, in V.
pub const VOLTAGE_LSB_V: f64 = 1e-2;
/// Vehicle reference speed LSB ([`crate::Sensor::v_ref_mm_s`]): 1 mm/s, in m/s.
pub const V_REF_LSB_M_PER_S: f64 = 1e-3;
/// Host timestamp LSB: 1 us, in s (the field wraps every 65.536 ms).
pub const TIME_LSB_S: f64 = 1e-6;

/// Quantises an SI value, `round(x / lsb)` half away from zero, and whether it was clamped
/// (saturated to `i32`, or NaN as 0).
///
/// ```
/// use wheelset_proto::units::{quantize, VOLTAGE_LSB_V};
/// assert_eq!(quantize(3961.234, VOLTAGE_LSB_V), (396_123, false));
/// assert_eq!(quantize(-0.000_004_9, 1e-5), (0, false));
/// assert_eq!(quantize(1e300, 1.0), (i32::MAX, true));
/// ```
#[must_use]
pub fn quantize(x: f64, lsb: f64) -> (i32, bool) {
    let q = x / lsb;
    if q.is_nan() {
        return (0, true);
    }
    let r = if q >= 0.0 { q + 0.5 } else { q - 0.5 };
    // `as` saturates silently: detect it so it is counted.
    let clamped = !(r > -2_147_483_649.0 && r < 2_147_483_648.0);
    (r as i32, clamped)
}

/// Converts wire counts back to SI: `count * lsb`.
#[must_use]
pub fn to_si(count: i32, lsb: f64) -> f64 {
    f64::from(count) * lsb
}
