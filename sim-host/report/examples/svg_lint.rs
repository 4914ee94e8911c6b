//! Lints SVG files drawn by `wheelset_report::svg`: names every label that overlaps
//! another or leaves the canvas, and every panel whose data leave its axes unmarked. `cargo run -p wheelset-report --example svg_lint --
//! out/report/*.svg`; exits 1 if any file has a problem.

use std::process::ExitCode;

fn main() -> ExitCode {
    let mut bad = false;
    for path in std::env::args().skip(1) {
        match std::fs::read_to_string(&path) {
            Ok(svg) => {
                for p in wheelset_report::svg::lint::problems(&svg) {
                    println!("{path}: {p}");
                    bad = true;
                }
            }
            Err(e) => {
                eprintln!("{path}: {e}");
                bad = true;
            }
        }
    }
    if bad {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
