//! `sim-host`: the plant simulator's command line.
//!
//! - `sim-host modes [--case a|b|c|d] [--points N] --json FILE [--plot DIR]`
//! - `sim-host rates [--control lead|gain|passive] [--model full|reduced] [--delay N]
//!   [--max-baud B] [--json FILE]`: the sampled-data rate analysis of the firmware loops
//! - `sim-host run --scenario curve|beating|FILE --control passive|gain|lead [--csv FILE] [--plot DIR]`
//! - `sim-host run ... --loop device [--wsp on|off] [--faults SPEC] [--seed N] [--baud B] [--latency-us L]`:
//!   the firmware runtime in the loop over the simulated serial link
//! - `sim-host run ... --loop core [--wsp on|off]`: the f64 control core on the plant
//!   (the device's laws and timing without the link)
//! - `sim-host run ... --json FILE`: the run's summary (with `[[adhesion]]` sections: the
//!   per-section adhesion table and the runaway verdict, `wheelset_plant::traction`)
//! - `sim-host adhesion --condition dry|wet|low [--v-mps V] --json FILE [--plot DIR]`:
//!   Polach's creep characteristic `F/Q` against creepage 0..0.2
//!
//! Exit codes: 0 success, 2 bad usage or bad input file, 1 other failures (writing output).

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
