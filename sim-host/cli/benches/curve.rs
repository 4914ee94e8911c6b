//! The 20 s `curve` scenario with traction, continuous phase-lead and PI controllers,
//! RK4 at 1e-4 s (200 000 steps). Target: at most 50 ms.
//! Run: `cargo bench -p sim-host --bench curve`.

mod common;

use criterion::{black_box, criterion_main, Criterion};
use wheelset_plant::control::YawLaw;
use wheelset_plant::params::Params;
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::run_continuous;

fn bench(c: &mut Criterion) {
    let sc = Scenario::load("curve", &Params::default()).expect("built-in scenario");
    let mut g = c.benchmark_group("curve");
    g.sample_size(20);
    g.bench_function("curve_20s_rk4_1e-4_lead", |b| {
        b.iter(|| black_box(run_continuous(black_box(&sc), YawLaw::Lead)))
    });
    g.finish();
    common::ratio("curve_20s_rk4_1e-4_lead", 20, || {
        run_continuous(&sc, YawLaw::Lead)
    });
}

#[allow(missing_docs)]
mod group {
    criterion::criterion_group!(benches, super::bench);
}
use group::benches;
criterion_main!(benches);
