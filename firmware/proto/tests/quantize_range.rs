//! The edges of `units::quantize`'s range: a value is clamped (and reported) exactly when
//! its rounding, half away from zero, leaves the `i32` range; the last values that round
//! inside it are carried as they are, unreported.

use wheelset_proto::units::quantize;

/// `i32::MAX` and `i32::MIN` as counts of an LSB of 1.
const MAX: f64 = i32::MAX as f64;
const MIN: f64 = i32::MIN as f64;

#[test]
fn the_last_values_inside_the_range_are_not_clamped() {
    // 2^31 - 1 + 0.4 rounds to 2^31 - 1; -2^31 - 0.4 rounds to -2^31.
    assert_eq!(quantize(MAX + 0.4, 1.0), (i32::MAX, false));
    assert_eq!(quantize(MIN - 0.4, 1.0), (i32::MIN, false));
    assert_eq!(quantize(MAX, 1.0), (i32::MAX, false));
    assert_eq!(quantize(MIN, 1.0), (i32::MIN, false));
}

#[test]
fn a_half_beyond_the_range_rounds_out_of_it_and_is_clamped() {
    // 2^31 - 0.5 rounds away from zero to 2^31: beyond; -2^31 - 0.5 to -2^31 - 1.
    assert_eq!(quantize(MAX + 0.5, 1.0), (i32::MAX, true));
    assert_eq!(quantize(MIN - 0.5, 1.0), (i32::MIN, true));
    assert_eq!(quantize(MAX + 1.0, 1.0), (i32::MAX, true));
    assert_eq!(quantize(MIN - 1.0, 1.0), (i32::MIN, true));
}

#[test]
fn not_a_number_is_zero_and_reported() {
    assert_eq!(quantize(f64::NAN, 1e-3), (0, true));
    // And zero is zero, unreported.
    assert_eq!(quantize(0.0, 1e-3), (0, false));
    assert_eq!(quantize(-0.0, 1e-3), (0, false));
}
