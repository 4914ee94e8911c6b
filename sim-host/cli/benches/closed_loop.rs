//! The 20 s `curve` scenario with the phase lead, closed over the simulated serial link:
//! the fixed-point firmware runtime at its default rate, default link, no faults (the
//! device loop of `sim-host run --scenario curve --control lead --loop device`, without
//! its continuous reference). Run: `cargo bench -p sim-host --bench closed_loop`; the
//! whole process side by side with another build: `scripts/loop-bench.sh`.

mod common;

use criterion::{black_box, criterion_main, Criterion};
use wheelset_loop::device_loop::{run_device, DeviceOptions};
use wheelset_plant::control::YawLaw;
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;

fn bench(c: &mut Criterion) {
    let sc = Scenario::load("curve", &Params::default()).expect("built-in scenario");
    let opt = DeviceOptions::default();
    let mut g = c.benchmark_group("closed_loop");
    g.sample_size(10);
    g.bench_function("curve_20s_lead_device_link", |b| {
        b.iter(|| black_box(run_device(black_box(&sc), YawLaw::Lead, &opt).expect("runs")))
    });
    g.finish();
    common::ratio("curve_20s_lead_device_link", 10, || {
        run_device(&sc, YawLaw::Lead, &opt).expect("runs")
    });
}

#[allow(missing_docs)]
mod group {
    criterion::criterion_group!(benches, super::bench);
}
use group::benches;
criterion_main!(benches);
