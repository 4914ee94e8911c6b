//! The built-in scenarios through the public API (moved from `scenario.rs`'s unit tests
//! when the file was split).
#![allow(clippy::unwrap_used)]

use wheelset_plant::params::Params;
use wheelset_plant::scenario::{track_at, Scenario};

#[test]
fn builtin_curve_matches_spec_table() {
    let s = Scenario::load("curve", &Params::default()).unwrap();
    assert_eq!(s.duration_ns, 20_000_000_000);
    let (c, th) = track_at(&s.track, 8_000_000_000, &mut 0);
    assert!((c - 1.0 / 2300.0).abs() < 1e-12);
    assert!((th - 6f64.to_radians()).abs() < 1e-12);
    let (c, _) = track_at(&s.track, 2_500_000_000, &mut 0); // half-way up the entry transition
    assert!((c - 0.5 / 2300.0).abs() < 1e-12);
    assert_eq!(track_at(&s.track, 500_000_000, &mut 0), (0.0, 0.0));
    assert_eq!(track_at(&s.track, 17_000_000_000, &mut 0), (0.0, 0.0));
    assert_eq!(s.traction.at(4_999_999_999), 0.0);
    assert!((s.traction.at(5_000_000_000) - 2460.0).abs() < 1e-9);
    assert!((s.resistance.at(5_000_000_000) - 5470.0).abs() < 1e-9);
}

#[test]
fn beating_moves_the_gear_stiffness() {
    let s = Scenario::load("beating", &Params::default()).unwrap();
    assert!(s.params.k_gear() < Params::default().k_gear());
}
