//! The same-run reference of the benchmarks: a fixed workload timed interleaved with the
//! benchmark's own, so that both see the same machine and load, and the ratio
//! `workload / reference` is stated with the absolutes and the conditions beside it.
//!
//! The reference is an RK4 integration of a damped 2-state oscillator, `x'' = -w^2 x -
//! 2 zeta w x'` with `w = 2 pi 10 rad/s`, `zeta = 0.1`, 200 000 steps of 1e-4 s (the
//! curve run's step count and step): f64 arithmetic with no memory traffic, the kind of
//! work the plant does, so a slower or busier core scales both alike. Every benchmark of
//! `sim-host` prints its ratio line after criterion's figures.
#![allow(dead_code)]

use std::hint::black_box;
use std::time::{Duration, Instant};

/// The reference workload: 200 000 RK4 steps of the damped oscillator; returns `x`.
pub fn reference() -> f64 {
    let (w, zeta, h) = (2.0 * std::f64::consts::PI * 10.0, 0.1, 1e-4);
    let f = |x: f64, v: f64| (v, -w * w * x - 2.0 * zeta * w * v);
    let (mut x, mut v) = (black_box(1e-3), black_box(0.0));
    for _ in 0..200_000 {
        let (k1x, k1v) = f(x, v);
        let (k2x, k2v) = f(x + 0.5 * h * k1x, v + 0.5 * h * k1v);
        let (k3x, k3v) = f(x + 0.5 * h * k2x, v + 0.5 * h * k2v);
        let (k4x, k4v) = f(x + h * k3x, v + h * k3v);
        x += h / 6.0 * (k1x + 2.0 * k2x + 2.0 * k3x + k4x);
        v += h / 6.0 * (k1v + 2.0 * k2v + 2.0 * k3v + k4v);
    }
    x
}

fn median(v: &mut [Duration]) -> Duration {
    v.sort();
    v[v.len() / 2]
}

/// The 1-minute load average (`/proc/loadavg`), if readable.
fn load_average() -> Option<f64> {
    std::fs::read_to_string("/proc/loadavg")
        .ok()?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// Times `work` and [`reference`] alternately, `rounds` times each, and prints the ratio
/// of the medians with both absolutes, the load average and the core count:
///
/// `ratio NAME / reference = R (NAME median A ms, reference median B ms; N rounds
/// interleaved; load average L, C cores)`
///
/// Returns the ratio.
pub fn ratio<T>(name: &str, rounds: usize, mut work: impl FnMut() -> T) -> f64 {
    let (mut a, mut b) = (Vec::new(), Vec::new());
    black_box(reference());
    black_box(work());
    let load0 = load_average();
    for _ in 0..rounds.max(1) {
        let t = Instant::now();
        black_box(work());
        a.push(t.elapsed());
        let t = Instant::now();
        black_box(reference());
        b.push(t.elapsed());
    }
    let (ma, mb) = (median(&mut a), median(&mut b));
    let r = ma.as_secs_f64() / mb.as_secs_f64();
    let load = match (load0, load_average()) {
        (Some(x), Some(y)) => format!("{x:.1}-{y:.1}"),
        _ => "unknown".into(),
    };
    println!(
        "ratio {name} / reference = {r:.2} ({name} median {:.3} ms, reference median {:.3} ms; \
         {} rounds interleaved; load average {load}, {} cores)",
        ma.as_secs_f64() * 1e3,
        mb.as_secs_f64() * 1e3,
        a.len(),
        std::thread::available_parallelism().map_or(0, |n| n.get())
    );
    r
}
