//! Encode + decode of one tick's Sensor and Actuation frames: through the general
//! encoder and decoder, and each of the codec pairs' per-tick calls on its own (the host's
//! Sensor encoder and Actuation decoder, the device's Actuation encoder and Sensor decoder).
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
    let (Message::Sensor(sensor), Message::Actuation(act)) = (sensor, act) else {
        return;
    };
    c.bench_function("host: encode_sensor", |b| {
        let mut buf = [0u8; SENSOR_FRAME_CAP];
        b.iter(|| encode_sensor(black_box(&sensor), &mut buf));
    });
    c.bench_function("device: encode_reply(actuation)", |b| {
        let mut buf = [0u8; MAX_FRAME];
        b.iter(|| encode_reply(Reply::Actuation(black_box(&act)), &mut buf));
    });
    let mut sf = [0u8; SENSOR_FRAME_CAP];
    let sn = encode_sensor(&sensor, &mut sf);
    let mut af = [0u8; MAX_FRAME];
    let an = encode_reply(Reply::Actuation(&act), &mut af).unwrap_or(0);
    c.bench_function("device: next_sensor_or_request", |b| {
        let mut dec: Decoder = Decoder::new();
        let mut s = Sensor::ZERO;
        let mut f: Result<Request, FrameError> = Err(FrameError::Crc);
        b.iter(|| {
            dec.next_sensor_or_request(black_box(&sf[..sn]), &mut s, &mut f)
                .0
        });
    });
    c.bench_function("host: next_message(actuation)", |b| {
        let mut dec: Decoder = Decoder::new();
        b.iter(|| dec.next_message(black_box(&af[..an])).0);
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
