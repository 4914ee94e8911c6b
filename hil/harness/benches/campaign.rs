//! A campaign point and a small campaign of `hil sweep`, in process: one point is `hil
//! run`'s closed loop (the 20 s curve, phase lead, the in-process device over the
//! simulated link) with its checks; the campaign runs four points on one thread through
//! `run_campaign`, as `hil sweep --param f11=5e6..8e6:4 --jobs 1` does. The campaign's
//! time over four is what a point costs inside a campaign.
//! Run: `cargo bench -p hil --bench campaign`.
#![allow(missing_docs)]

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use hil::run::{run, RunOptions};
use hil::sweep::{self, Campaign, Header, Identity};

fn campaign() -> Campaign {
    let axes = vec!["f11=5e6..8e6:4".parse().unwrap_or_else(|e| panic!("{e}"))];
    let base = RunOptions {
        progress: false,
        ..RunOptions::default()
    };
    Campaign {
        header: Header {
            scenario: base.scenario.clone(),
            control: base.control,
            target: base.target.to_string(),
            faults: String::new(),
            seed: base.link.seed,
            params_file: None,
            budget_file: None,
            sets: Vec::new(),
            follows: sweep::followers(&axes),
            points: 4,
            axes,
            identity: Identity {
                hil_version: env!("CARGO_PKG_VERSION").to_string(),
                hil_sha256: String::new(),
                elf_sha256: None,
                scenario_sha256: None,
                params_sha256: None,
                budget_sha256: None,
            },
        },
        base,
    }
}

fn bench(c: &mut Criterion) {
    let mut g = c.benchmark_group("campaign");
    g.sample_size(10);
    let point = RunOptions {
        progress: false,
        ..RunOptions::default()
    };
    g.bench_function("point_curve_20s_lead_inproc", |b| {
        b.iter(|| black_box(run(black_box(&point)).unwrap_or_else(|e| panic!("{e}"))))
    });
    let c4 = campaign();
    g.bench_function("campaign_4_points_1_thread", |b| {
        b.iter(|| {
            black_box(
                sweep::run_campaign(black_box(&c4), None, 1, &mut |_, _| {})
                    .unwrap_or_else(|e| panic!("{e}")),
            )
        })
    });
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
