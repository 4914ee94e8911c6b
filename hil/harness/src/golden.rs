//! Open-loop golden vectors through the fixed-point control core, on the host and on a
//! target, compared bit for bit.
//!
//! A vector is a sequence of sensor samples in wire codes. The **host** result is
//! `wheelset_runtime::Runtime<Fx>` ticked once per sample in this process; the **target**
//! result the Actuation frames a [`Transport`] returns for the same samples as Sensor
//! frames. Compared per tick: the torque and voltage codes, the flags and the echoed
//! sequence number (an internal difference that changes a rounding shows, and a differing
//! filter state shows in every later output). The vectors: [`vectors`].

use serde::Serialize;
use wheelset_control::{Fx, InputCodes};
use wheelset_proto::{Decoder, Message};
use wheelset_runtime::{Runtime, RuntimeConfig, RuntimeError};

use wheelset_loop::transport::{Transport, TransportError};

/// The recorded sensor stream (CSV: `y_dot_um_s,i_a_ma,omega_mrad_s,demand_nm`).
pub const RECORDED_CURVE: &str = include_str!("../../golden/curve_4.9-5.3s.csv");

/// One golden vector.
#[derive(Debug, Clone, PartialEq)]
pub struct Vector {
    /// Name.
    pub name: &'static str,
    /// What it exercises.
    pub about: &'static str,
    /// The samples, one per tick.
    pub samples: Vec<InputCodes>,
}

/// Motor speed at 25 m/s, mrad/s.
const OMEGA: i32 = 925_600;

fn codes(y_dot: i32, current: i32, speed: i32, demand: i32) -> InputCodes {
    InputCodes {
        y_dot,
        current,
        speed,
        demand,
    }
}

/// Parses the recorded stream; a malformed line names its number.
pub fn parse_recorded(text: &str) -> Result<Vec<InputCodes>, String> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') || line.starts_with("y_dot") {
            continue;
        }
        let v: Result<Vec<i32>, _> = line.split(',').map(|f| f.trim().parse::<i32>()).collect();
        match v.as_deref() {
            Ok([a, b, c, d]) => out.push(codes(*a, *b, *c, *d)),
            _ => return Err(format!("line {}: expected 4 integers, got `{line}`", i + 1)),
        }
    }
    Ok(out)
}

/// The golden vectors.
pub fn vectors() -> Result<Vec<Vector>, String> {
    let n = 2_000;
    let y_step = (0..n)
        .map(|k| codes(if k >= 100 { 10_000 } else { 0 }, 0, OMEGA, 0))
        .collect();
    let y_neg_step = (0..n)
        .map(|k| codes(if k >= 100 { -2_500 } else { 0 }, 0, OMEGA, 0))
        .collect();
    let chirp = (0..5_000)
        .map(|k| {
            let t = f64::from(k) / 5_000.0;
            let phase = 2.0 * std::f64::consts::PI * (0.5 * t + 0.5 * 499.5 * t * t);
            codes((20_000.0 * phase.sin()).round() as i32, 0, OMEGA, 0)
        })
        .collect();
    let traction = (0..n)
        .map(|k| {
            let t = (f64::from(k) - 100.0).max(0.0) / 5_000.0;
            let i = 115_000.0 * (1.0 - (-t / 0.01).exp());
            let d = if k >= 100 { 2_460 } else { 0 };
            codes(0, i.round() as i32, OMEGA, d)
        })
        .collect();
    let saturation = (0..n)
        .map(|k| {
            let s = if (k / 250) % 2 == 0 { 1 } else { -1 };
            codes(s * 1_500_000, -s * 2_500_000, OMEGA, s * 30_000)
        })
        .collect();
    Ok(vec![
        Vector {
            name: "y_step",
            about: "y' step 0 -> 10 mm/s (lead filter step response)",
            samples: y_step,
        },
        Vector {
            name: "y_neg_step",
            about: "y' step 0 -> -2.5 mm/s (negative, rounding toward -inf vs nearest)",
            samples: y_neg_step,
        },
        Vector {
            name: "y_chirp",
            about: "y' chirp 20 mm/s, 0.5 -> 500 Hz in 1 s",
            samples: chirp,
        },
        Vector {
            name: "traction_step",
            about: "demand step 2460 N m, current rising with 10 ms (PI, reference slew)",
            samples: traction,
        },
        Vector {
            name: "saturation",
            about: "inputs beyond every clamp, alternating every 50 ms (clamps, anti-windup)",
            samples: saturation,
        },
        Vector {
            name: "recorded_curve",
            about: "sensor stream recorded from the in-process closed loop, curve 4.9-5.3 s",
            samples: parse_recorded(RECORDED_CURVE)?,
        },
    ])
}

/// One tick's outputs (wire codes).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct Out {
    /// Yaw torque, 0.1 N m.
    pub t_psi_dnm: i32,
    /// Motor voltage, 10 mV.
    pub u_a_cv: i32,
    /// Flags.
    pub flags: u16,
    /// Echoed sequence number.
    pub seq_echo: u16,
}

fn sensor_frame(k: usize, s: &InputCodes) -> Vec<u8> {
    wheelset_audit::on_target::sensor_frame((k as u16).wrapping_add(1), s).unwrap_or_default()
}

fn decode_actuations(bytes: &[u8], dec: &mut Decoder, out: &mut Vec<Out>) {
    for r in dec.messages(bytes) {
        if let Ok(Message::Actuation(a)) = r {
            out.push(Out {
                t_psi_dnm: a.t_psi_dnm,
                u_a_cv: a.u_a_cv,
                flags: a.flags.0,
                seq_echo: a.seq_echo,
            });
        }
    }
}

/// The host result: the firmware's runtime in this process configured by `cfg`
/// ([`wheelset_loop::device_loop::runtime_for`]), one tick per sample.
pub fn run_host(v: &Vector, cfg: RuntimeConfig) -> Result<Vec<Out>, RuntimeError> {
    let mut rt = Runtime::<Fx>::try_new(cfg)?;
    let mut dec = Decoder::new();
    let mut out = Vec::with_capacity(v.samples.len());
    for (k, s) in v.samples.iter().enumerate() {
        rt.receive(&sensor_frame(k, s));
        let bytes = rt.tick(0).to_vec();
        decode_actuations(&bytes, &mut dec, &mut out);
    }
    Ok(out)
}

/// The target result: each sample as a Sensor frame through `tr` at `k T`, the
/// actuation received by `(k + 1) T`.
pub fn run_target(
    v: &Vector,
    tr: &mut dyn Transport,
    period_ns: u64,
) -> Result<Vec<Out>, TransportError> {
    let mut dec = Decoder::new();
    let mut out = Vec::with_capacity(v.samples.len());
    for (k, s) in v.samples.iter().enumerate() {
        let t = k as u64 * period_ns;
        tr.send(t, &sensor_frame(k, s))?;
        tr.recv(t + period_ns, &mut |_, bytes| {
            decode_actuations(bytes, &mut dec, &mut out)
        })?;
    }
    Ok(out)
}

/// One vector's comparison.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Comparison {
    /// Vector name.
    pub name: String,
    /// What it exercises.
    pub about: String,
    /// Ticks.
    pub ticks: usize,
    /// Actuations the target returned.
    pub target_ticks: usize,
    /// Ticks whose outputs differ in any bit (or are missing).
    pub mismatches: usize,
    /// The first differing tick: (tick, host, target).
    pub first_mismatch: Option<(usize, Out, Option<Out>)>,
    /// Largest |torque| and |voltage| codes seen on the host (the vector is not trivial).
    pub host_peak: (i32, i32),
    /// Identical bit for bit.
    pub identical: bool,
}

/// Compares host and target outputs.
#[must_use]
pub fn compare(v: &Vector, host: &[Out], target: &[Out]) -> Comparison {
    let mut mismatches = 0;
    let mut first = None;
    for (k, h) in host.iter().enumerate() {
        let t = target.get(k).copied();
        if t != Some(*h) {
            mismatches += 1;
            first.get_or_insert((k, *h, t));
        }
    }
    mismatches += target.len().saturating_sub(host.len());
    let host_peak = host.iter().fold((0, 0), |(a, b), o| {
        (
            a.max(o.t_psi_dnm.saturating_abs()),
            b.max(o.u_a_cv.saturating_abs()),
        )
    });
    Comparison {
        name: v.name.into(),
        about: v.about.into(),
        ticks: host.len(),
        target_ticks: target.len(),
        mismatches,
        first_mismatch: first,
        host_peak,
        identical: mismatches == 0 && host.len() == v.samples.len(),
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn the_vectors_are_valid_and_not_trivial() {
        let vs = vectors().unwrap();
        assert_eq!(vs.len(), 6);
        for v in &vs {
            let host = run_host(v, RuntimeConfig::default()).unwrap();
            assert_eq!(host.len(), v.samples.len(), "{}", v.name);
            let moving = host.windows(2).filter(|w| w[0] != w[1]).count();
            assert!(moving > 10, "{}: the outputs barely move", v.name);
            // The host result is deterministic and equals itself.
            let c = compare(v, &host, &run_host(v, RuntimeConfig::default()).unwrap());
            assert!(c.identical, "{}", v.name);
        }
        assert!(vs.iter().all(|v| !v.samples.is_empty()));
    }

    #[test]
    fn a_single_changed_bit_is_found() {
        let vs = vectors().unwrap();
        let v = &vs[0];
        let host = run_host(v, RuntimeConfig::default()).unwrap();
        let mut bad = host.clone();
        bad[1234].u_a_cv ^= 1;
        let c = compare(v, &host, &bad);
        assert!(!c.identical);
        assert_eq!(c.mismatches, 1);
        assert_eq!(c.first_mismatch.map(|m| m.0), Some(1234));
        let c = compare(v, &host, &host[..10]);
        assert_eq!(c.mismatches, host.len() - 10);
    }

    #[test]
    fn a_malformed_recording_names_the_line() {
        let e = parse_recorded("y_dot_um_s,i_a_ma,omega_mrad_s,demand_nm\n1,2,3,4\n1,2,x,4\n")
            .unwrap_err();
        assert!(e.contains("line 3"), "{e}");
    }
}
