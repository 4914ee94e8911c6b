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
    // Varying values, as in a run (a constant frame predicts every branch): 1024 frames
    // of a slow swing plus pseudo-random noise in each field.
    let mut x = 0x2545_f491_4f6c_dd1du64;
    let mut noise = |scale: i32| {
        x ^= x << 13;
        x ^= x >> 7;
        x ^= x << 17;
        (x % (2 * scale as u64 + 1)) as i32 - scale
    };
    let mut sensors = Vec::new();
    let mut acts = Vec::new();
    for k in 0..1024i32 {
        let swing = |amp: f64| (amp * (f64::from(k) * 0.05).sin()) as i32;
        sensors.push(Sensor {
            seq: k as u16,
            t_us: (k * 200) as u16,
            lateral: Lateral::Velocity(swing(3_000.0) + noise(200)),
            i_a_ma: 115_000 + swing(20_000.0) + noise(2_000),
            omega_m_mrad_s: 925_600 + noise(500),
            demand_nm: 2_460 + noise(30),
            v_ref_mm_s: 83_333 + noise(5),
        });
        acts.push(Actuation {
            seq_echo: k as u16,
            tick: (k + 1) as u16,
            exec: 0,
            flags: Flags(Flags::ENABLED | if k % 7 == 0 { Flags::YAW_SAT } else { 0 }),
            t_psi_dnm: swing(4_000.0) + noise(300),
            u_a_cv: 396_500 + noise(3_000),
        });
    }
    c.bench_function("host: encode_sensor x1024 varying", |b| {
        let mut buf = [0u8; SENSOR_FRAME_CAP];
        b.iter(|| {
            let mut n = 0;
            for s in &sensors {
                n += encode_sensor(black_box(s), &mut buf);
            }
            n
        });
    });
    c.bench_function("device: encode_reply(actuation) x1024 varying", |b| {
        let mut buf = [0u8; MAX_FRAME];
        b.iter(|| {
            let mut n = 0;
            for a in &acts {
                n += encode_reply(Reply::Actuation(black_box(a)), &mut buf).unwrap_or(0);
            }
            n
        });
    });
    let frames = |enc: &mut dyn FnMut(usize, &mut [u8]) -> usize| {
        let mut all = Vec::new();
        for k in 0..1024 {
            let mut buf = [0u8; MAX_FRAME];
            let n = enc(k, &mut buf);
            all.extend_from_slice(&buf[..n]);
        }
        all
    };
    let sensor_stream = frames(&mut |k, buf| {
        let mut f = [0u8; SENSOR_FRAME_CAP];
        let n = encode_sensor(&sensors[k], &mut f);
        buf[..n].copy_from_slice(&f[..n]);
        n
    });
    let act_stream =
        frames(&mut |k, buf| encode_reply(Reply::Actuation(&acts[k]), buf).unwrap_or(0));
    c.bench_function("device: next_sensor_or_request x1024 varying", |b| {
        let mut dec: Decoder = Decoder::new();
        let mut s = Sensor::ZERO;
        let mut f: Result<Request, FrameError> = Err(FrameError::Crc);
        b.iter(|| {
            let (mut rest, mut got) = (&sensor_stream[..], 0u32);
            while !rest.is_empty() {
                let (r, more) = dec.next_sensor_or_request(black_box(rest), &mut s, &mut f);
                got += u32::from(r == NextFrame::Sensor);
                rest = more;
            }
            got
        });
    });
    c.bench_function("host: next_message(actuation) x1024 varying", |b| {
        let mut dec: Decoder = Decoder::new();
        b.iter(|| {
            let (mut rest, mut got) = (&act_stream[..], 0u32);
            while !rest.is_empty() {
                let (r, more) = dec.next_message(black_box(rest));
                got += u32::from(matches!(r, Some(Ok(_))));
                rest = more;
            }
            got
        });
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
