//! The device loop over the link without the plant: 20 s at the default 5 kHz rate
//! (100 000 exchanges through the closed-loop adapter and the in-process device), to
//! separate the link + runtime cost from the plant's.
#![allow(missing_docs)]

mod common;

use criterion::{criterion_group, criterion_main, Criterion};
use wheelset_control::Fx;
use wheelset_loop::device_loop::{DeviceFault, InProc};
use wheelset_loop::exchange::{DeviceController, LoopSetup};
use wheelset_loop::sim_link::LinkConfig;
use wheelset_plant::control::{Measurements, SampledController};
use wheelset_runtime::RuntimeConfig;

/// 100 000 exchanges of the in-process device over the default link.
fn exchanges() -> f64 {
    let mut d = InProc::<Fx>::try_new(
        RuntimeConfig::default(),
        &LinkConfig::default(),
        DeviceFault::None,
    )
    .unwrap_or_else(|e| panic!("{e}"));
    let t = d.period_ns();
    let mut ctrl = DeviceController::new(
        &mut d,
        4.28,
        LoopSetup {
            period_ns: t,
            ..LoopSetup::default()
        },
    );
    ctrl.reserve(100_000);
    let mut acc = 0.0;
    for k in 0..100_000u64 {
        let m = Measurements {
            yd_mps: 1e-3 * ((k as f64) * 1e-3).sin(),
            i_a: 100.0,
            w_m: 925.6,
            demand_nm: 2460.0,
            ..Measurements::default()
        };
        acc += ctrl.step(k * t, &m).t_psi;
    }
    acc
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("device_link");
    g.sample_size(10);
    g.bench_function("20 s at 5 kHz, no plant", |b| b.iter(exchanges));
    g.finish();
    common::ratio("device_link_100000_exchanges", 10, exchanges);
}

criterion_group!(benches, bench);
criterion_main!(benches);
