//! `hil`: the harness's command line.
fn main() {}
