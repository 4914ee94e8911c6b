//! `hil soak` in process: a simulated hour runs clean (CI's soak; `hil soak --hours 24`
//! is the day), a broken device is caught with its time and seed and a shorter run
//! replays the failure, and bad flags are refused with the reason.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use std::process::Command;

use hil::soak::inproc::{soak, SoakOptions};
use hil::soak::service::ServiceOptions;
use wheelset_loop::inproc::DeviceFault;

const MINUTE_NS: u64 = 60_000_000_000;

fn options(minutes: u64, seed: u64, defect: DeviceFault) -> SoakOptions {
    SoakOptions {
        duration_ns: minutes * MINUTE_NS,
        seed,
        defect,
        progress: false,
        trace: false,
        service: ServiceOptions::default(),
    }
}

#[test]
fn a_simulated_hour_of_service_runs_clean() {
    let r = soak(options(60, 1, DeviceFault::None)).expect("the soak starts");
    eprintln!("{}", r.summary());
    assert!(r.failure.is_none(), "{}", r.summary());
    assert!((r.simulated_s - 3600.0).abs() < 0.01, "{}", r.simulated_s);
    // The service did what a day does, and the counters crossed their wrap.
    assert!(
        r.link_episodes.iter().all(|&n| n > 0),
        "{:?}",
        r.link_episodes
    );
    assert!(r.actuator_faults > 0 && r.rate_changes > 0 && r.adhesion_patches > 0);
    assert!(
        r.alarms[0] + r.alarms[1] >= r.actuator_faults,
        "{:?}",
        r.alarms
    );
    assert_eq!(r.alarms[2], 0, "no drive alarm");
    assert!(r.safe_entries > 0 && r.tick_wrap_s.is_some());
    assert!(r.up.frames.adds_up() && r.down.frames.adds_up());
    assert!(r.up.frames.rejected > 0 && r.down.frames.dropped > 0);
    assert!(r.statuses_checked > 500, "{}", r.statuses_checked);
}

/// Demand steps (up and down, to random levels up to 4 kN m) move the device's current
/// reference in a block, and the actuator check does not judge the transient they cause:
/// the run of the seed that once raised a false actuator alarm 0.2 s after a step of
/// about 2 kN m, clean.
#[test]
fn demand_steps_raise_no_false_alarm() {
    let mut o = options(5, 3, DeviceFault::None);
    o.service.demand_steps = true;
    let r = soak(o).expect("the soak starts");
    assert!(r.failure.is_none(), "{}", r.summary());
    assert!(r.configs > 0, "{}", r.summary());
}

#[test]
fn a_broken_device_is_caught_named_and_replayed_in_a_shorter_run() {
    // Every 150 000th frame the device sends has a bit flipped: the first about 30 s in.
    let broken = DeviceFault::Corrupt { every: 150_000 };
    let r = soak(options(10, 7, broken)).expect("the soak starts");
    let f = r.failure.expect("the soak catches the broken frame");
    let text = f.to_string();
    assert!(text.contains("seed 7"), "{text}");
    assert!(
        f.what.contains("device -> host") && f.what.contains("without faults"),
        "{text}"
    );
    assert!(
        f.t_ns > 10_000_000_000 && f.t_ns < 120_000_000_000,
        "{text}"
    );
    let replay = f.replay();
    assert!(
        replay.starts_with("hil soak --seed 7 --minutes "),
        "{replay}"
    );
    assert!(replay.ends_with(" --defect corrupt:150000"), "{replay}");
    let minutes: u64 = replay.split(' ').nth(5).unwrap().parse().unwrap();
    assert!(minutes < 10, "a shorter run: {replay}");
    let again = soak(options(minutes, 7, broken)).expect("the replay starts");
    assert_eq!(
        again.failure,
        Some(f),
        "the replay fails the same way, at the same time"
    );
}

fn hil(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(args)
        .output()
        .expect("hil runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// The condition the day leaves out (`docs/soak.md`): a low patch under traction. Its
/// traced onset shows the wheel creeping into slip below the protection's detection
/// (0.25 m/s) while `y'` grows, and the actuator check blames the actuator.
#[test]
fn a_low_patch_under_traction_is_traced_to_its_unexplained_actuator_alarm() {
    let (code, err) = hil(&[
        "soak",
        "--seed",
        "3",
        "--minutes",
        "2",
        "--low-adhesion",
        "--trace",
    ]);
    assert_eq!(code, 1, "{err}");
    let after = err
        .split("Adhesion { low: true")
        .nth(1)
        .expect("a low patch");
    let blocks: Vec<(f64, f64)> = after
        .lines()
        .filter(|l| l.contains("y' peak"))
        .map(|l| {
            let num = |key: &str| -> f64 {
                let v = l.split(key).nth(1).unwrap().trim_start();
                v[..v.find(' ').unwrap()].parse().unwrap()
            };
            (num("y' peak"), num("slip"))
        })
        .collect();
    assert!(blocks.len() >= 2, "{err}");
    assert!(
        blocks
            .windows(2)
            .all(|w| w[1].0 > w[0].0 && w[1].1 > w[0].1),
        "{blocks:?}"
    );
    assert!(
        blocks.iter().all(|b| (0.06..0.25).contains(&b.1)),
        "{blocks:?}"
    );
    let out = Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(["soak", "--seed", "3", "--minutes", "2", "--low-adhesion"])
        .output()
        .expect("hil runs");
    let out = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.contains("an alarm nobody expected (flags 0x0c01"),
        "{out}"
    );
}

#[test]
fn bad_soak_flags_are_refused_with_the_reason() {
    for (args, says) in [
        (&["soak"][..], "--hours"),
        (&["soak", "--hours", "0"], "positive"),
        (&["soak", "--hours", "-1"], "positive"),
        (&["soak", "--hours", "1", "--minutes", "3"], "--minutes"),
        (
            &["soak", "--hours", "1", "--target", "qemu"],
            "inproc or qemu-free",
        ),
        (&["soak", "--hours", "1", "--defect", "corrupt:0"], "EVERY"),
        (
            &["soak", "--hours", "1", "--defect", "wrong-sign"],
            "corrupt:EVERY",
        ),
        (
            &[
                "soak",
                "--minutes",
                "1",
                "--target",
                "qemu-free",
                "--defect",
                "corrupt:5",
            ],
            "in-process",
        ),
    ] {
        let (code, err) = hil(args);
        assert_eq!(code, 2, "{args:?}: {err}");
        assert!(err.contains(says), "{args:?}: {err}");
    }
}

#[test]
fn a_defect_the_soak_does_not_simulate_is_refused() {
    let err = soak(options(1, 1, DeviceFault::WrongSign)).expect_err("refused");
    assert!(err.contains("no defect"), "{err}");
}
