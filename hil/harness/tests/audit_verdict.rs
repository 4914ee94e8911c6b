//! `hil audit`'s verdict and counts, from the tool itself: the JSON's checks counted by
//! status are the counts the summary prints, and the verdict (JSON and summary) is the
//! worst status of the checks; the exit code follows it.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::process::Command;

#[test]
fn verdict_is_the_worst_check_and_the_counts_are_the_checks_by_status() {
    let dir = std::env::temp_dir().join(format!("hil-audit-verdict-{}", std::process::id()));
    let json = dir.join("audit.json");
    let out = Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(["audit", "--no-target", "--no-sweep", "--quiet", "--json"])
        .arg(&json)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    let checks = v["checks"].as_array().unwrap();
    assert!(!checks.is_empty());
    let count = |s: &str| {
        checks
            .iter()
            .filter(|c| c["status"] == s && c["not_run"] == false)
            .count()
    };
    let (p, w, f) = (count("pass"), count("warn"), count("fail"));
    let not_run = checks.iter().filter(|c| c["not_run"] == true).count();
    assert_eq!(not_run, 0, "--no-target: every check ran");
    assert_eq!(p + w + f, checks.len(), "every check has a known status");
    let rank = |s: &str| {
        ["pass", "warn", "fail"]
            .iter()
            .position(|x| *x == s)
            .unwrap()
    };
    let worst = checks
        .iter()
        .map(|c| rank(c["status"].as_str().unwrap()))
        .max()
        .unwrap();
    let verdict = ["pass", "warn", "fail"][worst];
    assert_eq!(v["verdict"], verdict);
    let line = format!(
        "verdict: {} ({p} pass, {w} warn, {f} fail)",
        verdict.to_uppercase()
    );
    assert!(stdout.contains(&line), "summary lacks `{line}`:\n{stdout}");
    // Every check not passed is printed (quiet prints exactly those).
    let shown = stdout
        .lines()
        .filter(|l| l.starts_with("  warn ") || l.starts_with("  fail "))
        .count();
    assert_eq!(shown, w + f);
    assert_eq!(out.status.code(), Some(i32::from(verdict == "fail")));
    let _ = std::fs::remove_dir_all(&dir);
}

/// Without the firmware (and without `--no-target`) the target comparison cannot run: it
/// is a check not run, counted in the verdict line, listed with the way to run it among
/// the checks not passed (terminal and report), and the verdict is at least a warning.
#[test]
fn a_target_comparison_that_cannot_run_shows_in_the_verdict() {
    let dir = std::env::temp_dir().join(format!("hil-audit-not-run-{}", std::process::id()));
    let json = dir.join("audit.json");
    let report = dir.join("report");
    let out = Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(["audit", "--no-plant", "--no-sweep", "--quiet", "--json"])
        .arg(&json)
        .arg("--report")
        .arg(&report)
        .env("WHEELSET_QEMU_ELF", dir.join("no-such-firmware.elf"))
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["target"]["outcome"], "not-run");
    let not_run: Vec<&serde_json::Value> = v["checks"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|c| c["not_run"] == true)
        .collect();
    assert_eq!(not_run.len(), 1, "{not_run:?}");
    assert_eq!(not_run[0]["status"], "warn");
    assert!(not_run[0]["remedy"].as_str().unwrap().contains("cargo fw"));
    assert_ne!(v["verdict"], "pass");
    let verdict = stdout.lines().find(|l| l.starts_with("verdict: ")).unwrap();
    assert!(verdict.ends_with(", 1 not run)"), "{verdict}");
    assert!(
        stdout.contains("target (QEMU) vs host Actuation frames: not run: ")
            && stdout.contains("remedy: build the firmware"),
        "{stdout}"
    );
    let md = std::fs::read_to_string(report.join("audit.md")).unwrap();
    let listed = md
        .split("Checks not passed:")
        .nth(1)
        .is_some_and(|rest| rest.contains("**not run** `all` target (QEMU)"));
    assert!(listed, "{md}");
    assert!(md.contains("1 not run"), "{md}");
    assert_eq!(out.status.code(), Some(i32::from(v["verdict"] == "fail")));
    let _ = std::fs::remove_dir_all(&dir);
}
