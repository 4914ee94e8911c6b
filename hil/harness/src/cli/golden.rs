//! `hil golden`: open-loop golden vectors on the host and on a target, compared bit for
//! bit.

use std::path::PathBuf;

use clap::Args;
use hil::run::{run, RunOptions, Target};
use wheelset_report::Verdict;
use wheelset_targets::qemu::machine::Machine;

use super::{input, load_params, run_error, unavailable, written, Failure};

#[derive(Args, Clone)]
pub(crate) struct GoldenArgs {
    /// Where the target side runs: inproc or qemu.
    #[arg(long, default_value = "inproc", value_parser = parse_golden_target)]
    target: Target,
    /// The QEMU target's emulated board: mps2-an386 (Cortex-M4F) or mps2-an385
    /// (Cortex-M3, no FPU; `target/fw/wheelset-qemu-m3.elf`).
    #[arg(long, default_value = "mps2-an386")]
    machine: Machine,
    /// Parameter file (TOML, as `sim-host --params`): the device's gains and motor
    /// constants on both sides follow it (a target other than inproc has its gains
    /// compiled in and refuses a file that changes them); `--record` runs the closed loop
    /// of `curve` at these parameters.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Write the comparison (JSON).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Instead of comparing: re-record the sensor stream of the `recorded_curve` vector
    /// from the in-process closed loop of `curve` (4.9-5.3 s) into this CSV file.
    #[arg(long)]
    record: Option<PathBuf>,
}

pub(crate) fn parse_golden_target(s: &str) -> Result<Target, String> {
    super::inproc_or_qemu(
        s,
        "golden vectors start a fresh QEMU per vector (--target qemu), not one started by hand",
        "golden vectors run on inproc or qemu",
    )
}

pub(crate) fn cmd_golden(g: &GoldenArgs) -> Result<Verdict, Failure> {
    use hil::golden;
    let params = load_params(g.params.as_deref())?;
    if let Some(path) = &g.record {
        let out = run(&RunOptions {
            params,
            ..RunOptions::default()
        })
        .map_err(|e| input(e.to_string()))?;
        let (from, to) = (4_900_000_000 / out.period_ns, 5_300_000_000 / out.period_ns);
        let rows = out
            .sensor_codes
            .iter()
            .take(to as usize)
            .skip(from as usize);
        let text: String = std::iter::once("y_dot_um_s,i_a_ma,omega_mrad_s,demand_nm\n".into())
            .chain(rows.map(|c| format!("{},{},{},{}\n", c.y_dot, c.current, c.speed, c.demand)))
            .collect();
        written(path, std::fs::write(path, text))?;
        say!(
            "golden: recorded {} samples into {}",
            to - from,
            path.display()
        );
        return Ok(Verdict::Pass);
    }
    let vectors = golden::vectors().map_err(|e| input(format!("golden vectors: {e}")))?;
    let opts = RunOptions {
        target: g.target.clone(),
        machine: g.machine,
        // As the host side's runtime (its own configuration: wheel-slip protection off until a
        // Config); `hil run` turns it on by default.
        wsp: false,
        ..RunOptions::default()
    };
    if g.target != Target::InProc {
        hil::run::remote_gains(&params, &g.target).map_err(|e| input(format!("--params: {e}")))?;
    }
    let rt = wheelset_loop::device_loop::runtime_for(&params);
    let period_ns = 1_000_000_000 / u64::from(rt.control.base_rate_hz);
    let mut results = Vec::new();
    for v in &vectors {
        let host = golden::run_host(v, rt).map_err(|e| input(e.to_string()))?;
        // A fresh device per vector: every vector starts from reset.
        let mut tr = hil::run::open_transport(&opts, rt).map_err(run_error)?;
        let target = golden::run_target(v, tr.as_mut(), period_ns).map_err(unavailable)?;
        let c = golden::compare(v, &host, &target);
        say!(
            "{:<15} {:>5} ticks  host vs {}: {}  (peak |T_psi| {} x 0.1 N m, |u_a| {} x 10 mV)  {}",
            c.name,
            c.ticks,
            g.target,
            if c.identical {
                "identical bit for bit".to_string()
            } else {
                format!(
                    "{} ticks DIFFER, first at tick {}",
                    c.mismatches,
                    c.first_mismatch.map_or_else(
                        || "-".to_string(),
                        |(t, host, target)| {
                            let out = |o: &hil::golden::Out| {
                                format!("T_psi {} dNm, u_a {} cV", o.t_psi_dnm, o.u_a_cv)
                            };
                            format!(
                                "{t} (host {}, target {})",
                                out(&host),
                                target.as_ref().map_or_else(|| "missing".to_string(), out)
                            )
                        }
                    )
                )
            },
            c.host_peak.0,
            c.host_peak.1,
            c.about
        );
        results.push(c);
    }
    let all = results.iter().all(|c| c.identical);
    say!(
        "golden: host and {} {} on {} of {} vectors",
        g.target,
        if all { "agree bit for bit" } else { "DISAGREE" },
        results.iter().filter(|c| c.identical).count(),
        results.len()
    );
    if let Some(p) = &g.json {
        let doc = serde_json::json!({
            "verdict": if all { "pass" } else { "fail" },
            "target": g.target.to_string(),
            "vectors": results,
        });
        written(p, hil::report::write_json(&doc, p))?;
    }
    Ok(if all { Verdict::Pass } else { Verdict::Fail })
}
