//! `hil`: the harness's command line.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

/// The wheelset controller's harness.
#[derive(Debug, Parser)]
#[command(name = "hil", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Fixed-point accuracy audit of the control core (JSON + Markdown report).
    Audit(hil::audit::AuditArgs),
}

fn main() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(if e.use_stderr() { 2 } else { 0 });
        }
    };
    match cli.command {
        Command::Audit(a) => match hil::audit::run(&a) {
            Ok(code) => ExitCode::from(code),
            Err(e) => {
                eprintln!("{e}");
                ExitCode::from(2)
            }
        },
    }
}
