//! Golden vectors: host and the in-process target agree bit for bit; a target whose
//! arithmetic differs is caught; the command line says so.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use hil::golden::{compare, run_host, run_target, vectors};
use wheelset_loop::inproc::{DeviceFault, InProc};
use wheelset_loop::sim_link::LinkConfig;
use wheelset_runtime::RuntimeConfig;

fn target(fault: DeviceFault) -> InProc {
    InProc::try_new(RuntimeConfig::default(), &LinkConfig::default(), fault).unwrap()
}

#[test]
fn host_and_in_process_target_agree_bit_for_bit() {
    for v in vectors().unwrap() {
        let host = run_host(&v, RuntimeConfig::default()).unwrap();
        let got = run_target(&v, &mut target(DeviceFault::None), 200_000).unwrap();
        let c = compare(&v, &host, &got);
        assert!(c.identical, "{}: {c:?}", v.name);
        assert_eq!(c.target_ticks, v.samples.len());
    }
}

#[test]
fn a_target_with_different_arithmetic_is_caught() {
    let vs = vectors().unwrap();
    let v = vs.iter().find(|v| v.name == "y_step").unwrap();
    let host = run_host(v, RuntimeConfig::default()).unwrap();
    let got = run_target(v, &mut target(DeviceFault::WrongSign), 200_000).unwrap();
    let c = compare(v, &host, &got);
    assert!(!c.identical);
    // Before the step the torque is zero either way; from the step on, every tick differs.
    let (first, _, _) = c.first_mismatch.unwrap();
    assert_eq!(first, 100);
    assert_eq!(c.mismatches, v.samples.len() - 100);
}

#[test]
fn the_command_reports_agreement_and_refuses_a_serial_target() {
    let json = std::path::PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("golden.json");
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(["golden", "--json", json.to_str().unwrap()])
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert_eq!(out.status.code(), Some(0), "{stdout}");
    assert!(
        stdout.contains("agree bit for bit on 6 of 6 vectors"),
        "{stdout}"
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert_eq!(v["verdict"], "pass");
    assert_eq!(v["vectors"].as_array().unwrap().len(), 6);
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_hil"))
        .args(["golden", "--target", "serial:/dev/ttyACM0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("inproc or qemu"));
}
