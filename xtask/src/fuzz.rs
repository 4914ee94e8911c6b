//! `cargo xtask fuzz --frames N [--seed S]`: hostile frames into the device runtime
//! (`Runtime<Fx>` and `Runtime<f32>`) from a seeded generator ([`Gen`]): valid,
//! bit-flipped, truncated, random, CRC-valid and oversize frames and hostile Configs, fed
//! in random chunks with 0-2 ticks after each. Checked after every frame and tick: no
//! panic (overflow checks on), every frame accounted by exactly the receive counter the
//! host's decoder expects, every Actuation within the actuator limits, every byte out a
//! valid frame (`docs/hardening.md`). A short seeded run is a unit test of this crate.

use std::panic::{catch_unwind, AssertUnwindSafe};
use std::time::Instant;

use wheelset_control::{Config as ControlConfig, Fx, SampleBits};
use wheelset_loop::inproc::rx_counts;
use wheelset_proto::units::{TORQUE_LSB_NM, VOLTAGE_LSB_V};
use wheelset_proto::{Command, Decoder, FrameError, Message};
use wheelset_runtime::{Runtime, RuntimeConfig};

mod gen;
#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests;

use gen::frame;
pub use gen::{Gen, KINDS};

/// The command line: `--frames N` (per sample type), `--seed S`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Args {
    /// Frames per sample type.
    pub frames: u64,
    /// Seed of the generator.
    pub seed: u64,
}

/// Parses `--frames N [--seed S]` (both also as `--x=V`).
pub fn parse_args(args: &[String]) -> Result<Args, String> {
    let usage = "usage: cargo xtask fuzz --frames N [--seed S]";
    let mut frames = None;
    let mut seed = 1u64;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let (flag, inline) = match a.split_once('=') {
            Some((f, v)) => (f, Some(v.to_string())),
            None => (a.as_str(), None),
        };
        let mut value = |name: &str| -> Result<u64, String> {
            let v = inline
                .clone()
                .or_else(|| it.next().cloned())
                .ok_or_else(|| format!("{name}: needs a value ({usage})"))?;
            let v = v.replace('_', "");
            v.parse::<u64>()
                .map_err(|_| format!("{name}: `{v}` is not a whole number >= 0 ({usage})"))
        };
        match flag {
            "--frames" => {
                let n = value("--frames")?;
                if n == 0 {
                    return Err(format!("--frames: must be at least 1 ({usage})"));
                }
                frames = Some(n);
            }
            "--seed" => seed = value("--seed")?,
            other => {
                return Err(format!(
                    "cargo xtask fuzz: unknown argument `{other}` ({usage})"
                ))
            }
        }
    }
    let frames = frames.ok_or_else(|| format!("--frames is required ({usage})"))?;
    Ok(Args { frames, seed })
}

/// What one sample type's run saw.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct Report {
    /// The sample type.
    pub numeric: &'static str,
    /// Frames generated, per kind ([`KINDS`]).
    pub generated: [u64; 8],
    /// Non-empty frames the device saw (a flipped byte to 0x00 splits one in two).
    pub frames_seen: u64,
    /// Of those, frames that reset the counters (not in `rx`).
    pub resets: u64,
    /// Ticks run.
    pub ticks: u64,
    /// The device's receive counters summed over the run, in [`rx_counts`]' order.
    pub rx: [u64; 7],
    /// Config frames the device took.
    pub configs_applied: u64,
    /// Config frames refused.
    pub configs_refused: u64,
    /// Status frames received and checked.
    pub status_frames: u64,
    /// Largest `|T_psi|` and `|u_a|` emitted, wire LSBs.
    pub max_torque: i64,
    /// See `max_torque`.
    pub max_voltage: i64,
}

/// Which receive counter a frame should move, by the host's decoder.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Expect {
    /// `rx_ok` (index 0); `reset`: the counters are zero afterwards.
    Ok { reset: bool },
    /// An error counter (index 1-5).
    Err(usize),
    /// The host's decoder says length or postcard error (index 4 or 5): the device
    /// rejects it the same way, counts a frame of a type it does not take unexpected
    /// (6), or counts an undefined Command variant or Config mode valid (refused).
    ErrOrUnexpected(usize),
    /// A valid frame of a device -> host type: `rx_unexpected` only (index 6).
    Unexpected,
}

fn host_expect(frame: &[u8]) -> Expect {
    let mut dec: Decoder = Decoder::new();
    match dec.messages(frame).last() {
        Some(Ok(Message::Command(Command::ResetCounters))) => Expect::Ok { reset: true },
        Some(Ok(Message::Actuation(_) | Message::Status(_))) => Expect::Unexpected,
        Some(Ok(_)) => Expect::Ok { reset: false },
        Some(Err(e @ (FrameError::Length | FrameError::Postcard))) => {
            Expect::ErrOrUnexpected(1 + e.index())
        }
        Some(Err(e)) => Expect::Err(1 + e.index()),
        // The host's decoder saw no frame: the device must not count one either.
        None => Expect::Err(usize::MAX),
    }
}

/// Limits of the outputs, wire LSBs: `|T_psi| <= torque`, `voltage.0 <= u_a <= voltage.1`.
#[derive(Debug, Clone, Copy)]
struct OutputLimits {
    torque: i64,
    voltage: (i64, i64),
}

fn output_limits() -> OutputLimits {
    let l = ControlConfig::default().limits;
    // One LSB of slack for the rounding of the limit itself to the wire.
    OutputLimits {
        torque: (l.torque / TORQUE_LSB_NM).ceil() as i64 + 1,
        voltage: (
            (l.voltage_min / VOLTAGE_LSB_V).floor() as i64 - 1,
            (l.voltage_max / VOLTAGE_LSB_V).ceil() as i64 + 1,
        ),
    }
}

/// One sample type's run of `n` frames from `seed`.
pub fn run<T: SampleBits>(n: u64, seed: u64) -> Result<Report, String> {
    let numeric = if T::NUMERIC == 0 { "Fx" } else { "f32" };
    let fail =
        |i: u64, what: String| format!("fuzz FAILED ({numeric}, seed {seed}, frame {i}): {what}");
    let mut g = Gen::new(seed ^ (u64::from(T::NUMERIC) << 56));
    let mut rt = Runtime::<T>::try_new(RuntimeConfig::default())
        .map_err(|e| format!("fuzz: the default runtime does not build: {e}"))?;
    let lim = output_limits();
    let mut rep = Report {
        numeric,
        ..Report::default()
    };
    let mut seq = 0u16;
    let mut exec = 0u32;
    for i in 0..n {
        let (kind, body) = frame::<T>(&mut g, &mut seq);
        rep.generated[kind] += 1;
        // The frames the device will see: the non-empty runs between delimiters.
        for part in body.split(|&b| b == 0).filter(|p| !p.is_empty()) {
            let mut bytes = part.to_vec();
            bytes.push(0);
            let expect = host_expect(&bytes);
            let before = *rt.counters();
            let refused_before = before.cmd_refused;
            let fed = catch_unwind(AssertUnwindSafe(|| {
                let mut rest = &bytes[..];
                while !rest.is_empty() {
                    let k = 1 + g.below(rest.len() as u64) as usize;
                    let (a, b) = rest.split_at(k);
                    rt.receive(a);
                    rest = b;
                }
            }));
            if fed.is_err() {
                return Err(fail(i, format!("receive panicked on {bytes:02x?}")));
            }
            rep.frames_seen += 1;
            let after = *rt.counters();
            let (b, a) = (rx_counts(&before), rx_counts(&after));
            let moved: Vec<usize> = (0..7).filter(|&k| a[k] != b[k]).collect();
            let one_up = |k: usize| moved == [k] && a[k] == b[k].wrapping_add(1);
            let ok = match expect {
                Expect::Ok { reset: true } => a == [0; 7],
                Expect::Ok { reset: false } => one_up(0),
                Expect::Err(k) => one_up(k),
                Expect::Unexpected => one_up(6),
                Expect::ErrOrUnexpected(k) => {
                    one_up(k)
                        || one_up(6)
                        || (k == 5
                            && one_up(0)
                            && after.cmd_refused == before.cmd_refused.wrapping_add(1))
                }
            };
            if !ok {
                let what = format!(
                    "frame {bytes:02x?} not accounted: host expects {expect:?}, device \
                     counters {b:?} -> {a:?}"
                );
                return Err(fail(i, what));
            }
            if matches!(expect, Expect::Ok { reset: true }) {
                rep.resets += 1;
                continue;
            }
            for k in 0..7 {
                rep.rx[k] += u64::from(a[k].wrapping_sub(b[k]));
            }
            if kind == 1 {
                if after.cmd_refused != refused_before {
                    rep.configs_refused += 1;
                } else {
                    rep.configs_applied += 1;
                }
            }
        }
        for _ in 0..g.below(3) {
            let out = catch_unwind(AssertUnwindSafe(|| rt.tick(exec).to_vec()));
            let Ok(out) = out else {
                return Err(fail(i, "tick panicked".into()));
            };
            exec = g.u64() as u32;
            rep.ticks += 1;
            check_output(&out, &rt, &lim, &mut rep).map_err(|e| fail(i, e))?;
        }
    }
    Ok(rep)
}

/// The checks of one tick's output (see the module docs).
fn check_output<T: SampleBits>(
    out: &[u8],
    rt: &Runtime<T>,
    lim: &OutputLimits,
    rep: &mut Report,
) -> Result<(), String> {
    let mut dec: Decoder = Decoder::new();
    let mut actuations = 0;
    for m in dec.messages(out) {
        match m {
            Ok(Message::Actuation(a)) => {
                actuations += 1;
                let (t, u) = (i64::from(a.t_psi_dnm), i64::from(a.u_a_cv));
                if t.abs() > lim.torque || u < lim.voltage.0 || u > lim.voltage.1 {
                    return Err(format!(
                        "output out of the actuator limits: T_psi {t} (|.| <= {}), u_a {u} \
                         (in {:?}) in {a:?}",
                        lim.torque, lim.voltage
                    ));
                }
                rep.max_torque = rep.max_torque.max(t.abs());
                rep.max_voltage = rep.max_voltage.max(u.abs());
            }
            Ok(Message::Status(s)) => {
                if s != *rt.counters() {
                    return Err(format!(
                        "Status frame {s:?} is not the device's counters {:?}",
                        rt.counters()
                    ));
                }
                rep.status_frames += 1;
            }
            other => return Err(format!("the tick sent {other:?}")),
        }
    }
    if actuations != 1 {
        return Err(format!("{actuations} actuation frames in one tick"));
    }
    Ok(())
}

/// The command: both sample types, a summary; an error names the seed and the frame of
/// the failed check.
pub fn fuzz(a: Args) -> Result<(), String> {
    outln!(
        "fuzz: {} frames per sample type, seed {} (overflow checks on: {})",
        a.frames,
        a.seed,
        cfg!(debug_assertions)
    );
    let t0 = Instant::now();
    let fx = run::<Fx>(a.frames, a.seed)?;
    print_report(&fx);
    let f = run::<f32>(a.frames, a.seed)?;
    print_report(&f);
    outln!(
        "fuzz: {} frames in {:.1} s: no panic, every output within the actuator limits, \
         every frame accounted",
        2 * a.frames,
        t0.elapsed().as_secs_f64()
    );
    Ok(())
}

fn print_report(r: &Report) {
    let rx = "ok crc cobs version length postcard unexpected".split(' ');
    outln!(
        "  Runtime<{}>: generated {}",
        r.numeric,
        counts(KINDS, &r.generated)
    );
    outln!(
        "    frames seen {}, ticks {}; rx {}; configs applied {} / refused {}; status frames {}; \
         max |T_psi| {} dNm, max |u_a| {} cV",
        r.frames_seen,
        r.ticks,
        counts(rx, &r.rx),
        r.configs_applied,
        r.configs_refused,
        r.status_frames,
        r.max_torque,
        r.max_voltage
    );
}

/// `name count` of `names` and `n` side by side, comma-separated.
fn counts<'a>(names: impl IntoIterator<Item = &'a str>, n: &[u64]) -> String {
    let items: Vec<String> = names
        .into_iter()
        .zip(n)
        .map(|(k, n)| format!("{k} {n}"))
        .collect();
    items.join(", ")
}
