//! Bad scenario and parameter files: each gets its typed error naming file and key;
//! none panics; the command line exits with code 2.

#![allow(clippy::unwrap_used)]

use std::process::Command;
use wheelset_plant::error::ConfigError;
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;

const GOOD: &str = "duration_s = 2.0\n[[track]]\nt_s = 0.0\n";

fn scenario_err(src: &str) -> ConfigError {
    match Scenario::from_toml_str(src, "bad.toml", &Params::default()) {
        Ok(_) => panic!("accepted:\n{src}"),
        Err(e) => e,
    }
}

#[test]
fn good_minimal_scenario_loads() {
    let sc = Scenario::from_toml_str(GOOD, "good.toml", &Params::default()).unwrap();
    assert_eq!(sc.name, "good");
    assert_eq!(sc.duration_ns, 2_000_000_000);
}

#[test]
fn each_bad_scenario_names_its_key() {
    let cases: &[(&str, &str)] = &[
        ("duration_s = 2.0\nspeed = 3\n", "speed"),
        ("duration_s = -1.0\n", "duration_s"),
        ("[[track]]\nt_s = 0.0\n", "duration_s"), // missing
        (
            "duration_s = 2.0\n[[track]]\nt_s = 0.0\nradius = 100.0\n",
            "radius",
        ),
        (
            "duration_s = 2.0\n[[track]]\nt_s = 1.0\n[[track]]\nt_s = 0.5\n",
            "track[1].t_s",
        ),
        (
            "duration_s = 2.0\n[[track]]\nt_s = 0.0\nradius_m = 10.0\n",
            "track[0].radius_m",
        ),
        (
            "duration_s = 2.0\n[[track]]\nt_s = 0.0\nradius_m = 3000.0\ncurvature_per_m = 1e-3\n",
            "track[0].radius_m",
        ),
        (
            "duration_s = 2.0\n[[track]]\nt_s = 0.0\ncant_deg = 45.0\n",
            "track[0].cant_deg",
        ),
        ("duration_s = 2.0\n[sim]\ndt_s = 1.0\n", "sim.dt_s"),
        (
            "duration_s = 2.0\n[sim]\ndt_s = 1e-4\noutput_dt_s = 1.5e-4\n",
            "sim.output_dt_s",
        ),
        (
            "duration_s = 2.0\n[traction]\ndemand_nm = 1e9\nt_on_s = 1.0\n",
            "traction.demand_nm",
        ),
        (
            "duration_s = 2.0\n[traction]\ndemand_nm = 1.0\nt_on_s = -1.0\n",
            "traction.t_on_s",
        ),
        (
            "duration_s = 2.0\n[resistance]\nf_run_n = nan\nt_on_s = 1.0\n",
            "resistance.f_run_n",
        ),
        ("duration_s = 2.0\n[params]\nf11 = 0.0\n", "params.f11"),
        (
            "duration_s = 2.0\n[params]\nwheel_mass = 3.0\n",
            "params.wheel_mass",
        ),
        ("duration_s = 2.0\n[plant]\naxle = \"bendy\"\n", "axle"),
    ];
    for (src, key) in cases {
        let e = scenario_err(src);
        assert!(e.to_string().starts_with("bad.toml:"), "{e}");
        assert_eq!(e.key(), Some(*key), "for\n{src}\ngot: {e}");
        assert!(e.to_string().contains(key), "{e}");
    }
}

#[test]
fn syntax_errors_are_parse_errors_with_a_line() {
    let e = scenario_err("duration_s = 2.0\n[[track]\nt_s = 0\n");
    match e {
        ConfigError::Parse { line, .. } => assert_eq!(line, Some(2)),
        other => panic!("{other}"),
    }
    let e = scenario_err("duration_s = \"long\"\n");
    assert!(matches!(e, ConfigError::Parse { .. }), "{e}");
}

#[test]
fn bad_parameter_files_name_their_key() {
    for (src, key) in [
        ("m = -3.0\n", "m"),
        ("lambda = 2.0\n", "lambda"),
        ("k_gear = 0.0\n", "k_gear"),
        ("v = 0.0\n", "v"),
        ("pi_ti = inf\n", "pi_ti"),
        ("conicity = 0.2\n", "conicity"),
    ] {
        let e = Params::from_toml_str(src, "p.toml").unwrap_err();
        assert_eq!(e.key(), Some(key), "{e}");
    }
}

fn sim_host(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(args)
        .output()
        .expect("run sim-host")
}

#[test]
fn cli_exits_2_on_bad_input_and_names_the_problem() {
    let dir = std::env::temp_dir().join(format!("sim-host-files-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let bad = dir.join("bad.toml");
    std::fs::write(&bad, "duration_s = 2.0\nbogus_key = 1\n").unwrap();
    let badp = dir.join("p.toml");
    std::fs::write(&badp, "f22 = -1.0\n").unwrap();
    let bad_s = bad.to_str().unwrap();
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (
            vec!["run", "--scenario", bad_s, "--control", "lead"],
            "bogus_key",
        ),
        (vec!["run", "--scenario", "no-such-track"], "no-such-track"),
        (vec!["run", "--control", "sideways"], "sideways"),
        (vec!["run", "--params", badp.to_str().unwrap()], "f22"),
        (vec!["fly"], "fly"),
        (vec!["modes", "--points", "1", "--json", "x.json"], "points"),
        (vec!["modes", "--case", "e", "--json", "x.json"], "case"),
        (vec!["modes"], "--json"),
        (
            vec![
                "modes",
                "--json",
                "x.json",
                "--params",
                badp.to_str().unwrap(),
            ],
            "f22",
        ),
    ];
    for (args, needle) in cases {
        let out = sim_host(&args);
        assert_eq!(out.status.code(), Some(2), "{args:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn cli_help_works_everywhere() {
    for args in [
        vec!["--help"],
        vec!["run", "--help"],
        vec!["modes", "--help"],
    ] {
        let out = sim_host(&args);
        assert_eq!(out.status.code(), Some(0), "{args:?}");
        assert!(String::from_utf8_lossy(&out.stdout).contains("Usage"));
    }
}
