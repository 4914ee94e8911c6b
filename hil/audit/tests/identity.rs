//! The instrumented type at the production formats is bit-identical to `Fx`: the two
//! controllers side by side on the same random inputs give the same output bits.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use wheelset_audit::qdyn::{self, Formats, QDyn};
use wheelset_control::{Config, Controller, Fx, Inputs, Sample};

/// The controller's outputs `(T_psi, u_a)` as raw bits for inputs `(y', i_a)` in pu.
fn outputs<T: Sample>(xs: &[(f64, f64)], bits: impl Fn(T) -> i64) -> Vec<(i64, i64)> {
    let mut c = Controller::<T>::try_new(&Config::default()).expect("the default Config");
    xs.iter()
        .map(|&(y, i)| {
            let o = c.tick(&Inputs {
                y_dot: T::from_f64(y),
                current: T::from_f64(i),
                speed: T::from_f64(0.9256),
                demand: T::from_f64(0.246),
            });
            (bits(o.yaw_torque), bits(o.voltage))
        })
        .collect()
}

#[test]
fn instrumented_type_is_bit_identical_to_fx() {
    let mut s = 0x9e37_79b9_7f4a_7c15_u64;
    let mut next = || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    };
    let xs: Vec<(f64, f64)> = (0..20_000).map(|_| (next() * 1.2, next() * 2.5)).collect();
    let fx = outputs::<Fx>(&xs, |v| i64::from(v.to_bits()));
    let q = qdyn::with_formats(Formats::PRODUCTION, || outputs::<QDyn>(&xs, |v| v.0));
    assert_eq!(fx.len(), xs.len());
    assert!(
        fx == q,
        "the first differing tick: {:?}",
        fx.iter().zip(&q).position(|(a, b)| a != b)
    );
}
