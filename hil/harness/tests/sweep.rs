//! `hil sweep`: every grid point in the closed loop; the records are the runs
//! of `hil run` at the points' parameters; `--shard I/N` parts merged by `hil sweep
//! merge` are the document of a single run, byte for byte; bad specs are refused naming
//! the flag.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;
use std::process::{Command, Output};

use hil::run::{run, Law, RunOptions};
use wheelset_plant::params::Params;

fn hil(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(args)
        .output()
        .expect("hil starts")
}

fn tmp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("sweep");
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

const SHORT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short.toml");
const GRID: [&str; 4] = ["--param", "f11=3e6..1e7:2", "--param", "lambda=0.1..0.4:3"];

fn sweep(extra: &[&str]) -> Output {
    let mut args = vec!["sweep", "--scenario", SHORT, "--quiet"];
    args.extend(GRID);
    args.extend(extra);
    hil(&args)
}

fn ok(out: &Output) -> String {
    let stdout = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(
        matches!(out.status.code(), Some(0 | 1)),
        "{stdout}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    stdout
}

#[test]
fn shards_merged_are_the_single_run_byte_for_byte_and_records_are_the_runs() {
    let (whole, s0, s1, s2, merged) = (
        tmp("whole.json"),
        tmp("s0.json"),
        tmp("s1.json"),
        tmp("s2.json"),
        tmp("merged.json"),
    );
    let report = tmp("report");
    ok(&sweep(&[
        "--json",
        whole.to_str().unwrap(),
        "--report",
        report.to_str().unwrap(),
        "--jobs",
        "2",
    ]));
    for (i, f) in [&s0, &s1, &s2].iter().enumerate() {
        let shard = format!("{i}/3");
        ok(&sweep(&[
            "--shard",
            &shard,
            "--json",
            f.to_str().unwrap(),
            "--jobs",
            "1",
        ]));
    }
    // Any order of the parts.
    let stdout = ok(&hil(&[
        "sweep",
        "merge",
        s2.to_str().unwrap(),
        s0.to_str().unwrap(),
        s1.to_str().unwrap(),
        "--json",
        merged.to_str().unwrap(),
    ]));
    assert!(stdout.contains("6 of 6 points"), "{stdout}");
    let (a, b) = (
        std::fs::read_to_string(&whole).unwrap(),
        std::fs::read_to_string(&merged).unwrap(),
    );
    assert_eq!(a, b, "the merged document differs from the single run's");
    let shard0: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&s0).unwrap()).unwrap();
    assert_eq!(shard0["shard"]["index"], 0);
    assert_eq!(shard0["records"].as_array().unwrap().len(), 2);

    // The document: one record per point with its parameters (f22 follows f11), the
    // verdict, peak |y| and the failing checks; each record is `hil run` at the point.
    let v: serde_json::Value = serde_json::from_str(&a).unwrap();
    assert_eq!(v["sweep"]["points"], 6);
    let recs = v["records"].as_array().unwrap();
    assert_eq!(recs.len(), 6);
    let s = &v["summary"];
    assert_eq!(
        s["pass"].as_u64().unwrap() + s["warn"].as_u64().unwrap() + s["fail"].as_u64().unwrap(),
        6
    );
    let mut peaks = Vec::new();
    for (i, r) in recs.iter().enumerate() {
        assert_eq!(r["index"], i);
        let p = &r["params"];
        assert_eq!(p["f22"], p["f11"]);
        assert!(r["failing"].is_array());
        let (f11, lambda) = (p["f11"].as_f64().unwrap(), p["lambda"].as_f64().unwrap());
        // The last axis fastest.
        assert_eq!(f11, [3e6, 1e7][i / 3]);
        assert!((lambda - [0.1, 0.25, 0.4][i % 3]).abs() < 1e-12, "{lambda}");
        peaks.push(r["peak_abs_y_m"].as_f64().unwrap());
    }
    assert!(peaks.windows(2).any(|w| w[0] != w[1]), "{peaks:?}");
    // Point 4 (f11 1e7, lambda 0.25) through hil run.
    let text = format!(
        "f11 = 1e7\nf22 = 1e7\nlambda = {}\n",
        recs[4]["params"]["lambda"]
    );
    let params = Params::from_toml_str(&text, "p").unwrap();
    let out = run(&RunOptions {
        scenario: SHORT.into(),
        control: Law::Lead,
        params,
        progress: false,
        ..RunOptions::default()
    })
    .unwrap();
    let peak = out
        .trajectory
        .records
        .iter()
        .map(|r| r.y_m.abs())
        .fold(0.0, f64::max);
    assert_eq!(recs[4]["peak_abs_y_m"].as_f64().unwrap(), peak);
    assert_eq!(recs[4]["verdict"], out.report.verdict.to_string());
    assert_eq!(
        recs[4]["failing"].as_array().unwrap().len(),
        hil::sweep::failing(&out.report).len()
    );

    // The report: a table row per point and a cell per point in each heat map.
    let md = std::fs::read_to_string(report.join("report.md")).unwrap();
    assert_eq!(
        md.lines()
            .filter(|l| l.starts_with("| ") && l.contains(" | 1.00e7 |"))
            .count(),
        3,
        "{md}"
    );
    for svg in ["verdict.svg", "peak_y.svg"] {
        let t = std::fs::read_to_string(report.join(svg)).unwrap();
        assert_eq!(t.matches(r#"<rect class="cell""#).count(), 6, "{svg}");
        let problems = wheelset_report::svg::lint::problems(&t);
        assert!(problems.is_empty(), "{svg}: {problems:#?}");
    }

    // A part left out, a part twice, another campaign: refused with the reason.
    let out = hil(&[
        "sweep",
        "merge",
        s0.to_str().unwrap(),
        s1.to_str().unwrap(),
        "--json",
        merged.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing"));
    let out = hil(&[
        "sweep",
        "merge",
        s0.to_str().unwrap(),
        s0.to_str().unwrap(),
        "--json",
        merged.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("more than one"));
    let mut other: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&s2).unwrap()).unwrap();
    other["sweep"]["seed"] = 7.into();
    let s2x = tmp("s2_other.json");
    std::fs::write(&s2x, other.to_string()).unwrap();
    let out = hil(&[
        "sweep",
        "merge",
        s0.to_str().unwrap(),
        s1.to_str().unwrap(),
        s2x.to_str().unwrap(),
        "--json",
        merged.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("another campaign"));
}

#[test]
fn bad_specs_are_refused_naming_the_flag() {
    let json = tmp("bad.json");
    let j = json.to_str().unwrap();
    for (args, words) in [
        (vec!["--param", "f11=1.."], vec!["--param", "FROM..TO:N"]),
        (
            vec!["--param", "f11=1e6..1e7:0"],
            vec!["--param", "at least 1"],
        ),
        (
            vec!["--param", "foo=1..2:3"],
            vec!["--param", "unknown parameter `foo`"],
        ),
        (
            vec!["--param", "lambda=0.1..5:2"],
            vec!["--param", "lambda", "plausible range"],
        ),
        (
            vec!["--param", "f11=1e6", "--param", "f11=2e6"],
            vec!["--param", "twice"],
        ),
        (
            vec!["--param", "f11=1e6", "--shard", "2/2"],
            vec!["--shard", "below N"],
        ),
        (vec!["--param", "f11=1e6", "--jobs", "0"], vec!["--jobs"]),
        (
            vec!["--param", "f11=1e6", "--target", "serial:/dev/null"],
            vec!["--target"],
        ),
        (
            vec![
                "--param",
                "lambda=0.1..0.2:2",
                "--scenario",
                "actuator-fault",
            ],
            vec!["--param lambda", "[params]"],
        ),
    ] {
        let mut a = vec!["sweep", "--quiet", "--json", j];
        a.extend(&args);
        let out = hil(&a);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {stderr}");
        for w in words {
            assert!(stderr.contains(w), "{args:?}: `{w}` not in {stderr}");
        }
    }
    // Without --param or --json.
    let out = hil(&["sweep", "--json", j]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--param"));
    let out = hil(&["sweep", "--param", "f11=1e6"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--json"));
}
