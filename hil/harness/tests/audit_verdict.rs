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
    let count = |s: &str| checks.iter().filter(|c| c["status"] == s).count();
    let (p, w, f) = (count("pass"), count("warn"), count("fail"));
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
