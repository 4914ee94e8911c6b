//! `sim-host`: the plant simulator's command line.
fn main() {}
