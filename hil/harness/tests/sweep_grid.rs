//! `hil sweep`'s grid: the axes, the shards, the points (moved from `sweep.rs`'s unit
//! tests; the public API only).
#![allow(clippy::unwrap_used)]

use hil::sweep::*;
use wheelset_plant::params::Params;

#[test]
fn an_axis_has_both_ends_and_linear_steps() {
    let a: Axis = "f11=1e6..1e7:5".parse().unwrap();
    assert_eq!(a.key, "f11");
    assert_eq!(a.values.len(), 5);
    assert_eq!(a.values[0], 1e6);
    assert_eq!(a.values[4], 1e7);
    for w in a.values.windows(2) {
        assert!((w[1] - w[0] - 2.25e6).abs() < 1e-6, "{:?}", a.values);
    }
    let one: Axis = "lambda=0.3".parse().unwrap();
    assert_eq!(one.values, vec![0.3]);
}

#[test]
fn bad_axes_and_shards_say_why() {
    for (spec, words) in [
        ("f11=1..", "FROM..TO:N"),
        ("f11=1e6..1e7:0", "at least 1"),
        ("foo=1..2:3", "unknown parameter `foo`"),
        ("f11", "KEY=FROM..TO:N"),
        ("f11=1e6..x:3", "TO `x`"),
        ("f11=1e6..1e7:2.5", "whole number"),
        ("f11=1e6..1e7:1", "one point"),
        ("f11=nan", "not finite"),
    ] {
        let e = spec.parse::<Axis>().unwrap_err();
        assert!(e.contains(words), "{spec}: {e}");
    }
    assert_eq!(
        "1/3".parse::<Shard>().unwrap(),
        Shard { index: 1, count: 3 }
    );
    for (spec, words) in [
        ("2/2", "below N"),
        ("0/0", "at least 1"),
        ("1", "I/N"),
        ("a/2", "`a`"),
    ] {
        let e = spec.parse::<Shard>().unwrap_err();
        assert!(e.contains(words), "{spec}: {e}");
    }
    let f: Axis = "f11=1e6..1e7:2".parse().unwrap();
    assert!(check_axes(&[f.clone(), f]).unwrap_err().contains("twice"));
    assert!(check_axes(&[]).unwrap_err().contains("--param"));
}

#[test]
fn the_grid_runs_the_last_axis_fastest_and_f22_follows_f11() {
    let axes: Vec<Axis> = ["f11=1e6..3e6:3", "lambda=0.1..0.2:2"]
        .iter()
        .map(|s| s.parse().unwrap())
        .collect();
    let f = followers(&axes);
    assert_eq!(f, vec![("f22".to_string(), "f11".to_string())]);
    let p = points(&axes, &f);
    assert_eq!(p.len(), 6);
    let get = |i: usize, k: &str| p[i].iter().find(|(key, _)| key == k).unwrap().1;
    assert_eq!((get(0, "f11"), get(0, "lambda")), (1e6, 0.1));
    assert_eq!((get(1, "f11"), get(1, "lambda")), (1e6, 0.2));
    assert_eq!((get(2, "f11"), get(2, "lambda")), (2e6, 0.1));
    assert_eq!((get(5, "f11"), get(5, "lambda")), (3e6, 0.2));
    for pt in &p {
        assert_eq!(get(0, "f22"), get(0, "f11"));
        let f11 = pt.iter().find(|(k, _)| k == "f11").unwrap().1;
        let f22 = pt.iter().find(|(k, _)| k == "f22").unwrap().1;
        assert_eq!(f11, f22);
    }
    // With f22 an axis of its own, it does not follow.
    let axes: Vec<Axis> = ["f11=1e6..3e6:3", "f22=5e6"]
        .iter()
        .map(|s| s.parse().unwrap())
        .collect();
    assert!(followers(&axes).is_empty());
    // The point's parameters are validated against the plausible ranges.
    let e = point_params(&Params::default(), &[("lambda".into(), 5.0)]).unwrap_err();
    assert!(e.contains("--param") && e.contains("lambda"), "{e}");
}
