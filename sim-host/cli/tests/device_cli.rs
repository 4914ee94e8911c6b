//! `sim-host run ... --loop device` from the command line: the interface scripts use.

use std::process::Command;

fn sim_host(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_sim-host"))
        .args(args)
        .output()
        .expect("sim-host runs");
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn device_loop_with_faults_writes_the_csv_and_accounts_for_every_frame() {
    let dir = std::env::temp_dir().join(format!("sim-host-device-cli-{}", std::process::id()));
    let csv = dir.join("device.csv");
    let csv_s = csv.to_str().expect("utf-8 path");
    let (code, out, err) = sim_host(&[
        "run",
        "--scenario",
        "curve",
        "--control",
        "lead",
        "--loop",
        "device",
        "--faults",
        "ber=1e-3,drop=0.1,outage=8.0:0.05",
        "--seed",
        "3",
        "--csv",
        csv_s,
    ]);
    assert_eq!(code, 0, "{out}{err}");
    // Both directions accounted, and the equation holds.
    assert_eq!(out.matches("[adds up]").count(), 2, "{out}");
    assert!(out.contains("host -> device: sent") && out.contains("device -> host: sent"));
    // The outage is entered and left. The device's own counts come from the Status
    // fetched after the run over the same faulty link: while its requests are lost the
    // device runs on held samples and may enter the safe state once more, not left by
    // the time the Status gets through (the counts then differ by one).
    let count = |key: &str| -> u32 {
        let rest = out
            .split(key)
            .nth(1)
            .unwrap_or_else(|| panic!("{key}: {out}"));
        rest.trim_start()
            .split(|c: char| !c.is_ascii_digit())
            .next()
            .and_then(|d| d.parse().ok())
            .unwrap_or_else(|| panic!("{key}: {out}"))
    };
    let (entries, exits) = (count("safe entries"), count("exits"));
    assert!(
        exits >= 1 && (entries == exits || entries == exits + 1),
        "{out}"
    );
    assert!(out.contains("vs continuous reference"), "{out}");
    let text = std::fs::read_to_string(&csv).expect("csv written");
    let header = text.lines().next().expect("header");
    assert!(header.starts_with("t_s,y_m,psi_rad,T_psi_Nm,Fx_R_N,Fx_L_N,Fy_N,v_mps,i_a_A,u_a_V"));
    assert!(
        header.ends_with(",seq,seq_echo,frame_age,flags,fresh"),
        "{header}"
    );
    let rows = text.lines().count() - 1;
    assert!(rows >= 20_000, "{rows} rows");
    // Every row has as many fields as the header.
    let n = header.split(',').count();
    assert!(text.lines().all(|l| l.split(',').count() == n));
    let _ = std::fs::remove_dir_all(&dir);
}

#[test]
fn bad_faults_and_a_slow_link_exit_2_with_the_reason() {
    let (code, _, err) = sim_host(&["run", "--loop", "device", "--faults", "ber=1e-3,jitter=4"]);
    assert_eq!(code, 2);
    assert!(
        err.contains("jitter=4") && err.contains("unknown key"),
        "{err}"
    );
    let (code, _, err) = sim_host(&["run", "--loop", "device", "--baud", "115200"]);
    assert_eq!(code, 2);
    assert!(
        err.contains("link budget exceeded") && err.contains("115200 baud"),
        "{err}"
    );
    let (code, _, err) = sim_host(&["run", "--loop", "sideways"]);
    assert_eq!(code, 2, "{err}");
}
