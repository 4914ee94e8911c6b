//! The binary: `hil` alone is `hil run`; the JSON document has the promised fields; bad
//! flags and files exit with code 2 and a clear message, never a panic.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;
use std::process::{Command, Output};

fn hil(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(args)
        .output()
        .expect("hil starts")
}

fn data(name: &str) -> String {
    format!("{}/tests/data/{name}", env!("CARGO_MANIFEST_DIR"))
}

fn tmp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("cli");
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

#[test]
fn no_subcommand_is_run_and_writes_the_verdict_document() {
    let json = tmp("default.json");
    let csv = tmp("default.csv");
    let report = tmp("report");
    let short = data("short.toml");
    let out = hil(&[
        "--scenario",
        &short,
        "--json",
        json.to_str().unwrap(),
        "--csv",
        csv.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("verdict: pass"), "{stdout}");
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["verdict"], "pass");
    assert_eq!(v["target"], "inproc");
    assert_eq!(v["scenario"], "short");
    assert!(v["timing"].is_object() && v["numerics"].is_object());
    let f = &v["frames"];
    let n = |k: &str| f[k].as_u64().unwrap();
    assert_eq!(
        n("sent"),
        n("received") + n("rejected") + n("dropped") + n("in_flight")
    );
    assert!(n("sent") > 30_000);
    // The CSV has sim-host's columns, one row per output sample.
    let text = std::fs::read_to_string(&csv).unwrap();
    let header = text.lines().next().unwrap();
    assert_eq!(header, wheelset_plant::sim::Record::COLUMNS.join(","));
    assert_eq!(text.lines().count(), 1 + 3001);
    // The report is readable without the harness: Markdown and SVG.
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert!(md.contains("## Timing") && md.contains("trajectories.svg"));
    assert!(md.contains("## Stability monitor") && md.contains("(monitor.svg)"));
    for svg in ["trajectories.svg", "exec_histogram.svg", "monitor.svg"] {
        let s = std::fs::read_to_string(report.join(svg)).unwrap();
        assert!(s.starts_with("<svg"), "{svg}");
        let problems = wheelset_report::svg::lint::problems(&s);
        assert!(problems.is_empty(), "{svg}: {problems:#?}");
    }
    // In process the device's exec is a simulated 0 ns: the histogram says so instead
    // of drawing one bar at 0, over the axis of the budgets a measured tick is held to.
    let h = std::fs::read_to_string(report.join("exec_histogram.svg")).unwrap();
    assert!(h.contains("not measured in process"), "{h}");
    assert!(!h.contains("fill=\"#56B4E9\""), "a bar was drawn");
    assert!(
        h.contains(">period T = ") && h.contains(">CPU fail "),
        "the budgets are not drawn: {h}"
    );
    // The plots draw what they judge against: the monitor's threshold, and beside each
    // signal the allowed error and the fail level of the numerics.
    let m = std::fs::read_to_string(report.join("monitor.svg")).unwrap();
    assert!(m.contains(">alarm threshold: RMS 30 mm/s</text>"), "{m}");
    let t = std::fs::read_to_string(report.join("trajectories.svg")).unwrap();
    assert_eq!(t.matches(">allowed ±").count(), 5, "{t}");
    assert_eq!(t.matches(">fail above ±").count(), 5, "{t}");
    // `hil run` with the same flags gives the same verdict document.
    let json2 = tmp("run.json");
    let out = hil(&[
        "run",
        "--scenario",
        &short,
        "--json",
        json2.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0));
    let v2: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json2).unwrap()).unwrap();
    assert_eq!(v2["frames"], v["frames"]);
    assert_eq!(v2["numerics"], v["numerics"]);
}

#[test]
fn a_warning_exits_zero_and_says_so() {
    let short = data("short.toml");
    // 45 us of execution puts the latency just above 0.8 T (at 5 Mbaud): a warning,
    // not a failure.
    let out = hil(&["run", "--scenario", &short, "--device-fault", "slow:45"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("verdict: warn"), "{stdout}");
    assert!(stdout.contains("timing.latency_max"), "{stdout}");
}

#[test]
fn a_failing_check_exits_non_zero() {
    let short = data("short.toml");
    let report = tmp("failing");
    let out = hil(&[
        "run",
        "--scenario",
        &short,
        "--device-fault",
        "wrong-sign",
        "--report",
        report.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(1));
    assert!(String::from_utf8_lossy(&out.stdout).contains("verdict: fail"));
    // A failing run's figures (errors far beyond their limits, a run cut short) are laid
    // out as cleanly as a passing one's.
    for svg in ["trajectories.svg", "monitor.svg"] {
        let s = std::fs::read_to_string(report.join(svg)).unwrap();
        let problems = wheelset_report::svg::lint::problems(&s);
        assert!(problems.is_empty(), "{svg}: {problems:#?}");
    }
}

#[test]
fn bad_flags_and_files_exit_2_with_a_clear_message() {
    let short = data("short.toml");
    let bad_syntax = data("bad_syntax.toml");
    let bad_budget = tmp("bad_budget.toml");
    std::fs::write(
        &bad_budget,
        "[timing]\ncpu_max = { warn = 0.9, fail = 0.1 }\n",
    )
    .unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["--nope"], "--nope"),
        (vec!["run", "--target", "usb"], "unknown target"),
        (vec!["run", "--target", "serial:"], "unknown target"),
        (vec!["run", "--control", "pid"], "pid"),
        (vec!["run", "--faults", "ber=2"], "outside [0, 1)"),
        (vec!["run", "--scenario", "/no/such/file.toml"], "file.toml"),
        (vec!["run", "--scenario", "nonsense"], "nonsense"),
        (vec!["run", "--scenario", &bad_syntax], "bad_syntax.toml"),
        (
            vec![
                "run",
                "--scenario",
                &short,
                "--budget",
                "/no/such/budget.toml",
            ],
            "budget.toml",
        ),
        (
            vec![
                "run",
                "--scenario",
                &short,
                "--budget",
                bad_budget.to_str().unwrap(),
            ],
            "warn <= fail",
        ),
        (
            vec!["run", "--scenario", &short, "--set", "timing.nope=1"],
            "nope",
        ),
        (vec!["run", "--scenario", &short, "--set", "x"], "KEY=VALUE"),
        (
            vec!["run", "--device-fault", "melt"],
            "unknown device fault",
        ),
        (vec!["run", "--device-fault", "stall"], "needs the time T"),
        (
            vec!["run", "--scenario", &short, "--device-fault", "stall:1"],
            "needs a device with a running watchdog",
        ),
        (
            vec!["run", "--target", "qemu", "--device-fault", "stall:1"],
            "needs --target qemu-free",
        ),
        (
            vec!["run", "--scenario", &short, "--baud", "115200"],
            "link budget exceeded",
        ),
        (vec!["run", "--baud", "0"], "baud"),
        (
            vec!["run", "--target", "qemu", "--faults", "ber=1e-3"],
            "simulated link",
        ),
        (
            vec![
                "run",
                "--target",
                "serial:/dev/null",
                "--device-fault",
                "slow",
            ],
            "in-process",
        ),
        (
            vec![
                "run",
                "--scenario",
                &short,
                "--json",
                "/proc/no/such/dir/x.json",
            ],
            "--json /proc/no/such/dir/x.json: cannot create",
        ),
    ];
    for (args, needle) in cases {
        let out = hil(&args);
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert!(
            err.contains(needle),
            "{args:?}: missing `{needle}` in {err}"
        );
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn a_missing_serial_port_is_a_clear_target_error() {
    let out = hil(&["run", "--target", "serial:/dev/no-such-port", "--quiet"]);
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(3), "{err}");
    assert!(
        err.contains("/dev/no-such-port") && err.contains("cannot open"),
        "{err}"
    );
    assert!(!err.contains("panicked"), "{err}");
}
