//! Encode + decode of one tick's Sensor and Actuation frames, and the per-tick calls on
//! their own (the host's Sensor encoder and Actuation decoder, the device's Actuation
//! encoder and Sensor decoder).
#![allow(missing_docs)]

use criterion::{black_box, criterion_group, criterion_main, Criterion};
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
        let mut dec = Decoder::new();
        b.iter(|| {
            let mut got = 0u32;
            for m in [&sensor, &act] {
                let n = encode(black_box(m), &mut buf).unwrap_or(0);
                got += dec.messages(&buf[..n]).filter(Result::is_ok).count() as u32;
            }
            got
        });
    });
    for (name, m) in [("encode sensor", &sensor), ("encode actuation", &act)] {
        c.bench_function(name, |b| {
            let mut buf = [0u8; MAX_FRAME];
            b.iter(|| encode(black_box(m), &mut buf));
        });
    }
    let s = encode_vec(&sensor).unwrap_or_default();
    c.bench_function("device: next_request(sensor)", |b| {
        let mut dec = Decoder::new();
        b.iter(|| dec.next_request(black_box(&s)).0);
    });
    let a = encode_vec(&act).unwrap_or_default();
    c.bench_function("host: next_message(actuation)", |b| {
        let mut dec = Decoder::new();
        b.iter(|| dec.next_message(black_box(&a)).0);
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
