//! Short seeded fuzz runs of both sample types, and the generator's reproducibility.

use super::*;

fn s(v: &[&str]) -> Vec<String> {
    v.iter().map(|x| x.to_string()).collect()
}

#[test]
fn the_command_line_parses_and_refuses() {
    assert_eq!(
        parse_args(&s(&["--frames", "10_000", "--seed=7"])),
        Ok(Args {
            frames: 10_000,
            seed: 7
        })
    );
    assert_eq!(parse_args(&s(&["--frames=5"])).map(|a| a.seed), Ok(1));
    for bad in [
        &["--frames"][..],
        &["--frames", "0"],
        &["--frames", "-3"],
        &["--frames", "1e6"],
        &["--seed", "4"],
        &["--frames", "4", "--bogus"],
    ] {
        let e = parse_args(&s(bad)).unwrap_err();
        assert!(
            e.contains("usage") || e.contains("required"),
            "{bad:?}: {e}"
        );
    }
}

/// The CI run: short, seeded, both sample types. Each kind of frame occurs, the
/// device saw all of them, refused hostile Configs and took its own.
#[test]
fn fuzz_short_seeded() {
    for r in [
        run::<Fx>(20_000, 1).unwrap(),
        run::<f32>(20_000, 1).unwrap(),
    ] {
        assert!(r.generated.iter().all(|&n| n > 100), "{r:?}");
        assert_eq!(r.rx.iter().sum::<u64>() + r.resets, r.frames_seen, "{r:?}");
        assert!(r.resets > 0, "{r:?}");
        assert!(
            r.rx[1..6].iter().all(|&n| n > 0),
            "every error kind seen: {r:?}"
        );
        assert!(r.configs_refused > 100 && r.configs_applied > 100, "{r:?}");
        assert!(r.status_frames > 100, "{r:?}");
    }
}

#[test]
fn a_seed_reproduces_a_run() {
    assert_eq!(run::<Fx>(2_000, 9), run::<Fx>(2_000, 9));
    assert_ne!(run::<Fx>(2_000, 9), run::<Fx>(2_000, 10));
}
