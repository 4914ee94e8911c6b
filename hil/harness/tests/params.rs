//! `--params FILE` on the harness: the plant, the reference and the device's
//! configuration all follow the parameters, at 3 MN creep and at conicity 0.4 with the
//! lead, through `hil run`, `hil golden` and the binary.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::path::PathBuf;
use std::process::{Command, Output};

use hil::run::{run, Law, RunOptions, Target};
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::run_continuous;
use wheelset_report::Verdict;
use wheelset_runtime::RuntimeConfig;

fn hil(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(args)
        .output()
        .expect("hil starts")
}

fn tmp(name: &str) -> PathBuf {
    let d = PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("params");
    std::fs::create_dir_all(&d).unwrap();
    d.join(name)
}

/// A parameter file with `text`, and the parameters it holds.
fn params_file(name: &str, text: &str) -> (PathBuf, Params) {
    let p = tmp(name);
    std::fs::write(&p, text).unwrap();
    (p.clone(), Params::from_file(&p).unwrap())
}

fn opts(params: &Params) -> RunOptions {
    RunOptions {
        scenario: "curve".into(),
        control: Law::Lead,
        params: params.clone(),
        progress: false,
        ..RunOptions::default()
    }
}

fn peak_y(t: &wheelset_plant::sim::Trajectory) -> f64 {
    t.records.iter().map(|r| r.y_m.abs()).fold(0.0, f64::max)
}

/// The lead at 3 MN creep (f11 = f22) and at conicity 0.4 passes through the harness;
/// the plant ran at those parameters (its trajectory is not the default one), the
/// reference is the continuous loop of the scenario loaded at them, and the report
/// names the parameters applied.
#[test]
fn the_lead_passes_at_3_mn_and_at_conicity_0_4_with_plant_and_reference_following() {
    let default = run(&opts(&Params::default())).unwrap();
    for (name, text) in [
        ("creep_3mn.toml", "f11 = 3e6\nf22 = 3e6\n"),
        ("conicity_0.4.toml", "lambda = 0.4\n"),
    ] {
        let (_, p) = params_file(name, text);
        assert_ne!(p, Params::default());
        let out = run(&opts(&p)).unwrap();
        let r = &out.report;
        println!(
            "{name}: verdict {}, peak |y| {:.4} mm (default {:.4} mm)",
            r.verdict,
            peak_y(&out.trajectory) * 1e3,
            peak_y(&default.trajectory) * 1e3
        );
        assert_eq!(r.verdict, Verdict::Pass, "{name}: {:?}", r.numerics);
        // The parameters applied: the file's (the curve has no [params]).
        assert_eq!(r.params, p, "{name}");
        // The plant: another trajectory than at the default parameters.
        assert_ne!(
            peak_y(&out.trajectory),
            peak_y(&default.trajectory),
            "{name}: the plant did not follow"
        );
        // The reference: the continuous loop of the scenario at these parameters.
        let sc = Scenario::load("curve", &p).unwrap();
        let reference = run_continuous(&sc, wheelset_plant::control::YawLaw::Lead);
        assert_eq!(out.reference.records.len(), reference.records.len());
        assert!(
            out.reference
                .records
                .iter()
                .zip(&reference.records)
                .all(|(a, b)| a.y_m == b.y_m && a.t_psi_nm == b.t_psi_nm),
            "{name}: the reference did not follow"
        );
        // These are plant parameters: the device's configuration is the default one.
        assert_eq!(out.runtime, default.runtime, "{name}");
    }
}

/// Gains in the file reach the in-process device (a scenario's `k_active = 5.0e4`): its
/// configuration holds them, differs from the default, is the rule of `sim-host --loop
/// device`, and the torque follows the reference.
#[test]
fn the_device_configuration_follows_the_gains_of_the_file() {
    let (_, p) = params_file(
        "gains.toml",
        "k_active = 5.0e4\nlead_gain = 6.0\npi_kp = 0.8\n",
    );
    let short = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short.toml");
    let out = run(&RunOptions {
        scenario: short.into(),
        ..opts(&p)
    })
    .unwrap();
    let c = &out.runtime.control;
    assert_eq!(c.gain_k, p.k_active);
    assert_eq!(c.lead.k, p.k_active);
    assert_eq!(c.lead.a, p.lead_gain);
    assert_eq!(c.pi.kp, p.pi_kp);
    let d = RuntimeConfig::default().control;
    assert_ne!((c.gain_k, c.lead.a, c.pi.kp), (d.gain_k, d.lead.a, d.pi.kp));
    let sc = Scenario::load(short, &p).unwrap();
    let mut want = wheelset_loop::device_loop::runtime_config(
        &sc,
        wheelset_plant::control::YawLaw::Lead,
        &wheelset_loop::device_loop::DeviceOptions::default(),
    );
    want.control.base_rate_hz = out.runtime.control.base_rate_hz;
    assert_eq!(out.runtime, want);
    let torque = out
        .report
        .numerics
        .signals
        .iter()
        .find(|s| s.name == "T_ctrl_Nm")
        .unwrap();
    assert_eq!(torque.verdict, Verdict::Pass, "{torque:?}");
}

/// A device elsewhere has its gains compiled in: a file that changes them is refused
/// before any target starts, naming the keys; plant parameters are not.
#[test]
fn gains_are_refused_for_a_device_elsewhere_naming_the_keys() {
    let (_, p) = params_file("remote.toml", "k_active = 5.0e4\nf11 = 3e6\n");
    let e = hil::run::remote_gains(&p, &Target::Qemu)
        .unwrap_err()
        .to_string();
    assert!(e.contains("k_active = 50000") && !e.contains("f11"), "{e}");
    assert!(e.contains("--target inproc"), "{e}");
    let e = run(&RunOptions {
        target: Target::Qemu,
        ..opts(&p)
    })
    .err()
    .unwrap()
    .to_string();
    assert!(e.contains("k_active"), "{e}");
    let (_, plant) = params_file("plant.toml", "f11 = 3e6\nlambda = 0.4\n");
    assert!(hil::run::remote_gains(&plant, &Target::Qemu).is_ok());
}

/// Golden vectors at the file's gains: both sides run the same configuration, which is
/// the default one at the default parameters and differs at other gains.
#[test]
fn golden_vectors_follow_the_gains() {
    use hil::golden::{run_host, vectors};
    use wheelset_loop::device_loop::runtime_for;
    assert_eq!(runtime_for(&Params::default()), RuntimeConfig::default());
    let (file, p) = params_file("golden.toml", "k_active = 5.0e4\n");
    let rt = runtime_for(&p);
    assert_eq!(rt.control.lead.k, 5.0e4);
    let v = &vectors().unwrap()[0];
    assert_ne!(
        run_host(v, rt).unwrap(),
        run_host(v, RuntimeConfig::default()).unwrap()
    );
    let out = hil(&["golden", "--params", file.to_str().unwrap()]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(stdout.contains("agree bit for bit on 6 of 6"), "{stdout}");
    // A device elsewhere refuses them (before QEMU starts).
    let out = hil(&[
        "golden",
        "--target",
        "qemu",
        "--params",
        file.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--params") && stderr.contains("k_active"),
        "{stderr}"
    );
}

/// The binary: `hil run --params FILE` writes the applied parameters into its JSON; a
/// bad file exits 2 naming the flag and the key.
#[test]
fn the_binary_takes_params_and_refuses_a_bad_file() {
    let (file, p) = params_file("cli_3mn.toml", "f11 = 3e6\nf22 = 3e6\n");
    let json = tmp("cli_3mn.json");
    let short = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short.toml");
    let out = hil(&[
        "run",
        "--scenario",
        short,
        "--params",
        file.to_str().unwrap(),
        "--json",
        json.to_str().unwrap(),
    ]);
    assert_eq!(
        out.status.code(),
        Some(0),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["params"]["f11"].as_f64(), Some(p.f11));
    assert_eq!(v["params"]["f22"].as_f64(), Some(p.f22));
    assert_eq!(v["params"]["lambda"].as_f64(), Some(p.lambda));
    let (bad, _) = (tmp("bad.toml"), ());
    std::fs::write(&bad, "lambda = 5.0\n").unwrap();
    let out = hil(&["run", "--params", bad.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--params") && stderr.contains("lambda"),
        "{stderr}"
    );
    let out = hil(&["run", "--params", "/nonexistent/p.toml"]);
    assert_eq!(out.status.code(), Some(2));
}

/// `hil audit --params FILE`: the audited configuration takes the file's gains; a bad
/// file is refused naming the flag, before any audit runs.
#[test]
fn the_audit_takes_the_gains_of_the_file() {
    use clap::Parser;
    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        a: wheelset_audit::AuditArgs,
    }
    let (file, p) = params_file("audit.toml", "k_active = 5.0e4\nlead_zero = 30.0\n");
    let cli = Cli::try_parse_from(["audit", "--params", file.to_str().unwrap()]).unwrap();
    let c = wheelset_audit::config_of(&cli.a);
    assert_eq!(c.gain_k, p.k_active);
    assert_eq!(c.lead.w1, p.lead_zero);
    assert_eq!(c, wheelset_loop::device_loop::runtime_for(&p).control);
    assert_eq!(
        wheelset_audit::config_of(&wheelset_audit::AuditArgs::default()),
        wheelset_control::Config::default()
    );
    let bad = tmp("audit_bad.toml");
    std::fs::write(&bad, "k_active = -1.0\n").unwrap();
    let out = hil(&["audit", "--params", bad.to_str().unwrap()]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--params") && stderr.contains("k_active"),
        "{stderr}"
    );
}
