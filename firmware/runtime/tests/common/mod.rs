//! What the runtime's tests share: Sensor frames at the `curve` operating point
//! (115 A, 925.6 rad/s = 83.3 m/s, 2.46 kN m demand) and the decoding of what a tick
//! returned.
#![allow(dead_code)]

use wheelset_proto::{encode_vec, Actuation, Decoder, Lateral, Message, Sensor};

/// A Sensor sample at the operating point: `seq`, `t_us = 200 seq` (the 5 kHz tick; the
/// runtime does not read it), lateral `lateral`, no reference speed.
pub fn sample(seq: u16, lateral: Lateral) -> Sensor {
    Sensor {
        seq,
        t_us: seq.wrapping_mul(200),
        lateral,
        i_a_ma: 115_000,
        omega_m_mrad_s: 925_600,
        demand_nm: 2_460,
        v_ref_mm_s: 0,
    }
}

/// `m` as a frame (COBS, delimiter included).
pub fn frame(m: &Message) -> Vec<u8> {
    encode_vec(m).expect("fits").to_vec()
}

/// The frame of `s`.
pub fn sensor_frame(s: Sensor) -> Vec<u8> {
    frame(&Message::Sensor(s))
}

/// The frame of a sample with lateral velocity `y_um_s` (um/s).
pub fn vel(seq: u16, y_um_s: i32) -> Vec<u8> {
    sensor_frame(sample(seq, Lateral::Velocity(y_um_s)))
}

/// Every message in the bytes a tick returned (the runtime sends only valid frames).
pub fn frames(bytes: &[u8]) -> Vec<Message> {
    let mut dec: Decoder = Decoder::new();
    dec.messages(bytes)
        .map(|r| r.expect("the runtime only sends valid frames"))
        .collect()
}

/// The Actuation frame a tick returned (its first frame).
pub fn act(bytes: &[u8]) -> Actuation {
    match frames(bytes).first() {
        Some(Message::Actuation(a)) => *a,
        other => panic!("expected an actuation frame, got {other:?}"),
    }
}
