//! `sim-host`: the plant simulator's command line.
//!
//! - `sim-host modes [--case a|b|c|d] [--points N] --json FILE [--plot DIR]`
//! - `sim-host rates [--control lead|gain|passive] [--model full|reduced] [--delay N]
//!   [--max-baud B] [--json FILE]`: the sampled-data rate analysis of the firmware loops
//! - `sim-host run --scenario curve|beating|FILE --control passive|gain|lead [--csv FILE] [--plot DIR]`
//! - `sim-host run ... --loop device [--faults SPEC] [--seed N] [--baud B] [--latency-us L]`:
//!   the firmware runtime in the loop over the simulated serial link
//! - `sim-host run ... --loop core [--wsp on|off]`: the f64 control core on the plant
//!   (the device's laws and timing without the link)
//! - `sim-host run ... --json FILE`: the run's summary (with `[[adhesion]]` sections: the
//!   per-section adhesion table and the runaway verdict, `sim_host::traction`)
//! - `sim-host adhesion --condition dry|wet|low [--v-mps V] --json FILE [--plot DIR]`:
//!   Polach's creep characteristic `F/Q` against creepage 0..0.2
//!
//! Exit codes: 0 success, 2 bad usage or bad input file, 1 other failures (writing output).

use clap::{Parser, Subcommand, ValueEnum};
use sim_host::control::YawLaw;
use sim_host::error::ConfigError;
use sim_host::modes::{creep_grid, sweep_case, Case};
use sim_host::params::Params;
use sim_host::scenario::Scenario;
use sim_host::sim::{run_continuous, Trajectory};
use std::path::PathBuf;
use std::process::ExitCode;

/// Plant simulator of a railway wheelset with traction (docs/model.md).
#[derive(Parser)]
#[command(name = "sim-host", version, about, long_about = None)]
struct Cli {
    #[command(subcommand)]
    cmd: Cmd,
}

#[derive(Subcommand)]
enum Cmd {
    /// Modal analysis along the creep sweep f11 = f22 = 1-10 MN (Figs. 2-5).
    Modes(ModesArgs),
    /// Simulate a track scenario with the continuous-time reference controllers.
    Run(RunArgs),
    /// Sampled-data rate analysis of the firmware's loops (ZOH + delay, the discrete
    /// controllers of wheelset-control) over creep 1-10 MN and conicity 0.05-0.4.
    Rates(RatesArgs),
    /// Polach's adhesion-limited creep characteristic of a rail condition.
    Adhesion(AdhesionArgs),
}

/// Rail condition on the command line.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum ConditionArg {
    /// Dry rail.
    Dry,
    /// Wet rail.
    Wet,
    /// Low adhesion (leaves, contamination).
    Low,
}

impl From<ConditionArg> for sim_host::adhesion::Condition {
    fn from(c: ConditionArg) -> Self {
        use sim_host::adhesion::Condition;
        match c {
            ConditionArg::Dry => Condition::Dry,
            ConditionArg::Wet => Condition::Wet,
            ConditionArg::Low => Condition::Low,
        }
    }
}

#[derive(clap::Args)]
struct AdhesionArgs {
    /// Rail condition.
    #[arg(long, value_enum)]
    condition: ConditionArg,
    /// Speed, m/s (default: the parameters' `v`, 83.3).
    #[arg(long = "v-mps")]
    v_mps: Option<f64>,
    /// Points over creepage 0..0.2 (at least 200).
    #[arg(long, default_value_t = 401, value_parser = clap::value_parser!(u32).range(200..=1_000_000))]
    points: u32,
    /// Write the characteristic as JSON here (directories created).
    #[arg(long)]
    json: PathBuf,
    /// Write `adhesion-<condition>.svg` into this directory.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Parameter file (TOML, any subset of the parameters: `q`, `f11`, `v` ...).
    #[arg(long)]
    params: Option<PathBuf>,
}

/// Plant of the rate analysis.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum RatesModel {
    /// Case (d) linearisation: flexible axle, motor on its gear spring, armature.
    Full,
    /// Case (a) lateral/yaw plus the armature circuit alone.
    Reduced,
}

#[derive(clap::Args)]
struct RatesArgs {
    /// Yaw control mode analysed.
    #[arg(long, value_enum, default_value = "lead")]
    control: Control,
    /// Plant model.
    #[arg(long, value_enum, default_value = "full")]
    model: RatesModel,
    /// Parameter file (TOML, any subset of the parameters).
    #[arg(long)]
    params: Option<PathBuf>,
    /// Ticks of computation and transport delay on the actuation (the firmware: 1).
    #[arg(long, default_value_t = 1, allow_negative_numbers = true)]
    delay: usize,
    /// The fastest UART baud the link may assume (selection criterion).
    #[arg(long, default_value_t = 6_000_000, allow_negative_numbers = true)]
    max_baud: u32,
    /// Write the table as JSON (directories created).
    #[arg(long)]
    json: Option<PathBuf>,
}

/// Yaw control mode.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum Control {
    /// Mechanical yaw spring `k_yaw psi` (no actuator).
    Passive,
    /// Active yaw damping, pure gain `T = K y'` (spring replaced by the actuator).
    Gain,
    /// Active yaw damping with phase lead `K 7.5 (s+37)/(s+274)` on `y'`.
    Lead,
}

impl From<Control> for YawLaw {
    fn from(c: Control) -> Self {
        match c {
            Control::Passive => YawLaw::Passive,
            Control::Gain => YawLaw::Gain,
            Control::Lead => YawLaw::Lead,
        }
    }
}

/// Analysis case of docs/model.md.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum CaseArg {
    /// Passive yaw spring, rigid axle, no traction dynamics.
    A,
    /// Active pure gain, rigid axle.
    B,
    /// Active phase lead, rigid axle.
    C,
    /// Phase lead, flexible axle, gear spring, motor, armature, PI current loop.
    D,
}

#[derive(clap::Args)]
struct ModesArgs {
    /// Analyse only this case (default: all four).
    #[arg(long, value_enum)]
    case: Option<CaseArg>,
    /// Points of the sweep, evenly spaced over 1-10 MN (1, 2, 5 and 10 MN are always
    /// included exactly).
    #[arg(long, default_value_t = 1000, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(2..=1_000_000))]
    points: u32,
    /// Write the results as JSON here (directories created).
    #[arg(long)]
    json: PathBuf,
    /// Write one root-locus SVG per case into this directory.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Parameter file (TOML, any subset of the parameters).
    #[arg(long)]
    params: Option<PathBuf>,
}

#[derive(clap::Args)]
struct RunArgs {
    /// Built-in scenario (`curve`, `beating`) or a scenario TOML file.
    #[arg(long, default_value = "curve")]
    scenario: String,
    /// Yaw control mode.
    #[arg(long, value_enum, default_value = "lead")]
    control: Control,
    /// Parameter file (TOML, any subset of the parameters); the scenario's [params]
    /// table is applied on top.
    #[arg(long)]
    params: Option<PathBuf>,
    /// Write the trajectory as CSV (1 ms samples by default; directories created).
    #[arg(long)]
    csv: Option<PathBuf>,
    /// Write the run's summary as JSON (with `[[adhesion]]` sections: the `adhesion`
    /// object of `sim_host::traction`; directories created).
    #[arg(long)]
    json: Option<PathBuf>,
    /// Write SVG plots (lateral, torque, creep, traction) into this directory.
    #[arg(long)]
    plot: Option<PathBuf>,
    /// Also run these modes and overlay them on the plots (e.g. `--compare passive`).
    #[arg(long, value_enum)]
    compare: Vec<Control>,
    /// Print the state of every run (this one and the `--compare` ones) at this time, s
    /// (repeatable; the nearest output sample), and each run's peaks.
    #[arg(long = "at", value_name = "T_S", allow_negative_numbers = true)]
    at: Vec<f64>,
    #[command(flatten)]
    device: DeviceArgs,
}

/// Which controllers close the loop.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum LoopKind {
    /// The continuous-time reference controllers (extra ODE states).
    Continuous,
    /// The firmware runtime (fixed point) over the simulated serial link.
    Device,
    /// The control core in f64 on the plant, no link (one period of delay, wire
    /// quantisation of the inputs): the reference of the device, protection included.
    Core,
}

/// Wheel-slip protection switch.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum OnOff {
    /// On.
    On,
    /// Off.
    Off,
}

/// The device loop's options (`--loop device`). All but `--loop` apply to the device
/// loop only: given without `--loop device` they are refused, naming the flag.
#[derive(clap::Args)]
struct DeviceArgs {
    /// Loop kind.
    #[arg(long = "loop", value_enum, default_value = "continuous")]
    loop_kind: LoopKind,
    /// Wheel-slip protection of the control core (`--loop core`; default on). The device
    /// loop refuses it until the runtime forwards wire v2's `Config::wsp` to the core.
    #[arg(long, value_enum)]
    wsp: Option<OnOff>,
    /// Link faults, e.g. `ber=1e-3,drop=0.1,outage=8.0:0.05` (keys: ber, drop, byte_drop,
    /// outage=START_S:LEN_S[:up|down], burst=RATE_HZ:LEN_BYTES, dir=both|up|down);
    /// default none.
    #[arg(long, allow_hyphen_values = true)]
    faults: Option<String>,
    /// Seed of the link's fault injection [default: 1].
    #[arg(long, allow_negative_numbers = true)]
    seed: Option<u64>,
    /// Link baud rate (10 bits per byte) [default: 5000000].
    #[arg(long, allow_negative_numbers = true)]
    baud: Option<u32>,
    /// One-way link latency, us, in [0, 1e6] [default: 2].
    #[arg(long, allow_negative_numbers = true)]
    latency_us: Option<f64>,
    /// Device base rate, Hz (default: the control core's).
    #[arg(long, allow_negative_numbers = true)]
    rate_hz: Option<u32>,
    /// Ticks the device bridges a missing sensor frame before its safe state
    /// [default: the runtime's].
    #[arg(long, allow_negative_numbers = true)]
    hold_ticks: Option<u16>,
    /// What the Sensor frames carry of the lateral motion: `velocity` (y') or
    /// `acceleration` (y'', integrated on the device with a wash-out) [default: velocity].
    #[arg(long, value_enum)]
    lateral: Option<Lateral>,
}

impl DeviceArgs {
    /// The device-loop flags that were given (for refusing them on the continuous loop).
    fn given(&self) -> Vec<&'static str> {
        [
            ("--faults", self.faults.is_some()),
            ("--seed", self.seed.is_some()),
            ("--baud", self.baud.is_some()),
            ("--latency-us", self.latency_us.is_some()),
            ("--rate-hz", self.rate_hz.is_some()),
            ("--hold-ticks", self.hold_ticks.is_some()),
            ("--lateral", self.lateral.is_some()),
        ]
        .into_iter()
        .filter(|(_, g)| *g)
        .map(|(f, _)| f)
        .collect()
    }
}

/// Largest `--latency-us`: 1 s (a link slower than that cannot carry any control rate).
const MAX_LATENCY_US: f64 = 1e6;

/// Lateral sensing over the link.
#[derive(Clone, Copy, ValueEnum, PartialEq, Eq, Debug)]
enum Lateral {
    /// Lateral velocity `y'`.
    Velocity,
    /// Lateral acceleration `y''`.
    Acceleration,
}

/// A command failure with its exit code.
struct Failure {
    code: u8,
    msg: String,
}

impl From<ConfigError> for Failure {
    fn from(e: ConfigError) -> Self {
        Failure {
            code: 2,
            msg: e.to_string(),
        }
    }
}

fn io_fail(what: &std::path::Path, e: std::io::Error) -> Failure {
    Failure {
        code: 1,
        msg: format!("{}: cannot write: {e}", what.display()),
    }
}

fn load_params(path: &Option<PathBuf>) -> Result<Params, ConfigError> {
    match path {
        Some(p) => Params::from_file(p),
        None => Ok(Params::default()),
    }
}

/// One simulation of the scenario. This is the place where further loop kinds (the
/// device over the link) plug in: they produce the same [`Trajectory`].
fn simulate(sc: &Scenario, control: Control) -> Trajectory {
    run_continuous(sc, control.into())
}

fn warn(msg: &str) {
    eprintln!("sim-host: warning: {msg}");
}

fn cmd_run(a: &RunArgs) -> Result<(), Failure> {
    if a.device.loop_kind != LoopKind::Device {
        if let Some(flag) = a.device.given().first() {
            return Err(Failure {
                code: 2,
                msg: format!(
                    "{flag}: applies only to the device loop over the simulated link (add --loop device); \
                     the {} loop has no link, rate or device",
                    if a.device.loop_kind == LoopKind::Core {
                        "core"
                    } else {
                        "continuous"
                    }
                ),
            });
        }
    }
    let base = load_params(&a.params)?;
    let sc = Scenario::load(&a.scenario, &base)?;
    let end_s = sc.duration_ns as f64 * 1e-9;
    if let Some(t) =
        a.at.iter()
            .find(|t| !(t.is_finite() && (0.0..=end_s).contains(*t)))
    {
        return Err(Failure {
            code: 2,
            msg: format!("--at {t}: must be a time within the run, 0-{end_s} s"),
        });
    }
    if !a.at.is_empty() && a.device.loop_kind != LoopKind::Continuous {
        return Err(Failure {
            code: 2,
            msg: "--at: only for the continuous loop (the default --loop)".into(),
        });
    }
    // Every trajectory kept at once: this one, the compared ones, and on the device loop
    // the continuous reference (the device's own records are checked with its rate).
    let kept = 1
        + a.compare.iter().filter(|&&c| c != a.control).count() as u64
        + u64::from(a.device.loop_kind == LoopKind::Device);
    sim_host::memory::check_runs(sc.duration_ns, sc.output_dt_ns, None, kept).map_err(|msg| {
        Failure {
            code: 2,
            msg: format!("{}: {msg}", sc.source),
        }
    })?;
    for law in std::iter::once(a.control).chain(a.compare.iter().copied()) {
        if let Some(w) = sc.law_warning(law.into()) {
            warn(&w);
        }
    }
    if a.device.loop_kind == LoopKind::Device {
        return cmd_run_device(a, &sc);
    }
    if a.device.loop_kind == LoopKind::Core {
        return cmd_run_core(a, &sc);
    }
    let main = simulate(&sc, a.control);
    let mut runs = vec![main];
    for &c in &a.compare {
        if c != a.control {
            runs.push(simulate(&sc, c));
        }
    }
    let main = &runs[0];
    print_summary(&sc, main);
    print_modes(&sc, a.control);
    print_at(&runs, &a.at);
    write_run_summary(&a.json, &sc, main, None)?;
    if let Some(path) = &a.csv {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| io_fail(dir, e))?;
        }
        let f = std::fs::File::create(path).map_err(|e| io_fail(path, e))?;
        main.write_csv(std::io::BufWriter::new(f))
            .map_err(|e| io_fail(path, e))?;
        println!("csv: {} ({} rows)", path.display(), main.records.len());
    }
    if let Some(dir) = &a.plot {
        let files =
            sim_host::figures::write_time_histories(&runs, dir).map_err(|e| io_fail(dir, e))?;
        for f in files {
            println!("plot: {}", f.display());
        }
    }
    Ok(())
}

/// Prints the linearised modes of the scenario's plant with `law` at its operating point
/// (pure rolling, straight track, the scenario's creep coefficients), least damped first.
fn print_modes(sc: &Scenario, law: Control) {
    let Some(modes) = sim_host::modes::modes_at_point(&sc.params, sc.axle, sc.drive, law.into())
    else {
        return;
    };
    println!(
        "modes of this plant and law at pure rolling on straight track, f11 {:.1} MN, f22 {:.1} MN (least damped first; structural zero left out):",
        sc.params.f11 * 1e-6,
        sc.params.f22 * 1e-6
    );
    for m in modes {
        let shares: Vec<String> = sim_host::modes::GROUPS
            .iter()
            .zip(m.participation)
            .filter(|(_, x)| *x >= 0.05)
            .map(|(g, x)| format!("{g} {x:.2}"))
            .collect();
        println!(
            "  {:<16} {:>7.2} Hz  zeta {:+.3}  lambda {:+.2} {:+.2}j 1/s; participation: {}",
            m.mode.name,
            m.mode.freq_hz,
            m.mode.zeta,
            m.mode.re,
            m.mode.im,
            shares.join(", ")
        );
    }
}

/// `--at`: the state of every run at each time (nearest output sample), then each
/// run's peaks. `y/y0` is the displacement over the pure rolling line (1 = on it).
fn print_at(runs: &[Trajectory], at: &[f64]) {
    if at.is_empty() {
        return;
    }
    println!(
        "{:>6} {:<8} {:>9} {:>9} {:>7} {:>9} {:>11} {:>8} {:>8} {:>8}",
        "t_s",
        "control",
        "y_mm",
        "y0_mm",
        "y/y0",
        "T_psi_Nm",
        "T_spring_Nm",
        "Fx_R_N",
        "Fx_L_N",
        "Fy_N"
    );
    for &t in at {
        for tr in runs {
            let Some(r) = tr
                .records
                .iter()
                .min_by(|a, b| (a.t_s - t).abs().total_cmp(&(b.t_s - t).abs()))
            else {
                continue;
            };
            println!(
                "{:>6.3} {:<8} {:>9.4} {:>9.4} {:>7.3} {:>9.1} {:>11.1} {:>8.1} {:>8.1} {:>8.1}",
                r.t_s,
                tr.info.control,
                r.y_m * 1e3,
                r.y0_m * 1e3,
                if r.y0_m != 0.0 {
                    r.y_m / r.y0_m
                } else {
                    f64::NAN
                },
                r.t_psi_nm,
                r.t_spring_nm,
                r.fx_r_n,
                r.fx_l_n,
                r.fy_n
            );
        }
    }
    for tr in runs {
        let peak = |f: &dyn Fn(&sim_host::sim::Record) -> f64| {
            tr.records.iter().map(f).fold(0.0f64, |a, b| a.max(b.abs()))
        };
        println!(
            "peaks, {}: |y| {:.4} mm, |T_psi| {:.1} N m, |F_x| {:.1} N, |F_y| {:.1} N",
            tr.info.control,
            peak(&|r| r.y_m) * 1e3,
            peak(&|r| r.t_psi_nm),
            peak(&|r| r.fx_r_n.abs().max(r.fx_l_n.abs())),
            peak(&|r| r.fy_n)
        );
    }
}

fn progress(total: u64, msg: &str) -> indicatif::ProgressBar {
    use std::io::IsTerminal;
    if !std::io::stderr().is_terminal() {
        return indicatif::ProgressBar::hidden();
    }
    let pb = indicatif::ProgressBar::new(total);
    if let Ok(style) =
        indicatif::ProgressStyle::with_template("{msg} [{bar:40}] {pos}/{len} points ({eta})")
    {
        pb.set_style(style.progress_chars("=> "));
    }
    pb.set_message(msg.to_string());
    pb
}

fn cmd_rates(a: &RatesArgs) -> Result<(), Failure> {
    use sim_host::sampled::{rates, Criteria, LinkBudget, Model};
    if a.delay > 10 {
        return Err(Failure {
            code: 2,
            msg: format!("--delay {}: at most 10 ticks", a.delay),
        });
    }
    if a.max_baud == 0 {
        return Err(Failure {
            code: 2,
            msg: "--max-baud 0: must be positive".into(),
        });
    }
    let p = load_params(&a.params)?;
    let mode = match a.control {
        Control::Passive => wheelset_control::YawMode::Passive,
        Control::Gain => wheelset_control::YawMode::Gain,
        Control::Lead => wheelset_control::YawMode::Lead,
    };
    let model = match a.model {
        RatesModel::Full => Model::Full,
        RatesModel::Reduced => Model::Reduced,
    };
    let mut cfg = wheelset_control::Config {
        yaw_mode: mode,
        ..wheelset_control::Config::default()
    };
    cfg.motor.k_m = p.k_m;
    cfg.motor.n = p.n_gear;
    let criteria = Criteria {
        max_baud: a.max_baud as f64,
        ..Criteria::default()
    };
    let report =
        rates(&p, model, &cfg, a.delay, &LinkBudget::default(), &criteria).map_err(|e| {
            Failure {
                code: 2,
                msg: format!("rate analysis: {e}"),
            }
        })?;
    print!("{}", report.render());
    if let Some(path) = &a.json {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| io_fail(dir, e))?;
        }
        let text = serde_json::to_string_pretty(&report.to_json()).map_err(|e| Failure {
            code: 1,
            msg: format!("JSON: {e}"),
        })?;
        std::fs::write(path, text).map_err(|e| io_fail(path, e))?;
        println!("wrote {}", path.display());
    }
    Ok(())
}

fn cmd_modes(a: &ModesArgs) -> Result<(), Failure> {
    let p = load_params(&a.params)?;
    let cases: Vec<Case> = match a.case {
        None => Case::ALL.to_vec(),
        Some(CaseArg::A) => vec![Case::A],
        Some(CaseArg::B) => vec![Case::B],
        Some(CaseArg::C) => vec![Case::C],
        Some(CaseArg::D) => vec![Case::D],
    };
    sim_host::memory::check_modes(u64::from(a.points), cases.len() as u64)
        .map_err(|msg| Failure { code: 2, msg })?;
    let grid = creep_grid(a.points as usize);
    let pb = progress((grid.len() * cases.len()) as u64, "modal sweep");
    let mut sweeps = Vec::new();
    for &case in &cases {
        let sw = sweep_case(&p, case, &grid, || pb.inc(1)).map_err(|e| Failure {
            code: 1,
            msg: e.to_string(),
        })?;
        sweeps.push(sw);
    }
    pb.finish_and_clear();
    println!(
        "modal sweep: v = {} m/s, f11 = f22 over {} points in 1-10 MN; kinematic frequency v sqrt(lambda/(r0 Lg))/2pi = {:.3} Hz",
        p.v,
        grid.len(),
        p.kinematic_hz()
    );
    println!(
        "the structural zero eigenvalue (free rolling at any speed) is excluded from every verdict"
    );
    for sw in &sweeps {
        // Conditioning at the reported points: eig(A) against eig(A^T).
        let worst = [1e6, 2e6, 5e6, 1e7]
            .iter()
            .filter_map(|&c| {
                sim_host::numeric::eigen_disagreement(&sw.case.matrix(&p, c).0).map(|d| (d, c))
            })
            .fold((0.0f64, 0.0), |a, b| if b.0 > a.0 { b } else { a });
        if worst.0 > sim_host::numeric::ILL_CONDITIONED {
            warn(&format!(
                "case ({}): the eigenvalue problem is ill-conditioned with these parameters: the \
                 eigenvalues of A and A^T differ by {:.1e} (relative) at {} MN, so the modes below \
                 carry only about {} correct digits",
                sw.case.id(),
                worst.0,
                worst.1 * 1e-6,
                (-worst.0.log10()).floor().max(0.0)
            ));
        }
        println!("case ({}): {}", sw.case.id(), sw.case.label());
        for c in [1e6, 2e6, 5e6, 1e7] {
            let Some(k) = sw.index_of(c) else { continue };
            let modes: Vec<String> = sw
                .modes_at(k)
                .iter()
                .map(|m| format!("{} {:.2} Hz zeta {:.3}", m.name, m.freq_hz, m.zeta))
                .collect();
            let z = sw.structural_zero(k).map_or(f64::NAN, |l| l.norm());
            println!(
                "  {:>4.0} MN {}: {} | structural zero |lambda| = {z:.1e}",
                c * 1e-6,
                if sw.stable_at(k) {
                    "stable  "
                } else {
                    "UNSTABLE"
                },
                modes.join("; ")
            );
        }
        if sw.crossings.is_empty() {
            println!("  no crossing in 1-10 MN");
        }
        for c in &sw.crossings {
            println!(
                "  crossing: {} at {:.4} MN, {:.2} Hz, unstable {}",
                c.mode,
                c.creep_n * 1e-6,
                c.freq_hz,
                if c.unstable_below { "below" } else { "above" }
            );
        }
    }
    let json = serde_json::json!({
        "speed_mps": p.v,
        "kinematic_hz": p.kinematic_hz(),
        "note": "structural zero eigenvalue (free rolling at any speed) reported as structural_zero and excluded from stability verdicts",
        "params": &p,
        "derived": {"k_t": p.k_t(), "k_gear": p.k_gear(), "y0_at_2300m": p.pure_rolling_y(1.0 / 2300.0)},
        "cases": sweeps.iter().map(|s| s.to_json()).collect::<Vec<_>>(),
    });
    if let Some(dir) = a.json.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| io_fail(dir, e))?;
    }
    let text = serde_json::to_string(&json).map_err(|e| Failure {
        code: 1,
        msg: e.to_string(),
    })?;
    std::fs::write(&a.json, text).map_err(|e| io_fail(&a.json, e))?;
    println!("json: {}", a.json.display());
    if let Some(dir) = &a.plot {
        for sw in &sweeps {
            let f = sim_host::figures::write_root_locus(sw, dir).map_err(|e| io_fail(dir, e))?;
            println!("plot: {}", f.display());
        }
    }
    Ok(())
}

/// `--loop core`: the f64 control core on the plant; with `--plot` and `[[adhesion]]`
/// sections also the traction figure with and without protection (`adhesion.svg`).
fn cmd_run_core(a: &RunArgs, sc: &Scenario) -> Result<(), Failure> {
    use sim_host::core_loop::run_core;
    let fail = |e: sim_host::core_loop::CoreError| Failure {
        code: 2,
        msg: e.to_string(),
    };
    let wsp = a.device.wsp != Some(OnOff::Off);
    let (tr, c) = run_core::<f64>(sc, a.control.into(), wsp).map_err(fail)?;
    print_summary(sc, &tr);
    println!(
        "wheel-slip protection {}: {} events, {} ticks acting",
        if wsp { "on" } else { "off" },
        c.wsp_events,
        c.wsp_ticks
    );
    write_run_summary(&a.json, sc, &tr, Some(wsp))?;
    if let Some(path) = &a.csv {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| io_fail(dir, e))?;
        }
        let f = std::fs::File::create(path).map_err(|e| io_fail(path, e))?;
        tr.write_csv(std::io::BufWriter::new(f))
            .map_err(|e| io_fail(path, e))?;
        println!("csv: {} ({} rows)", path.display(), tr.records.len());
    }
    if let Some(dir) = &a.plot {
        let mut runs = vec![tr];
        for &k in &a.compare {
            runs.push(simulate(sc, k));
        }
        let files =
            sim_host::figures::write_time_histories(&runs, dir).map_err(|e| io_fail(dir, e))?;
        for f in files {
            println!("plot: {}", f.display());
        }
        if !sc.adhesion.is_empty() {
            let (other, _) = run_core::<f64>(sc, a.control.into(), !wsp).map_err(fail)?;
            let (on, off) = if wsp {
                (&runs[0], &other)
            } else {
                (&other, &runs[0])
            };
            let f = sim_host::traction::write_figure(
                &[("protection on", on), ("protection off", off)],
                dir,
            )
            .map_err(|e| io_fail(dir, e))?;
            println!("plot: {}", f.display());
        }
    }
    Ok(())
}

/// `--loop device`: the firmware runtime over the simulated link; prints the frame
/// accounting and the deviation from the continuous reference.
fn cmd_run_device(a: &RunArgs, sc: &Scenario) -> Result<(), Failure> {
    use sim_host::device::{deviation, run_device, DeviceOptions, CURVE_WINDOWS};
    let d = &a.device;
    if d.wsp.is_some() {
        return Err(Failure {
            code: 2,
            msg: "--wsp: the device loop cannot switch the wheel-slip protection yet (the \
                  runtime does not forward Config.wsp to the control core); use --loop core"
                .to_string(),
        });
    }
    let latency_us = d.latency_us.unwrap_or(2.0);
    if !(latency_us.is_finite() && (0.0..=MAX_LATENCY_US).contains(&latency_us)) {
        return Err(Failure {
            code: 2,
            msg: format!(
                "--latency-us {latency_us:e}: must be a finite value in [0, {MAX_LATENCY_US:e}] us"
            ),
        });
    }
    let baud = d.baud.unwrap_or(sim_host::link::DEFAULT_BAUD);
    if baud == 0 {
        return Err(Failure {
            code: 2,
            msg: "--baud 0: must be positive".into(),
        });
    }
    if d.rate_hz == Some(0) {
        return Err(Failure {
            code: 2,
            msg: "--rate-hz 0: must be positive".into(),
        });
    }
    let faults_spec = d.faults.clone().unwrap_or_default();
    let faults: sim_host::link::Faults =
        faults_spec
            .parse()
            .map_err(|e: sim_host::link::FaultSpecError| Failure {
                code: 2,
                msg: e.to_string(),
            })?;
    let opt = DeviceOptions {
        link: sim_host::link::LinkConfig {
            baud,
            latency_ns: (latency_us * 1e3).round() as u64,
            faults,
            seed: d.seed.unwrap_or(1),
        },
        hold_ticks: d.hold_ticks.unwrap_or(wheelset_runtime::DEFAULT_HOLD_TICKS),
        base_rate_hz: d.rate_hz,
        lateral: match d.lateral.unwrap_or(Lateral::Velocity) {
            Lateral::Velocity => sim_host::device::LateralSensing::Velocity,
            Lateral::Acceleration => sim_host::device::LateralSensing::Acceleration,
        },
    };
    let hz = d
        .rate_hz
        .unwrap_or(wheelset_control::Config::default().base_rate_hz);
    let period_ns = 1_000_000_000 / u64::from(hz.max(1));
    let kept = 2 + a.compare.iter().filter(|&&c| c != a.control).count() as u64;
    sim_host::memory::check_runs(sc.duration_ns, sc.output_dt_ns, Some(period_ns), kept).map_err(
        |msg| Failure {
            code: 2,
            msg: format!("{}: {msg}", sc.source),
        },
    )?;
    if let Some(w) = sim_host::rate_check::warning(sc, a.control.into(), hz) {
        warn(&w);
    }
    let run = run_device(sc, a.control.into(), &opt).map_err(|e| Failure {
        code: 2,
        msg: e.to_string(),
    })?;
    print_summary(sc, &run.trajectory);
    write_run_summary(&a.json, sc, &run.trajectory, None)?;
    println!(
        "link: {} baud, latency {} us, period {} us, faults `{}` (seed {})",
        opt.link.baud,
        latency_us,
        run.period_ns as f64 / 1e3,
        if faults_spec.is_empty() {
            "none"
        } else {
            &faults_spec
        },
        opt.link.seed
    );
    print!("{}", run.report);
    println!();
    let reference = simulate(sc, a.control);
    println!(
        "vs continuous reference: {}",
        deviation(&run.trajectory, &reference, CURVE_WINDOWS)
    );
    if let Some(path) = &a.csv {
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir).map_err(|e| io_fail(dir, e))?;
        }
        let f = std::fs::File::create(path).map_err(|e| io_fail(path, e))?;
        run.write_csv(std::io::BufWriter::new(f))
            .map_err(|e| io_fail(path, e))?;
        println!(
            "csv: {} ({} rows)",
            path.display(),
            run.trajectory.records.len()
        );
    }
    if let Some(dir) = &a.plot {
        let mut runs = vec![run.trajectory, reference];
        for &c in &a.compare {
            if c != a.control {
                runs.push(simulate(sc, c));
            }
        }
        let files =
            sim_host::figures::write_time_histories(&runs, dir).map_err(|e| io_fail(dir, e))?;
        for f in files {
            println!("plot: {}", f.display());
        }
    }
    Ok(())
}

/// Writes `value` as pretty JSON to `path` (directories created).
fn write_json(path: &std::path::Path, value: &serde_json::Value) -> Result<(), Failure> {
    if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).map_err(|e| io_fail(dir, e))?;
    }
    let text = serde_json::to_string_pretty(value).map_err(|e| Failure {
        code: 1,
        msg: format!("{}: {e}", path.display()),
    })?;
    std::fs::write(path, text).map_err(|e| io_fail(path, e))?;
    println!("json: {}", path.display());
    Ok(())
}

/// The summary JSON of a run (`--json`): the run's description, and with `[[adhesion]]`
/// sections the `adhesion` object; prints the sections table.
fn write_run_summary(
    path: &Option<PathBuf>,
    sc: &Scenario,
    tr: &Trajectory,
    wsp: Option<bool>,
) -> Result<(), Failure> {
    let adhesion = sim_host::traction::summary(sc, tr);
    if let Some(a) = &adhesion {
        println!(
            "adhesion: runaway {}, slip peak {:.3} m/s",
            a.runaway, a.slip_peak_mps
        );
        println!("  t0-t1 s      condition  mu_peak  mu_used_mean  utilisation  slip_peak_mps");
        for s in &a.sections {
            println!(
                "  {:>5.1}-{:<5.1}  {:<9}  {:>7.4}  {:>12.4}  {:>11.3}  {:>13.3}",
                s.t0, s.t1, s.condition, s.mu_peak, s.mu_used_mean, s.utilisation, s.slip_peak_mps
            );
        }
    }
    let Some(path) = path else {
        return Ok(());
    };
    let json = serde_json::json!({
        "scenario": sc.name,
        "source": sc.source,
        "run": tr.info,
        "wsp": wsp,
        "adhesion": adhesion,
    });
    write_json(path, &json)
}

fn cmd_adhesion(a: &AdhesionArgs) -> Result<(), Failure> {
    let p = load_params(&a.params)?;
    let v = a.v_mps.unwrap_or(p.v);
    if !(v.is_finite() && (0.1..=200.0).contains(&v)) {
        return Err(Failure {
            code: 2,
            msg: format!("--v-mps {v}: must be within [0.1, 200] m/s"),
        });
    }
    let ch = sim_host::traction::characteristic(a.condition.into(), v, &p, a.points as usize);
    println!(
        "adhesion {}: v {} m/s, Q {:.1} N, f11 {:.3e} N, mu0 {} A {} B {} s/m kA {} kS {}; peak F/Q {:.4} at creepage {:.5} (slip {:.3} m/s)",
        ch.condition, ch.v_mps, ch.q_n, ch.f11_n, ch.mu0, ch.a, ch.b, ch.ka, ch.ks,
        ch.mu_peak, ch.creepage_peak, ch.slip_peak_mps
    );
    println!("source: {}", ch.source);
    let json = serde_json::to_value(&ch).map_err(|e| Failure {
        code: 1,
        msg: e.to_string(),
    })?;
    write_json(&a.json, &json)?;
    if let Some(dir) = &a.plot {
        std::fs::create_dir_all(dir).map_err(|e| io_fail(dir, e))?;
        let path = dir.join(format!("adhesion-{}.svg", ch.condition));
        ch.figure().save(&path).map_err(|e| io_fail(&path, e))?;
        println!("plot: {}", path.display());
    }
    Ok(())
}

fn print_summary(sc: &Scenario, tr: &Trajectory) {
    let p = &sc.params;
    println!(
        "scenario {} ({}), control {}, {} s, RK4 dt {} s, {} steps",
        sc.name,
        sc.source,
        tr.info.control,
        sc.duration_ns as f64 * 1e-9,
        tr.info.dt_s,
        tr.info.steps
    );
    println!(
        "plant: axle {:?}, drive {}, yaw spring {}; project defaults used: k_lat {} N/m, k_t {:.4e} N m/rad, k_gear {:.4e} N m/rad, PI Ti {} s",
        sc.axle,
        sc.drive,
        tr.info.control == "passive",
        p.k_lat,
        p.k_t(),
        p.k_gear(),
        p.pi_ti
    );
    let max = |f: &dyn Fn(&sim_host::sim::Record) -> f64| {
        tr.records.iter().map(f).fold(0.0f64, |a, b| a.max(b.abs()))
    };
    println!(
        "max |y| {:.4} mm, max |T_psi| {:.1} N m, max |F_x| {:.1} N, max |F_y| {:.1} N",
        max(&|r| r.y_m) * 1e3,
        max(&|r| r.t_psi_nm),
        max(&|r| r.fx_r_n.abs().max(r.fx_l_n.abs())),
        max(&|r| r.fy_n)
    );
    if let Some(stop) = sim_host::outcome::stop_of(tr) {
        println!("WARNING: {stop}");
    }
    if let Some(last) = tr.records.last() {
        println!(
            "end: v {:.4} m/s, i_a {:.2} A, u_a {:.1} V",
            last.v_mps, last.i_a_a, last.u_a_v
        );
    }
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
    let res = match &cli.cmd {
        Cmd::Modes(a) => cmd_modes(a),
        Cmd::Run(a) => cmd_run(a),
        Cmd::Rates(a) => cmd_rates(a),
        Cmd::Adhesion(a) => cmd_adhesion(a),
    };
    match res {
        Ok(()) => ExitCode::SUCCESS,
        Err(f) => {
            eprintln!("sim-host: error: {}", f.msg);
            ExitCode::from(f.code)
        }
    }
}
