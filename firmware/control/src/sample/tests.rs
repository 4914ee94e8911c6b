//! The sample types' arithmetic: rounding, saturation, Q31 products, quantisation.

use super::fx::{round_f64, sat32};
use super::*;

#[test]
fn fixed_mul_rounds_to_nearest() {
    let half = Coef::from_num(0.5);
    // 3 LSB * 0.5 = 1.5 LSB -> 2 (ties up); -3 LSB * 0.5 = -1.5 -> -1 (ties up).
    assert_eq!(Fx::from_bits(3).mul_c(half).to_bits(), 2);
    assert_eq!(Fx::from_bits(-3).mul_c(half).to_bits(), -1);
    assert!(Fx::quantise(-1.0).is_none() && Fx::quantise(1.0).is_none());
    assert!(Fx::quantise(0.999_999_999).is_some());
}

#[test]
fn mul_q31_never_overflows_for_valid_coefficients() {
    let reference = |x: i32, c: i32| (x as i128 * c as i128 + (1 << 30)) >> 31;
    let cmax = i32::MAX;
    let edges = [
        i32::MIN,
        i32::MIN + 1,
        -(1 << 30),
        -3,
        -1,
        0,
        1,
        3,
        1 << 30,
        i32::MAX,
    ];
    for &x in &edges {
        for &c in &[-cmax, -cmax + 1, -1, 0, 1, cmax - 1, cmax] {
            let r = reference(x, c);
            assert!(r >= i32::MIN as i128 && r <= i32::MAX as i128, "{x} {c}");
            assert_eq!(mul_q31(x, c) as i128, r, "{x} {c}");
        }
    }
    let mut s = 0x2545_f491_4f6c_dd1du64;
    for _ in 0..200_000 {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        let (x, c) = (s as i32, ((s >> 32) as i32).max(-cmax));
        assert_eq!(mul_q31(x, c) as i128, reference(x, c), "{x} {c}");
    }
}

/// `apply` without the 64-bit variable shift is the plain formula, bit for bit, for
/// every shift and at the edges of `x` and `mul` (saturation both ways included).
#[test]
fn fx_scale_apply_is_the_formula() {
    let reference = |x: i32, f: &FxScale| sat32((x as i64 * f.mul as i64 + f.round) >> f.shift);
    let xs = [
        i32::MIN,
        i32::MIN + 1,
        -(1 << 30),
        -12345,
        -1,
        0,
        1,
        7,
        1 << 30,
        i32::MAX,
    ];
    let muls = [1024u64, 1025, 268_435_456, (1 << 31) - 1];
    let mut seed = 0x9E37_79B9_7F4A_7C15u64;
    for shift in 0..=62u8 {
        for &m in &muls {
            let f = FxScale::from_bits(m, shift).expect("valid");
            for &x in &xs {
                assert_eq!(f.apply(x), reference(x, &f), "{x} {m} {shift}");
            }
            for _ in 0..2000 {
                seed ^= seed << 13;
                seed ^= seed >> 7;
                seed ^= seed << 17;
                let x = seed as i32 >> (seed >> 59);
                let f = FxScale::from_bits(1024 + (seed >> 33) % ((1 << 31) - 1024), shift)
                    .expect("valid");
                assert_eq!(f.apply(x), reference(x, &f), "{x} {f:?}");
            }
        }
    }
}

/// The factor a scale really applies, `mul / 2^shift`.
fn factor(s: &FxScale) -> f64 {
    (0..s.shift).fold(f64::from(s.mul), |f, _| f * 0.5)
}

#[test]
fn fx_scale_is_accurate() {
    for f in [1e-6 * 268_435_456.0, 0.037_252_902_984, 1.0, 3.3e5, 7.0e-9] {
        let s = FxScale::new(f).expect("representable");
        assert!((factor(&s) / f - 1.0).abs() < 1e-6, "{f}: {s:?}");
    }
    assert!(FxScale::new(f64::NAN).is_none());
    assert!(FxScale::new(-1.0).is_none());
    assert!(FxScale::new(3e9).is_none());
    let s = FxScale::new(1000.0).expect("ok");
    assert_eq!(s.apply(i32::MAX), i32::MAX);
    assert_eq!(s.apply(i32::MIN), i32::MIN);
    assert_eq!(s.apply(-7), -7000);
}

#[test]
fn float_sanitize_and_codes() {
    assert_eq!(f32::NAN.sanitize(), (0.0, true));
    assert_eq!(1.5f32.sanitize(), (1.5, false));
    assert_eq!(f64::INFINITY.to_code(&1.0), i32::MAX);
    assert_eq!(f64::NAN.to_code(&1.0), 0);
    assert_eq!((-2.5f64).to_code(&1.0), -3);
    assert!(f32::NAN.limit(-1.0, 1.0).1);
}

/// Error feedback: a constant increment of 0.3 LSB accumulates exactly, where the
/// rounded product adds 0 forever (a dead band).
#[test]
fn integrator_increment_has_no_dead_band() {
    let c = Coef::from_num(0.3 / 1000.0); // x = 1000 LSB -> 0.3 LSB per step
    let x = Fx::from_bits(1000);
    let mut r = 0u64;
    let mut acc = 0i64;
    for n in 1..=10_000i64 {
        acc += x.mul_c_acc(c, &mut r).to_bits() as i64;
        let exact = (x.to_bits() as i64 * c.to_bits() as i64 * n) >> 31;
        assert!((acc - exact).abs() <= 1, "{n}: {acc} vs {exact}");
    }
    assert_eq!(
        x.mul_c(c).to_bits(),
        0,
        "the rounded product is a dead band"
    );
    // Negative increments and the extremes stay in range.
    let mut r = 0u64;
    for (x, c) in [
        (Fx::MIN, Coef::MAX),
        (Fx::MAX, Coef::MAX),
        (Fx::MIN, -Coef::MAX),
    ] {
        let y = x.mul_c_acc(c, &mut r).to_f64();
        assert!((y - x.to_f64() * c.to_num::<f64>()).abs() < 1e-6, "{x} {c}");
    }
}

/// The shifted increment ([`Sample::mul_c_acc_shr`]): its running sum is the exact sum
/// of `x c 2^-s` to one LSB, for every shift, both signs and the extreme operands; the
/// remainder stays below `2^(31+s)`.
#[test]
fn shifted_increment_is_exact_to_one_lsb() {
    for s in 1..=Fx::ACC_SHIFT_MAX {
        for (x, c) in [
            (1000, 0x5a5a_5a5a),
            (-12_345_678, 0x4000_0001),
            (i32::MAX, i32::MAX),
            (i32::MIN, i32::MAX),
            (i32::MIN, -i32::MAX),
            (7, 1),
        ] {
            let (xf, cf) = (Fx::from_bits(x), Coef::from_bits(c));
            let mut r = 0u64;
            let mut acc = 0i128;
            for n in 1..=200i128 {
                acc += i128::from(xf.mul_c_acc_shr(cf, s, &mut r).to_bits());
                assert!(r < 1u64 << (31 + s), "s {s}: remainder {r}");
                // floor(n x c / 2^(31+s)): the sum is never above it, at most 1 below.
                let exact = (i128::from(x) * i128::from(c) * n) >> (31 + s);
                assert!(acc <= exact && exact - acc <= 1, "s {s} x {x} c {c} n {n}");
            }
        }
    }
}

/// The shift holds a small coefficient with the format's significant bits: the largest
/// `s` with `c_max 2^s` below 1, refused from 0.5 up (the smallest shift is 1).
#[test]
fn acc_shift_choice() {
    assert_eq!(Fx::acc_shift(4.0e-4), Some(11)); // 4e-4 2^11 = 0.82
    assert_eq!(Fx::acc_shift(0.3), Some(1));
    assert_eq!(Fx::acc_shift(0.5), None);
    assert_eq!(Fx::acc_shift(1e-12), Some(Fx::ACC_SHIFT_MAX));
    for bad in [0.0, -1e-3, f64::NAN, f64::INFINITY] {
        assert_eq!(Fx::acc_shift(bad), None, "{bad}");
        assert_eq!(f32::acc_shift(bad), None, "{bad}");
    }
    assert_eq!(f32::acc_shift(4.0e-4), Some(0));
    assert!(Fx::acc_shift_ok(1) && Fx::acc_shift_ok(30) && !Fx::acc_shift_ok(0));
    assert!(f32::acc_shift_ok(0) && !f32::acc_shift_ok(1));
    // The product at the chosen shift keeps ~28 significant bits of Ki = 4e-5.
    let s = Fx::acc_shift(4.0e-4).expect("fits");
    let c = Fx::quantise(4.0e-5 * (1u64 << s) as f64).expect("fits");
    let bits = (c.to_bits() as f64).log2();
    assert!(bits > 27.0, "{bits}");
}

#[test]
fn fixed_from_non_finite_f64_does_not_panic() {
    assert_eq!(Fx::from_f64(f64::NAN), Fx::ZERO);
    assert_eq!(Fx::from_f64(f64::INFINITY), Fx::MAX);
    assert_eq!(Fx::from_f64(f64::NEG_INFINITY), Fx::MIN);
    assert_eq!(Fx::from_f64(1e300), Fx::MAX);
    assert_eq!(Fx::from_f64(0.5).to_f64(), 0.5);
}

/// The `apply` of before the precomputed form (a run-time branch on `shift`), kept as
/// the reference the precomputed form must equal bit for bit.
fn apply_branching(f: &FxScale, x: i32) -> i32 {
    let p = x as i64 * f.mul as i64 + f.round;
    let (hi, lo) = ((p >> 32) as i32, p as u32);
    let s = f.shift;
    if s >= 32 {
        hi >> (s - 32).min(31)
    } else if s == 0 {
        sat32(p)
    } else {
        let q = ((lo >> s) | ((hi as u32) << (32 - s))) as i32;
        if hi >> s == q >> 31 {
            q
        } else if hi < 0 {
            i32::MIN
        } else {
            i32::MAX
        }
    }
}

/// The precomputed, branch-on-`wide` `apply` equals the branching one and the plain
/// formula for every shift `0..=62` with edge and random `mul` and `x` (saturation both
/// ways, the saturation thresholds `x = ±2^31 2^shift / mul` and their neighbours), for
/// the scales [`FxScale::new`] makes from random factors over its whole range, and for
/// the out-of-range shifts the compiled-in constructor tolerates without panicking.
#[test]
fn fx_scale_precomputed_apply_equals_branching() {
    let formula = |x: i32, f: &FxScale| {
        if f.shift > 62 {
            apply_branching(f, x)
        } else {
            sat32((x as i64 * f.mul as i64 + f.round) >> f.shift)
        }
    };
    let check = |f: &FxScale, x: i32| {
        let (a, b) = (f.apply(x), apply_branching(f, x));
        assert_eq!(a, b, "{x} {f:?}");
        assert_eq!(a, formula(x, f), "{x} {f:?}");
    };
    let mut seed = 0x2545_F491_4F6C_DD1Du64;
    let mut next = || {
        seed ^= seed << 13;
        seed ^= seed >> 7;
        seed ^= seed << 17;
        seed
    };
    let muls = [
        1024u64,
        1025,
        65_537,
        1 << 30,
        (1 << 30) + 1,
        (1 << 31) - 2,
        (1 << 31) - 1,
    ];
    for shift in 0..=62u8 {
        for i in 0..muls.len() + 64 {
            let m = match muls.get(i) {
                Some(&m) => m,
                None => 1024 + next() % ((1 << 31) - 1024),
            };
            let f = FxScale::from_bits(m, shift).expect("valid");
            // Where saturation starts: |x mul| 2^-shift near 2^31.
            let t = ((1i128 << 31) << shift) / f.mul as i128;
            for x in [i32::MIN, i32::MIN + 1, -1, 0, 1, i32::MAX - 1, i32::MAX] {
                check(&f, x);
            }
            for d in -2i128..=2 {
                for v in [t + d, -t + d] {
                    if let Ok(x) = i32::try_from(v) {
                        check(&f, x);
                    }
                }
            }
            for _ in 0..200 {
                let r = next();
                check(&f, r as i32 >> (r >> 59));
            }
        }
    }
    // The scales `new` produces, log-uniform over its range.
    for _ in 0..20_000 {
        let r = next();
        // A mantissa in [1, 2) times 2^k, k in -40..=31.
        let mut factor = 1.0 + (r >> 11) as f64 / (1u64 << 53) as f64;
        let k = (r % 72) as i32 - 40;
        for _ in 0..k.unsigned_abs() {
            factor *= if k < 0 { 0.5 } else { 2.0 };
        }
        if let Some(f) = FxScale::new(factor) {
            assert_eq!(FxScale::from_bits(f.mul as u64, f.shift as u8), Some(f));
            for _ in 0..8 {
                let r = next();
                check(&f, r as i32 >> (r >> 59));
            }
            check(&f, i32::MIN);
            check(&f, i32::MAX);
        }
    }
    // Shifts above 62 (refused by `from_bits`; the compiled-in path builds them with a
    // zero `round` above 63): no panic, the same result as the branching form.
    for shift in 63..=255u32 {
        let f = FxScale::from_parts(1 << 30, shift);
        for x in [i32::MIN, -1, 0, 1, i32::MAX] {
            assert_eq!(f.apply(x), apply_branching(&f, x), "{x} {f:?}");
        }
    }
}

#[test]
fn round_f64_rounds_half_away_from_zero() {
    for (x, want) in [
        (2.5, 3.0),
        (-2.5, -3.0),
        (2.4, 2.0),
        (-2.4, -2.0),
        (2.6, 3.0),
        (-2.6, -3.0),
        (0.5, 1.0),
        (-0.5, -1.0),
        (0.0, 0.0),
        (1_048_575.5, 1_048_576.0),
    ] {
        assert_eq!(round_f64(x), want, "{x}");
    }
}

#[test]
fn fixed_square_rounds_to_nearest() {
    // (b 2^-28)^2 = b^2 2^-56 in Q4.28: b^2 / 2^28 LSB, rounded to nearest.
    for b in [
        1i32,
        3,
        11_585,
        16_385,
        23_170,
        46_341,
        -46_341,
        1 << 20,
        33_554_431,
    ] {
        let want = ((f64::from(b) * f64::from(b)) / f64::from(1u32 << 28)).round();
        assert_eq!(f64::from(Fx::from_bits(b).square().to_bits()), want, "{b}");
    }
}

#[test]
fn fixed_pre_doubling_coefficient_and_unit_range_edges() {
    // A coefficient is pre-doubled only while 2c stays a coefficient: |c| <= 2^30 - 2 LSB.
    let c = |b: i32| Coef::from_bits(b);
    assert_eq!(Fx::pre_coeff(c((1 << 30) - 2)), Some(c(i32::MAX - 3)));
    assert_eq!(Fx::pre_coeff(c(-(1 << 30) + 2)), Some(c(i32::MIN + 4)));
    assert_eq!(Fx::pre_coeff(c((1 << 30) - 1)), None);
    assert_eq!(Fx::pre_coeff(c(-(1 << 30) + 1)), None);
    // In the unit interval: positive, or zero when zero is allowed; never negative.
    assert!(Fx::coeff_in_unit(c(1), false));
    assert!(Fx::coeff_in_unit(c(0), true) && !Fx::coeff_in_unit(c(0), false));
    assert!(!Fx::coeff_in_unit(c(-1), true) && !Fx::coeff_in_unit(c(-1), false));
}

/// A sample type with only the required operations (`f64`'s), so the trait's provided
/// operations are the ones used (the audit's dynamic format relies on them).
#[derive(Clone, Copy, Debug, Default, PartialEq, PartialOrd)]
struct Plain(f64);

impl Sample for Plain {
    type Coeff = f64;
    type Residue = ();
    type Scale = f64;
    const ZERO: Self = Plain(0.0);
    const NAME: &'static str = "plain";
    fn from_f64(x: f64) -> Self {
        Plain(x)
    }
    fn to_f64(self) -> f64 {
        self.0
    }
    fn quantise(c: f64) -> Option<f64> {
        f64::quantise(c)
    }
    fn coeff_to_f64(c: f64) -> f64 {
        c
    }
    fn sat_add(self, rhs: Self) -> Self {
        Plain(self.0 + rhs.0)
    }
    fn sat_sub(self, rhs: Self) -> Self {
        Plain(self.0 - rhs.0)
    }
    fn mul_c(self, c: f64) -> Self {
        Plain(self.0 * c)
    }
    fn to_coeff_sat(self) -> f64 {
        self.0
    }
    fn mul_c_acc(self, c: f64, _r: &mut ()) -> Self {
        Plain(self.0 * c)
    }
    fn limit(self, lo: Self, hi: Self) -> (Self, bool) {
        let (y, c) = self.0.limit(lo.0, hi.0);
        (Plain(y), c)
    }
    fn sanitize(self) -> (Self, bool) {
        let (y, bad) = self.0.sanitize();
        (Plain(y), bad)
    }
    fn scale_in(factor: f64) -> Option<f64> {
        f64::scale_in(factor)
    }
    fn scale_out(factor: f64) -> Option<f64> {
        f64::scale_out(factor)
    }
    fn from_code(code: i32, scale: &f64) -> Self {
        Plain(f64::from_code(code, scale))
    }
    fn to_code(self, scale: &f64) -> i32 {
        self.0.to_code(scale)
    }
}

#[test]
fn the_provided_operations_are_their_definitions() {
    let p = Plain;
    assert_eq!(p(-1.5).square(), p(2.25));
    assert_eq!(Plain::two_pu(), p(2.0));
    for (x, max, inside) in [
        (1.0, 1.0, true),
        (-1.0, 1.0, true),
        (0.0, 0.0, true),
        (1.0 + 1e-9, 1.0, false),
        (-1.0 - 1e-9, 1.0, false),
        (f64::NAN, 1.0, false),
    ] {
        assert_eq!(p(x).abs_within(p(max)), inside, "{x} {max}");
    }
    for (x, inside) in [
        (-0.5, true),
        (1.0, true),
        (0.0, true),
        (-0.5 - 1e-9, false),
        (1.0 + 1e-9, false),
        (f64::NAN, false),
    ] {
        assert_eq!(p(x).within(p(-0.5), p(1.0)), inside, "{x}");
    }
    assert_eq!(Plain::pre_coeff(0.25), None);
    assert_eq!(p(3.0).mul_pre(0.25), p(0.75));
    assert_eq!(p(3.0).mul_c_small(-0.25), p(-0.75));
    assert_eq!(Plain::acc_shift(0.5), Some(0));
    assert_eq!(Plain::acc_shift(0.0), None);
    assert!(Plain::acc_shift_ok(0) && !Plain::acc_shift_ok(1));
    assert_eq!(p(3.0).mul_c_acc_shr(0.5, 0, &mut ()), p(1.5));
}

/// The provided tick is the controller's: the same outputs as `f64`'s, tick by tick.
#[test]
fn the_provided_tick_is_the_controllers() {
    let cfg = crate::Config::default();
    let mut a = crate::Controller::<Plain>::try_new(&cfg).expect("valid");
    let mut b = crate::Controller::<f64>::try_new(&cfg).expect("valid");
    for k in 0..200 {
        let x = f64::from(k % 17) * 0.01 - 0.08;
        let ia = crate::Inputs {
            y_dot: p(x),
            current: p(0.1),
            speed: p(0.5),
            demand: p(0.3),
        };
        let ib = crate::Inputs {
            y_dot: x,
            current: 0.1,
            speed: 0.5,
            demand: 0.3,
        };
        let (oa, ob) = (a.tick(&ia), b.tick(&ib));
        assert_eq!(
            (oa.yaw_torque.0, oa.voltage.0),
            (ob.yaw_torque, ob.voltage),
            "tick {k}"
        );
    }
    fn p(x: f64) -> Plain {
        Plain(x)
    }
}
