//! One controller tick (both loops, limits, counters) for each sample type, and the
//! wire-code tick of the fixed-point build. `cargo bench -p wheelset-control`.
// criterion_group! generates an undocumented fn.
#![allow(missing_docs)]

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use wheelset_control::{Config, Controller, FixedController, InputCodes, Inputs, Sample};

fn bench_type<T: Sample>(c: &mut Criterion) {
    let cfg = Config::default();
    let mut ctl = Controller::<T>::try_new(&cfg).expect("valid");
    // A varying, in-range input so no branch is trivially predicted away.
    let inputs: Vec<Inputs<T>> = (0..1024)
        .map(|k| {
            let s = (k as f64 * 0.37).sin();
            Inputs::from_si(&cfg.scales, 0.01 * s, 115.0 + 20.0 * s, 925.6, 2460.0)
        })
        .collect();
    let mut k = 0usize;
    c.bench_function(&format!("tick {}", T::NAME), |b| {
        b.iter(|| {
            k = (k + 1) & 1023;
            black_box(ctl.tick(black_box(&inputs[k])))
        })
    });
}

fn bench_codes(c: &mut Criterion) {
    let cfg = Config::default();
    let mut ctl = FixedController::try_new(&cfg).expect("valid");
    let codes: Vec<InputCodes> = (0..1024)
        .map(|k| InputCodes {
            y_dot: (k * 37) % 2001 - 1000,
            current: 115_000 + (k * 13) % 999,
            speed: 925_600,
            demand: 2460,
        })
        .collect();
    let mut k = 0usize;
    c.bench_function("tick_codes Q4.28", |b| {
        b.iter(|| {
            k = (k + 1) & 1023;
            black_box(ctl.tick_codes(black_box(&codes[k])))
        })
    });
}

fn benches(c: &mut Criterion) {
    bench_type::<wheelset_control::Fx>(c);
    bench_type::<f32>(c);
    bench_type::<f64>(c);
    bench_codes(c);
}

criterion_group!(tick, benches);
criterion_main!(tick);
