//! Placeholder replaced by the modal sweep benchmark.
fn main() {}
