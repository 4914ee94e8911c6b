//! The modal sweep: 1000 creep points for each of the four cases (a)-(d), with mode
//! tracking and crossing bisection (the computation of `sim-host modes`, without its
//! JSON). Run: `cargo bench -p sim-host --bench sweep`.

mod common;

use criterion::{black_box, criterion_main, Criterion};
use wheelset_plant::modes::{creep_grid, sweep_case, Case};
use wheelset_plant::params::Params;

fn bench(c: &mut Criterion) {
    let p = Params::default();
    let grid = creep_grid(1000);
    let mut g = c.benchmark_group("modes");
    g.sample_size(10);
    g.bench_function("sweep_4_cases_x_1000_points", |b| {
        b.iter(|| {
            for case in Case::ALL {
                black_box(sweep_case(&p, case, black_box(&grid), || {}).ok());
            }
        })
    });
    g.finish();
    common::ratio("sweep_4_cases_x_1000_points", 10, || {
        for case in Case::ALL {
            black_box(sweep_case(&p, case, &grid, || {}).ok());
        }
    });
}

#[allow(missing_docs)]
mod group {
    criterion::criterion_group!(benches, super::bench);
}
use group::benches;
criterion_main!(benches);
