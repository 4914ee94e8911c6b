//! `hil`: the harness's command line. `hil` alone is `hil run` with the defaults (the
//! in-process target, the `curve` scenario, the phase-lead law).
//!
//! Exit codes: 0 pass (warnings included), 1 a check failed, 2 bad flags or input files,
//! 3 the target could not be used (QEMU or the ELF missing, no such port, I/O).

use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::{Args, Parser, Subcommand, ValueEnum};
use hil::budget::{Budgets, Verdict};
use hil::inproc::DeviceFault;
use hil::machine::Machine;
use hil::report;
use hil::run::{run, Law, RunError, RunOptions, Target};
use sim_host::link::{Faults, LinkConfig};
use sim_host::params::Params;

/// `println!` that ignores a closed stdout (`hil | head`) instead of panicking.
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write as _;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

/// The HIL harness: the plant against the device wherever it runs, with timing and
/// numerics verdicts. Without a subcommand: `hil run`.
#[derive(Parser)]
#[command(name = "hil", version, about, args_conflicts_with_subcommands = true)]
struct Cli {
    #[command(subcommand)]
    cmd: Option<Cmd>,
    #[command(flatten)]
    run: RunArgs,
}

#[derive(Subcommand)]
enum Cmd {
    /// Closed loop of a scenario with the device on a target; timing, numerics and
    /// frame-accounting verdicts.
    Run(RunArgs),
    /// Open-loop golden vectors (steps, a chirp, saturation, a recorded sensor stream)
    /// through the fixed-point core on the host and on a target, compared bit for bit.
    Golden(GoldenArgs),
    /// Fixed-point accuracy audit of the control core (JSON + Markdown report).
    Audit(hil::audit::AuditArgs),
    /// The closed loop at every point of a parameter grid (`--param KEY=FROM..TO:N`,
    /// repeatable), on all cores: one JSON record per point, a Markdown table and heat
    /// maps. `hil sweep merge` joins `--shard` parts. Exit 1 if a point failed.
    Sweep(SweepCmd),
    /// A free-running stand-in for a board: the firmware's runtime on its own clock at
    /// the base rate behind a pseudo-terminal it creates (prints its path), answering
    /// every tick. For `hil run --target serial:PATH` (real-time pacing).
    Serve(ServeArgs),
}

#[derive(Args, Clone)]
struct ServeArgs {
    /// Create a pseudo-terminal and serve on it (the only transport so far).
    #[arg(long, required = true)]
    pty: bool,
    /// Base rate at start, Hz (a host Config frame may change it, as on the board).
    #[arg(long, default_value_t = wheelset_control::DEFAULT_BASE_RATE_HZ)]
    rate_hz: u32,
    /// Stop after this many seconds (default: until killed).
    #[arg(long)]
    duration_s: Option<f64>,
    /// Pin the stand-in to this CPU (default: the first one allowed).
    #[arg(long)]
    cpu: Option<usize>,
    /// Core clock the `exec` field is expressed in, Hz.
    #[arg(long, default_value_t = hil::run::DEFAULT_CPU_HZ)]
    cpu_hz: f64,
    /// Do not ask for SCHED_FIFO, locked memory or a pinned core.
    #[arg(long)]
    no_rt: bool,
    /// Write what the stand-in did (JSON) at the end.
    #[arg(long)]
    json: Option<PathBuf>,
}

#[derive(Args, Clone)]
struct GoldenArgs {
    /// Where the target side runs: inproc or qemu.
    #[arg(long, default_value = "inproc", value_parser = parse_golden_target)]
    target: Target,
    /// The QEMU target's emulated board: mps2-an386 (Cortex-M4F) or mps2-an385
    /// (Cortex-M3, no FPU; `target/fw/wheelset-qemu-m3.elf`).
    #[arg(long, default_value = "mps2-an386", value_parser = parse_machine)]
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

#[derive(Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
struct SweepCmd {
    #[command(subcommand)]
    sub: Option<SweepSub>,
    #[command(flatten)]
    args: SweepArgs,
}

#[derive(Subcommand)]
enum SweepSub {
    /// Joins the documents of `hil sweep --shard I/N` runs into the document a single
    /// run of the whole grid writes.
    Merge(MergeArgs),
}

#[derive(Args)]
struct MergeArgs {
    /// The shards' JSON documents (any order).
    #[arg(required = true, value_name = "FILE")]
    files: Vec<PathBuf>,
    /// Write the merged document here.
    #[arg(long, required = true, value_name = "OUT")]
    json: Option<PathBuf>,
    /// Also write the campaign's report (table and heat maps) into this directory.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
}

#[derive(Args)]
struct SweepArgs {
    /// One axis of the grid: `KEY=FROM..TO:N` (N linearly spaced values, both ends
    /// included) or `KEY=VALUE`; KEY is any parameter key (SI units). `f11` sets `f22`
    /// too unless `f22` is an axis. Repeatable; the last axis varies fastest.
    #[arg(long = "param", value_name = "KEY=FROM..TO:N", required = true, value_parser = parse_axis)]
    axes: Vec<hil::sweep::Axis>,
    /// Built-in scenario or a scenario TOML file.
    #[arg(long, default_value = "curve")]
    scenario: String,
    /// Base parameter file (TOML, as `hil run --params`); each point's values apply on
    /// top, the scenario's [params] on top of those.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Yaw control law of the device (and of the reference).
    #[arg(long, value_enum, default_value = "lead")]
    control: Control,
    /// Where the device runs: inproc or qemu (one QEMU per thread).
    #[arg(long, default_value = "inproc", value_parser = parse_sweep_target)]
    target: Target,
    /// Link faults at every point, e.g. `ber=1e-4,drop=0.01` (in-process link only).
    #[arg(long, default_value = "", value_parser = parse_faults)]
    faults: Faults,
    /// Seed of the link's faults, the same at every point.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Budget file (TOML; see `hil::budget`).
    #[arg(long)]
    budget: Option<PathBuf>,
    /// Override one budget (repeatable), as `hil run --set`.
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// Run only shard I of N (the points i with i mod N = I, from 0); join the parts
    /// with `hil sweep merge`.
    #[arg(long, value_name = "I/N", value_parser = parse_shard)]
    shard: Option<hil::sweep::Shard>,
    /// Threads (default: every core allowed).
    #[arg(long, value_name = "N")]
    jobs: Option<usize>,
    /// Write the campaign's document (JSON): one record per point.
    #[arg(long, required = true, value_name = "FILE")]
    json: Option<PathBuf>,
    /// Write the report (Markdown table, heat maps of the verdicts and of peak |y|) into
    /// this directory.
    #[arg(long, value_name = "DIR")]
    report: Option<PathBuf>,
    /// Never show the progress bar.
    #[arg(long)]
    quiet: bool,
}

fn parse_axis(s: &str) -> Result<hil::sweep::Axis, String> {
    s.parse()
}

fn parse_shard(s: &str) -> Result<hil::sweep::Shard, String> {
    s.parse()
}

fn parse_sweep_target(s: &str) -> Result<Target, String> {
    match s.parse::<Target>()? {
        t @ (Target::InProc | Target::Qemu) => Ok(t),
        Target::QemuAt(_) => {
            Err("a sweep starts its own QEMUs (--target qemu), not one started by hand".into())
        }
        Target::Serial(_) => {
            Err("a sweep runs on inproc or qemu (one board cannot run a grid in parallel)".into())
        }
    }
}

fn parse_machine(s: &str) -> Result<Machine, String> {
    s.parse()
}

fn parse_channel(s: &str) -> Result<hil::qemu::Channel, String> {
    match s {
        "uart" => Ok(hil::qemu::Channel::Uart),
        "bulk" => Ok(hil::qemu::Channel::Bulk),
        _ => Err(format!("unknown QEMU link `{s}` (expected uart or bulk)")),
    }
}

fn parse_golden_target(s: &str) -> Result<Target, String> {
    match s.parse::<Target>()? {
        t @ (Target::InProc | Target::Qemu) => Ok(t),
        Target::QemuAt(_) => Err(
            "golden vectors start a fresh QEMU per vector (--target qemu), not one started by hand"
                .into(),
        ),
        Target::Serial(_) => Err("golden vectors run on inproc or qemu".into()),
    }
}

#[derive(Clone, Copy, ValueEnum)]
enum Control {
    /// Passive: the mechanical yaw spring in the plant, no yaw torque from the device.
    Passive,
    /// Pure gain `T = K y'`.
    Gain,
    /// Phase lead `K 7.5 (s+37)/(s+274)` on `y'`.
    Lead,
}

#[derive(Clone, Copy, ValueEnum)]
enum PaceArg {
    /// Wall-clock periods.
    Realtime,
    /// Wait for each answer.
    Lockstep,
}

#[derive(Args, Clone)]
struct RunArgs {
    /// Where the device runs: inproc, qemu or serial:PATH.
    #[arg(long, default_value = "inproc", value_parser = parse_target)]
    target: Target,
    /// The QEMU target's emulated board: mps2-an386 (Cortex-M4F) or mps2-an385
    /// (Cortex-M3, no FPU; `target/fw/wheelset-qemu-m3.elf`).
    #[arg(long, default_value = "mps2-an386", value_parser = parse_machine)]
    machine: Machine,
    /// The QEMU target's link: `uart` (UART0 over TCP, byte by byte through the emulated
    /// UART: the faithful path) or `bulk` (semihosting file I/O on two FIFOs, one trap
    /// per frame: the same frames bit for bit, about ten times faster).
    #[arg(long, default_value = "uart", value_parser = parse_channel)]
    qemu_link: hil::qemu::Channel,
    /// Built-in scenario (curve, beating, low-adhesion, actuator-fault) or a scenario TOML
    /// file.
    #[arg(long, default_value = "curve")]
    scenario: String,
    /// Parameter file (TOML, any subset of the parameters, as `sim-host --params`); the
    /// scenario's [params] apply on top. The plant, the reference and the device's
    /// configuration follow the result.
    #[arg(long, value_name = "FILE")]
    params: Option<PathBuf>,
    /// Yaw control law of the device (and of the reference).
    #[arg(long, value_enum, default_value = "lead")]
    control: Control,
    /// Link faults, e.g. `ber=1e-4,drop=0.01,outage=8:0.05` (simulated link only).
    #[arg(long, default_value = "", value_parser = parse_faults)]
    faults: Faults,
    /// Write the verdict document (JSON).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write the closed-loop trajectory (sim-host's CSV columns).
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Write a Markdown report with SVG plots into this directory.
    #[arg(long)]
    report: Option<PathBuf>,
    /// Budget file (TOML; see `hil::budget` for the keys and defaults).
    #[arg(long)]
    budget: Option<PathBuf>,
    /// Override one budget, e.g. `--set timing.cpu_max.fail=0.5` (repeatable).
    #[arg(long = "set", value_name = "KEY=VALUE")]
    sets: Vec<String>,
    /// A deliberately broken in-process device: wrong-sign, slow[:EXEC_US], jitter[:MAX_US],
    /// corrupt[:EVERY].
    #[arg(long, default_value = "none", value_parser = parse_device_fault)]
    device_fault: DeviceFault,
    /// Link baud (10 bits per byte).
    #[arg(long, default_value_t = sim_host::link::DEFAULT_BAUD, allow_negative_numbers = true)]
    baud: u32,
    /// Seed of the simulated link's faults.
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    seed: u64,
    /// Serial target pacing: realtime (a board on its own timer) or lockstep (a
    /// frame-clocked device answering each frame).
    #[arg(long, value_enum, default_value = "realtime")]
    pace: PaceArg,
    /// Core clock of the board, Hz (converts its cycle counts to time).
    #[arg(long, default_value_t = hil::run::DEFAULT_CPU_HZ, allow_negative_numbers = true)]
    cpu_hz: f64,
    /// Base rate of the device, Hz (default: the control core's 5000). In process the
    /// device is built at it; a free-running serial device is configured over the wire
    /// (rates and coefficients from `wheelset_runtime::rates_for`). The link is checked
    /// against it before the run.
    #[arg(long)]
    rate_hz: Option<u32>,
    /// Real-time pacing: pin the harness's loop to this CPU (default: the last one
    /// allowed).
    #[arg(long)]
    rt_cpu: Option<usize>,
    /// Real-time pacing: do not ask for SCHED_FIFO, locked memory or a pinned core.
    #[arg(long)]
    no_rt: bool,
    /// Never show the progress bar.
    #[arg(long)]
    quiet: bool,
}

fn parse_target(s: &str) -> Result<Target, String> {
    s.parse()
}

fn parse_faults(s: &str) -> Result<Faults, String> {
    s.parse::<Faults>().map_err(|e| e.to_string())
}

fn parse_device_fault(s: &str) -> Result<DeviceFault, String> {
    s.parse()
}

/// A failure with its exit code.
struct Failure {
    code: u8,
    msg: String,
}

fn input(msg: impl Into<String>) -> Failure {
    Failure {
        code: 2,
        msg: msg.into(),
    }
}

/// The parameters of `--params FILE` (the paper's without it); a bad file names the
/// flag, the file and the key.
fn load_params(path: Option<&std::path::Path>) -> Result<Params, Failure> {
    match path {
        Some(p) => Params::from_file(p).map_err(|e| input(format!("--params: {e}"))),
        None => Ok(Params::default()),
    }
}

fn run_error(e: RunError) -> Failure {
    match e {
        RunError::Input(m) => input(m),
        RunError::Target(e) => Failure {
            code: 3,
            msg: e.to_string(),
        },
    }
}

fn cmd_run(a: &RunArgs, command: &str) -> Result<Verdict, Failure> {
    let budgets = Budgets::load(a.budget.as_deref(), &a.sets).map_err(|e| input(e.to_string()))?;
    let params = load_params(a.params.as_deref())?;
    if a.baud == 0 {
        return Err(input("--baud: must be positive"));
    }
    if !(a.cpu_hz.is_finite() && a.cpu_hz > 0.0) {
        return Err(input(format!(
            "--cpu-hz {}: must be a positive number",
            a.cpu_hz
        )));
    }
    // A scenario meant for other laws (its `laws` key) warns before the run; a file
    // that does not load is reported by the run itself.
    if let Ok(sc) = sim_host::scenario::Scenario::load(&a.scenario, &params) {
        let law = match a.control {
            Control::Passive => sim_host::control::YawLaw::Passive,
            Control::Gain => sim_host::control::YawLaw::Gain,
            Control::Lead => sim_host::control::YawLaw::Lead,
        };
        if let Some(w) = sc.law_warning(law) {
            eprintln!("hil: warning: {w}");
        }
    }
    if a.target != Target::Qemu && a.machine != Machine::default() {
        return Err(input(format!(
            "--machine {}: the emulated board is for --target qemu, not {}",
            a.machine, a.target
        )));
    }
    if a.target != Target::Qemu && a.qemu_link != hil::qemu::Channel::Uart {
        return Err(input(format!(
            "--qemu-link bulk: the bulk channel is the QEMU target's, not {}'s",
            a.target
        )));
    }
    if a.target != Target::InProc {
        if a.faults != Faults::none() {
            return Err(input(format!(
                "--faults: the fault injection is part of the simulated link; target {} has a real one",
                a.target
            )));
        }
        if a.device_fault != DeviceFault::None {
            return Err(input(format!(
                "--device-fault: only the in-process device can be broken on purpose, not {}",
                a.target
            )));
        }
    }
    // The faults as applied (canonical spec), whichever form the flag took
    // (`--faults SPEC` or `--faults=SPEC`).
    let faults_spec = a.faults.to_string();
    let opts = RunOptions {
        target: a.target.clone(),
        scenario: a.scenario.clone(),
        control: match a.control {
            Control::Passive => Law::Passive,
            Control::Gain => Law::Gain,
            Control::Lead => Law::Lead,
        },
        faults_spec,
        device_fault: a.device_fault,
        budgets,
        link: LinkConfig {
            baud: a.baud,
            faults: a.faults.clone(),
            seed: a.seed,
            ..LinkConfig::default()
        },
        pace: match a.pace {
            PaceArg::Realtime => hil::serial::Pace::RealTime,
            PaceArg::Lockstep => hil::serial::Pace::LockStep,
        },
        cpu_hz: a.cpu_hz,
        timeout: std::time::Duration::from_secs(5),
        machine: a.machine,
        qemu_link: a.qemu_link,
        progress: !a.quiet && std::io::stderr().is_terminal(),
        rate_hz: a.rate_hz,
        realtime: if a.no_rt {
            hil::rt_os::Want::none()
        } else {
            hil::rt_os::Want::all(
                a.rt_cpu
                    .or_else(|| hil::rt_os::allowed_cpus().last().copied()),
            )
        },
        params,
    };
    let out = run(&opts).map_err(run_error)?;
    print_summary(&out.report);
    let io = |what: &std::path::Path, e: std::io::Error| {
        input(format!("{}: cannot write: {e}", what.display()))
    };
    if let Some(p) = &a.json {
        report::write_json(&out.report, p).map_err(|e| io(p, e))?;
        say!("json: {}", p.display());
    }
    if let Some(p) = &a.csv {
        report::write_csv(&out.trajectory, p).map_err(|e| io(p, e))?;
        say!(
            "csv: {} ({} rows)",
            p.display(),
            out.trajectory.records.len()
        );
    }
    if let Some(d) = &a.report {
        let files = report::write_report(&out, d, command).map_err(|e| io(d, e))?;
        for f in files {
            say!("report: {}", f.display());
        }
    }
    Ok(out.report.verdict)
}

fn cmd_golden(g: &GoldenArgs) -> Result<Verdict, Failure> {
    use hil::golden;
    let params = load_params(g.params.as_deref())?;
    if let Some(path) = &g.record {
        let out = run(&RunOptions {
            progress: false,
            params,
            ..RunOptions::default()
        })
        .map_err(|e| input(e.to_string()))?;
        let (from, to) = (4_900_000_000 / out.period_ns, 5_300_000_000 / out.period_ns);
        let mut text = String::from("y_dot_um_s,i_a_ma,omega_mrad_s,demand_nm\n");
        for c in out
            .sensor_codes
            .iter()
            .take(to as usize)
            .skip(from as usize)
        {
            text.push_str(&format!(
                "{},{},{},{}\n",
                c.y_dot, c.current, c.speed, c.demand
            ));
        }
        std::fs::write(path, text)
            .map_err(|e| input(format!("{}: cannot write: {e}", path.display())))?;
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
        ..RunOptions::default()
    };
    if g.target != Target::InProc {
        hil::run::remote_gains(&params, &g.target).map_err(|e| input(format!("--params: {e}")))?;
    }
    let rt = golden::runtime_for(&params);
    let period_ns = 1_000_000_000 / u64::from(rt.control.base_rate_hz);
    let mut results = Vec::new();
    for v in &vectors {
        let host = golden::run_host_with(v, rt).map_err(|e| input(e.to_string()))?;
        // A fresh device per vector: every vector starts from reset.
        let mut tr = hil::run::open_transport(&opts, rt).map_err(run_error)?;
        let target = golden::run_target(v, tr.as_mut(), period_ns).map_err(|e| Failure {
            code: 3,
            msg: e.to_string(),
        })?;
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
                    "{} ticks DIFFER, first at tick {:?}",
                    c.mismatches, c.first_mismatch
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
        let text = serde_json::to_string_pretty(&doc).unwrap_or_default();
        std::fs::write(p, text + "\n")
            .map_err(|e| input(format!("{}: cannot write: {e}", p.display())))?;
    }
    Ok(if all { Verdict::Pass } else { Verdict::Fail })
}

fn cmd_sweep(c: &SweepCmd, command: &str) -> Result<Verdict, Failure> {
    use hil::sweep;
    let write =
        |doc: &sweep::SweepDoc, json: &std::path::Path, report_dir: Option<&std::path::Path>| {
            if let Some(d) = json.parent().filter(|d| !d.as_os_str().is_empty()) {
                std::fs::create_dir_all(d)
                    .map_err(|e| input(format!("{}: cannot create: {e}", d.display())))?;
            }
            std::fs::write(json, sweep::to_json(doc))
                .map_err(|e| input(format!("{}: cannot write: {e}", json.display())))?;
            say!("json: {}", json.display());
            if let Some(d) = report_dir {
                let files = report::write_sweep_report(doc, d, command)
                    .map_err(|e| input(format!("{}: cannot write: {e}", d.display())))?;
                for f in files {
                    say!("report: {}", f.display());
                }
            }
            for r in &doc.records {
                let checks: Vec<&str> = r.failing.iter().map(|c| c.check.as_str()).collect();
                say!(
                    "  {:>4}  {}: {}, peak |y| {:.3} mm{}{}",
                    r.index,
                    r.params
                        .iter()
                        .map(|(k, v)| format!("{k} = {}", report::value_label(*v)))
                        .collect::<Vec<_>>()
                        .join(", "),
                    r.verdict,
                    r.peak_abs_y_m * 1e3,
                    r.diverged_at_s
                        .map_or(String::new(), |t| format!(", diverged at {t:.3} s")),
                    if checks.is_empty() {
                        String::new()
                    } else {
                        format!("; not passed: {}", checks.join(", "))
                    }
                );
            }
            let s = &doc.summary;
            say!(
                "hil sweep: {} of {} points{}: {} pass, {} warn, {} fail",
                doc.records.len(),
                doc.sweep.points,
                doc.shard
                    .map_or(String::new(), |sh| format!(" (shard {sh})")),
                s.pass,
                s.warn,
                s.fail
            );
            Ok(if s.fail > 0 {
                Verdict::Fail
            } else {
                Verdict::Pass
            })
        };
    if let Some(SweepSub::Merge(m)) = &c.sub {
        let mut parts = Vec::new();
        for f in &m.files {
            let name = f.display().to_string();
            let text = sim_host::input::read_input(f).map_err(|e| input(e.to_string()))?;
            parts.push((name.clone(), sweep::from_json(&text, &name).map_err(input)?));
        }
        let doc = sweep::merge(&parts).map_err(input)?;
        let json = m
            .json
            .as_deref()
            .ok_or_else(|| input("--json OUT: needed"))?;
        return write(&doc, json, m.report.as_deref());
    }
    let a = &c.args;
    let json = a
        .json
        .as_deref()
        .ok_or_else(|| input("--json FILE: needed"))?;
    let points = sweep::check_axes(&a.axes).map_err(input)?;
    let jobs = match a.jobs {
        Some(0) => return Err(input("--jobs 0: at least one thread")),
        Some(n) => n,
        None => std::thread::available_parallelism().map_or(1, std::num::NonZeroUsize::get),
    };
    if a.target != Target::InProc && a.faults != Faults::none() {
        return Err(input(format!(
            "--faults: the fault injection is part of the simulated link; target {} has a real one",
            a.target
        )));
    }
    let budgets = Budgets::load(a.budget.as_deref(), &a.sets).map_err(|e| input(e.to_string()))?;
    let params = load_params(a.params.as_deref())?;
    let law = match a.control {
        Control::Passive => Law::Passive,
        Control::Gain => Law::Gain,
        Control::Lead => Law::Lead,
    };
    if let Ok(sc) = sim_host::scenario::Scenario::load(&a.scenario, &params) {
        let yaw = match a.control {
            Control::Passive => sim_host::control::YawLaw::Passive,
            Control::Gain => sim_host::control::YawLaw::Gain,
            Control::Lead => sim_host::control::YawLaw::Lead,
        };
        if let Some(w) = sc.law_warning(yaw) {
            eprintln!("hil: warning: {w}");
        }
    }
    let campaign = sweep::Campaign {
        base: RunOptions {
            target: a.target.clone(),
            scenario: a.scenario.clone(),
            control: law,
            faults_spec: a.faults.to_string(),
            budgets,
            link: LinkConfig {
                faults: a.faults.clone(),
                seed: a.seed,
                ..LinkConfig::default()
            },
            progress: false,
            realtime: hil::rt_os::Want::none(),
            params,
            ..RunOptions::default()
        },
        header: sweep::Header {
            scenario: a.scenario.clone(),
            control: law,
            target: a.target.to_string(),
            faults: a.faults.to_string(),
            seed: a.seed,
            params_file: a.params.as_ref().map(|p| p.display().to_string()),
            budget_file: a.budget.as_ref().map(|p| p.display().to_string()),
            sets: a.sets.clone(),
            axes: a.axes.clone(),
            follows: sweep::followers(&a.axes),
            points,
        },
    };
    let bar = (!a.quiet && std::io::stderr().is_terminal()).then(|| {
        let pb = indicatif::ProgressBar::new(0);
        pb.set_style(
            indicatif::ProgressStyle::with_template(
                "{msg} [{bar:40}] {pos}/{len} points ({elapsed}, eta {eta})",
            )
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        pb.set_message(format!("hil sweep {} on {jobs} threads", a.scenario));
        pb
    });
    let mut tick = |done: usize, total: usize| {
        if let Some(pb) = &bar {
            pb.set_length(total as u64);
            pb.set_position(done as u64);
        }
    };
    let doc = sweep::run_campaign(&campaign, a.shard, jobs, &mut tick).map_err(run_error)?;
    if let Some(pb) = &bar {
        pb.finish_and_clear();
    }
    write(&doc, json, a.report.as_deref())
}

fn cmd_serve(a: &ServeArgs) -> Result<Verdict, Failure> {
    use hil::serve;
    use std::io::Write as _;
    let duration = match a.duration_s {
        None => None,
        Some(d) if d.is_finite() && d > 0.0 => Some(std::time::Duration::from_secs_f64(d)),
        Some(d) => {
            return Err(input(format!(
                "--duration-s {d}: must be a positive number"
            )))
        }
    };
    if !(a.cpu_hz.is_finite() && a.cpu_hz > 0.0) {
        return Err(input("--cpu-hz: must be a positive number"));
    }
    let rt = serve::runtime_at(a.rate_hz).map_err(input)?;
    let opts = serve::ServeOptions {
        rate_hz: a.rate_hz,
        duration,
        cpu_hz: a.cpu_hz,
        want: if a.no_rt {
            hil::rt_os::Want::none()
        } else {
            hil::rt_os::Want::all(
                a.cpu
                    .or_else(|| hil::rt_os::allowed_cpus().first().copied()),
            )
        },
    };
    let (mut master, slave, path) = serve::open_pty().map_err(|e| Failure {
        code: 3,
        msg: format!("cannot create a pseudo-terminal: {e}"),
    })?;
    // The path first, alone on its line, for whoever starts the stand-in.
    say!("{path}");
    let _ = std::io::stdout().flush();
    eprintln!(
        "hil serve: the runtime (fixed point) free-running at {} Hz on {path};          `hil run --target serial:{path}`",
        a.rate_hz
    );
    let stop = std::sync::atomic::AtomicBool::new(false);
    let rep = serve::serve(&mut master, rt, &opts, &stop).map_err(|e| Failure {
        code: 3,
        msg: format!("{path}: {e}"),
    })?;
    drop(slave);
    eprintln!(
        "hil serve: {} ticks, {} late, {} skipped (max lateness {:.1} us), rx {} B, tx {} B, \
         {} frames dropped, {} Hz at the end; realtime {:?}",
        rep.ticks,
        rep.late,
        rep.skipped,
        rep.max_lateness_ns as f64 * 1e-3,
        rep.rx_bytes,
        rep.tx_bytes,
        rep.tx_dropped,
        rep.rate_hz,
        rep.realtime
    );
    if let Some(p) = &a.json {
        let text = serde_json::to_string_pretty(&rep).unwrap_or_default();
        std::fs::write(p, text + "\n")
            .map_err(|e| input(format!("{}: cannot write: {e}", p.display())))?;
    }
    Ok(Verdict::Pass)
}

/// What a timing check's value is a fraction of (`hil::timing`'s checks).
fn check_unit(name: &str) -> &'static str {
    match name {
        "missed_frac" | "overrun_frac" => "of the periods",
        "link" => "of the link's capacity",
        _ => "of T",
    }
}

fn print_summary(r: &hil::run::RunReport) {
    let t = &r.timing;
    say!(
        "hil run: target {}, scenario {} ({}), control {:?}, {} periods of {} ns",
        r.target,
        r.scenario,
        r.scenario_source,
        r.control,
        t.periods,
        t.period_ns
    );
    let exec = if t.exec_measured || t.exec_units.max > 0.0 {
        format!(
            "exec {:.0}/{:.0}/{:.0} {} (min/mean/max)",
            t.exec_units.min, t.exec_units.mean, t.exec_units.max, t.exec_unit
        )
    } else {
        "exec not measured in process (real figures: --target qemu, cargo xtask fw-bench, a board)"
            .to_string()
    };
    say!(
        "timing {}: {exec}, latency max {:.1} us{}, jitter max {}, \
         missed {}, overruns {}, CPU max {:.2} %, link {:.1} %",
        t.verdict,
        t.latency_ns.max * 1e-3,
        if t.latency_modelled {
            " (modelled)"
        } else {
            ""
        },
        t.jitter_max_ns
            .map_or("n/a".to_string(), |j| format!("{:.1} us", j * 1e-3)),
        t.missed_ticks,
        t.overruns,
        t.cpu_max * 100.0,
        t.link_utilisation * 100.0
    );
    for c in t.checks.iter().filter(|c| c.verdict != Verdict::Pass) {
        say!(
            "  timing.{}: {:.4} {} > {} {} (warn {}, fail {})",
            c.name,
            c.value,
            check_unit(&c.name),
            c.verdict,
            if c.verdict == Verdict::Fail {
                c.limit.fail
            } else {
                c.limit.warn
            },
            c.limit.warn,
            c.limit.fail
        );
    }
    say!(
        "numerics {} (vs {}):",
        r.numerics.verdict,
        r.numerics.reference
    );
    if let Some(t) = r.numerics.run_diverged_at_s {
        say!("  the closed loop DIVERGED at {t:.3} s (run stopped)");
    }
    if let Some(t) = r.numerics.reference_diverged_at_s {
        say!("  the f64 continuous reference DIVERGED at {t:.3} s (no yardstick)");
    }
    for s in &r.numerics.signals {
        say!(
            "  {:<10} max err {:.3e} (at {:.3} s) of allowed {:.3e}: {}",
            s.name,
            s.max_err,
            s.max_err_t_s,
            s.allowed,
            s.verdict
        );
    }
    let f = &r.frames;
    say!(
        "frames {} ({}): sent {} = received {} + rejected {} + dropped {} + in flight {}{}",
        r.frames_verdict,
        f.source,
        f.sent,
        f.received,
        f.rejected,
        f.dropped,
        f.in_flight,
        if f.pre_run > 0 {
            format!("; {} frames before the run discarded (pre_run)", f.pre_run)
        } else {
            String::new()
        }
    );
    for (name, d) in [("host -> device", &f.up), ("device -> host", &f.down)] {
        say!(
            "  {name}: sent {} = received {} + rejected {} + dropped {} + in flight {}",
            d.sent,
            d.received,
            d.rejected,
            d.dropped,
            d.in_flight
        );
    }
    if let Some(h) = r.transport.as_ref().and_then(|t| t.get("host")) {
        say!(
            "host (real time): missed {} of {} deadlines ({} late sends, {} late receives), \
             send lateness p99 {:.1} us; obtained {}",
            h["missed_deadlines"],
            h["periods"],
            h["late_sends"],
            h["late_receives"],
            h["send_lateness_ns"]["p99"].as_f64().unwrap_or(0.0) * 1e-3,
            r.transport
                .as_ref()
                .and_then(|t| t.get("realtime"))
                .map_or(String::new(), ToString::to_string)
        );
    }
    let default = Params::default().entries();
    let changed: Vec<String> = r
        .params
        .entries()
        .iter()
        .zip(&default)
        .filter(|((_, a), (_, b))| a != b)
        .map(|((k, a), _)| format!("{k} = {}", report::value_label(*a)))
        .collect();
    if !changed.is_empty() {
        say!("parameters (the paper's but): {}", changed.join(", "));
    }
    say!("verdict: {}", r.verdict);
    let m = &r.monitor;
    say!(
        "  monitor ({}): {} alarm(s){}; expected {}{}: {}{}",
        m.source,
        m.alarms.len(),
        m.first_alarm_s
            .map_or(String::new(), |t| format!(", first at {t:.3} s")),
        m.expect,
        match (m.deadline_s, m.fault_s) {
            (Some(d), Some(f)) => format!(
                " by {d:.3} s (fault at {f:.3} s, sigma {:.1} 1/s)",
                m.sigma_per_s.unwrap_or(0.0)
            ),
            (Some(d), None) => format!(" by {d:.3} s (the plant diverged there on its own)"),
            _ => String::new(),
        },
        m.verdict,
        if m.reason.is_empty() {
            String::new()
        } else {
            format!(" ({})", m.reason)
        }
    );
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let code = if e.use_stderr() { 2 } else { 0 };
            let _ = e.print();
            return ExitCode::from(code);
        }
    };
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let res = match &cli.cmd {
        Some(Cmd::Run(a)) => cmd_run(a, &command),
        None => cmd_run(&cli.run, &command),
        Some(Cmd::Golden(g)) => cmd_golden(g),
        Some(Cmd::Serve(a)) => cmd_serve(a),
        Some(Cmd::Sweep(c)) => cmd_sweep(c, &command),
        Some(Cmd::Audit(a)) => match hil::audit::run(a) {
            Ok(code) => return ExitCode::from(code),
            Err(e) => Err(input(e.to_string())),
        },
    };
    match res {
        Ok(Verdict::Fail) => ExitCode::from(1),
        Ok(_) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("hil: error: {}", f.msg);
            ExitCode::from(f.code)
        }
    }
}
