//! Encode + decode of one tick's Sensor and Actuation frames.
#![allow(missing_docs)]

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use wheelset_proto::oracle::*;
use wheelset_proto::*;

fn bench(c: &mut Criterion) {
    let sensor = Message::Sensor(Sensor {
        seq: 40_000,
        t_us: 12_345,
        lateral: Lateral::Velocity(2_000),
        i_a_ma: 115_000,
        omega_m_mrad_s: 925_600,
        demand_nm: 2_460,
        v_ref_mm_s: 0,
    });
    let act = Message::Actuation(Actuation {
        seq_echo: 40_000,
        tick: 40_001,
        exec: 600,
        flags: Flags(Flags::ENABLED),
        t_psi_dnm: 2_000,
        u_a_cv: 396_500,
    });
    c.bench_function("encode+decode sensor+actuation", |b| {
        let mut buf = [0u8; MAX_FRAME];
        let mut dec: Decoder = Decoder::new();
        b.iter(|| {
            let mut got = 0u32;
            for m in [&sensor, &act] {
                let n = encode(black_box(m), &mut buf).unwrap_or(0);
                dec.feed(&buf[..n], |r| got += u32::from(r.is_ok()));
            }
            got
        });
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
