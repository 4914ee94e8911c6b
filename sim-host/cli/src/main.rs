//! `sim-host`: the plant simulator's command line (`modes`, `rates`, `run`, `adhesion`;
//! `--help` documents each). Exit codes: 0 success, 2 bad usage or bad input file, 1
//! other failures (writing output).

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod cli;
mod figures;

use cli::{
    cmd_adhesion, cmd_modes, cmd_rates, cmd_run, AdhesionArgs, ModesArgs, RatesArgs, RunArgs,
};

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

fn main() -> ExitCode {
    let res = match &Cli::parse().cmd {
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
