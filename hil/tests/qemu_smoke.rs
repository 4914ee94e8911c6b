//! Processor in the loop: the `wheelset-qemu` firmware under QEMU, lock-step over its
//! UART. Skips when QEMU or the ELF is missing, unless `REQUIRE_QEMU=1` (set by
//! `cargo xtest` when QEMU is installed), in which case that is a failure.
#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

use hil::qemu::{Qemu, QemuConfig};

/// Starts the emulated device, or `None` (skip) when it cannot run here and the run
/// does not require it.
fn start_or_skip(test: &str) -> Option<Qemu> {
    let cfg = QemuConfig::new();
    if let Err(e) = cfg.check() {
        if std::env::var("REQUIRE_QEMU").as_deref() == Ok("1") {
            panic!("{test}: REQUIRE_QEMU=1 but the emulated device cannot run: {e}");
        }
        eprintln!("{test}: SKIPPED: {e}");
        return None;
    }
    match Qemu::start(&cfg) {
        Ok(q) => Some(q),
        Err(e) => panic!("{test}: {e}"),
    }
}

fn cobs_encode(data: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8];
    let mut code_at = 0;
    for &b in data {
        if b == 0 {
            out[code_at] = (out.len() - code_at) as u8;
            code_at = out.len();
            out.push(0);
        } else {
            out.push(b);
            if out.len() - code_at == 0xFF {
                out[code_at] = 0xFF;
                code_at = out.len();
                out.push(0);
            }
        }
    }
    out[code_at] = (out.len() - code_at) as u8;
    out.push(0);
    out
}

fn cobs_decode(frame: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut i = 0;
    while i < frame.len() {
        let code = frame[i] as usize;
        assert!(
            code > 0 && i + code <= frame.len(),
            "bad COBS frame {frame:?}"
        );
        out.extend_from_slice(&frame[i + 1..i + code]);
        i += code;
        if code < 0xFF && i < frame.len() {
            out.push(0);
        }
    }
    out
}

/// One tick's reply of the link-test stub: (tick, last_exec, frames, echoed payload).
type Reply = (u32, u32, u32, Vec<u8>);

/// Runs `ticks` lock-step exchanges: one sensor-sized frame in, one reply out.
fn run_link(q: &mut Qemu, ticks: u32) -> Vec<Reply> {
    let mut trace = Vec::new();
    for k in 0..ticks {
        // Varying payload with zeros in it (COBS must carry them).
        let payload: Vec<u8> = (0..12u32).map(|i| ((k * 7 + i * 13) % 256) as u8).collect();
        q.send(&cobs_encode(&payload)).unwrap();
        let raw = cobs_decode(&q.recv_frame().unwrap());
        assert!(raw.len() >= 12, "tick {k}: short reply {raw:?}");
        let word = |i: usize| u32::from_le_bytes(raw[i..i + 4].try_into().unwrap());
        let reply = (word(0), word(4), word(8), raw[12..].to_vec());
        // The device ticked once per host frame and saw exactly that frame: the
        // frame-clocked lock-step.
        assert_eq!(reply.0, k + 1, "tick count");
        assert_eq!(reply.2, k + 1, "frames received");
        assert_eq!(cobs_decode(&reply.3), payload, "tick {k}: echo");
        if k > 0 {
            assert!(reply.1 > 0, "tick {k}: no execution time measured");
        }
        trace.push(reply);
    }
    trace
}

#[test]
fn lock_step_link_is_closed_and_deterministic() {
    let Some(mut q) = start_or_skip("lock_step_link_is_closed_and_deterministic") else {
        return;
    };
    let first = run_link(&mut q, 300);
    drop(q);
    let mut q = start_or_skip("second run").unwrap();
    let second = run_link(&mut q, 300);
    // Same bytes in, same per-tick trace out, execution times (instruction counts)
    // included.
    assert_eq!(first, second);
    // Execution time is counted in instructions: plausible for a tick, not zero.
    let max = first.iter().map(|r| r.1).max().unwrap();
    assert!((50..100_000).contains(&max), "max exec {max}");
}

#[test]
fn a_missing_elf_is_a_clear_error() {
    let cfg = QemuConfig {
        elf: "/nonexistent/wheelset-qemu.elf".into(),
        ..QemuConfig::new()
    };
    let e = Qemu::start(&cfg).unwrap_err().to_string();
    assert!(
        e.contains("cargo fw") || e.contains("apt-get install qemu-system-arm"),
        "{e}"
    );
}
