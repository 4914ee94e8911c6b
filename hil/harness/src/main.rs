//! `hil`: the harness's command line. `hil` alone is `hil run` with the defaults (the
//! in-process target, the `curve` scenario, the phase-lead law).
//!
//! Exit codes: 0 pass (warnings included), 1 a check failed, 2 bad flags or input files,
//! 3 the target could not be used (QEMU or the ELF missing, no such port, I/O).

use std::process::ExitCode;

use clap::{Parser, Subcommand};
use wheelset_report::Verdict;

/// `println!` that ends the program quietly with success on a closed stdout (`hil |
/// head`), as Unix tools do, instead of panicking (`wheelset_report::out`).
macro_rules! say {
    ($($t:tt)*) => {
        wheelset_report::outln!($($t)*)
    };
}

mod cli;

use cli::{
    cmd_golden, cmd_run, cmd_serve, cmd_soak, cmd_sweep, input, GoldenArgs, RunArgs, ServeArgs,
    SoakArgs, SweepCmd,
};

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
    Audit(wheelset_audit::AuditArgs),
    /// The closed loop at every point of a parameter grid (`--param KEY=FROM..TO:N`,
    /// repeatable), on all cores: one JSON record per point, a Markdown table and heat
    /// maps. `hil sweep merge` joins `--shard` parts. Exit 1 if a point failed.
    Sweep(SweepCmd),
    /// A free-running stand-in for a board: the firmware's runtime on its own clock at
    /// the base rate behind a pseudo-terminal it creates (prints its path), answering
    /// every tick. For `hil run --target serial:PATH` (real-time pacing).
    Serve(ServeArgs),
    /// A simulated day (or any hours) of service with nothing lost: one runtime over the
    /// simulated link through a random track, link, adhesion and actuator faults and
    /// Config changes, checked at every tick; or (`--target qemu-free`) the free-running
    /// firmware under QEMU in real time. Exit 1 on the first failure, named with its
    /// simulated time and seed.
    Soak(SoakArgs),
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
        Some(Cmd::Soak(a)) => cmd_soak(a),
        Some(Cmd::Audit(a)) => match wheelset_audit::run(a) {
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
