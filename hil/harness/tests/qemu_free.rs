//! The real firmware free-running under QEMU (`hil run --target qemu-free`):
//! `wheelset-qemu-free.elf` ticks on its own TIMER0 with QEMU's clock following the
//! host's (no `-icount`), and the harness paces it in real time over UART0's TCP chardev,
//! as it paces a board, at the build's 500 Hz (QEMU's UART carries 26-55 kB/s host ->
//! device here, one byte per round trip between its threads: 1 kHz does not hold; README
//! "QEMU free-running").
//!
//! The scenario is `short-nodrive` with passive control (`tests/data/short-nodrive.toml`):
//! at 500 Hz the traction current loop is unstable by its sampling (`cargo sim rates`), so
//! a run with the drive diverges whatever the pacing; without it the run measures the
//! pacing, the frame accounting and the watchdog reset.
//!
//! Judged: the accounting and the numerics; the timing is printed, and judged by hand on
//! a quiet machine (`JUDGE_TIMING=1`): the latency's 99th percentile
//! within two periods (the bar for a board) and the device's misses under 5 %
//! (measured 0.8-1.3 % on a quiet machine: QEMU's UART is slow both ways, and the
//! exchange takes about half the period; a board's bar of 1 % is for the stand-in and a
//! board, `realtime_pty.rs`). The one condition under which the timing is reported and
//! not judged is measured, not assumed: the host's own deadline loop (SCHED_FIFO, its own
//! core) missing 1 % or more, which a disturbed machine does (seen here in a VM whose
//! load average was under 2: 59 and 162 of 1 500); the test prints it with the load.
//! The same holds when the run is refused at its start because the device's frames come
//! slower than its period (a CI run at load 1.8 measured 2 722.5 us of a 2 000 us period:
//! QEMU's threads starved); a device that did not take the rate ticks *faster* (the
//! firmware's default 5 kHz) and still fails the test.
//! Skips when QEMU or the ELF is missing, unless `REQUIRE_QEMU=1`: then it fails.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use hil::run::{run, RunOptions, Target, QEMU_FREE_RATE_HZ};
use wheelset_report::Verdict;
use wheelset_targets::qemu::QemuConfig;

/// One free-running QEMU at a time: two in parallel on a loaded 2-core machine miss the
/// harness's start-up deadlines (measured: "no Status frame within 5s after the Config
/// frame").
static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());

fn available(test: &str) -> bool {
    common::can_run(test, &QemuConfig::free_running())
}

const SCENARIO: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/short-nodrive.toml");

fn loadavg() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .unwrap_or_default()
        .trim()
        .to_string()
}

/// The period the pre-run measured when it refused the run because the device's frames
/// did not come at the run's rate (`wheelset_targets::realtime::prepare`: "the device ticks every
/// X us, not every Y us ..."), in us; `None` for any other error.
fn behind_us(error: &str) -> Option<f64> {
    let rest = error.split("the device ticks every ").nth(1)?;
    rest.split(" us").next()?.trim().parse().ok()
}

/// Runs `opts`; `None` (printed as not judged) when the pre-run refused because the
/// device's frames came slower than its period, a panic on any other error.
fn start(what: &str, opts: &RunOptions) -> Option<hil::run::RunOutcome> {
    let e = match run(opts) {
        Ok(out) => return Some(out),
        Err(e) => e.to_string(),
    };
    let period_us = 1e6 / f64::from(QEMU_FREE_RATE_HZ);
    match behind_us(&e) {
        Some(us) if us > period_us => {
            eprintln!(
                "qemu-free: {what} not judged: refused at its start because the device's \
                 frames came every {us:.1} us, slower than its {period_us:.1} us period \
                 (QEMU's threads starved; load {}): {e}",
                loadavg()
            );
            None
        }
        _ => panic!("{what} starts (load {}): {e}", loadavg()),
    }
}

#[test]
fn the_pre_run_refusal_is_recognised_and_nothing_else_is() {
    let refusal = "qemu-free: the device ticks every 2722.5 us, not every 2000.0 us of the \
                   run's rate: it did not take the rate (--rate-hz) or cannot hold it";
    assert_eq!(behind_us(refusal), Some(2722.5));
    assert_eq!(behind_us("qemu-free: no Status frame within 5s"), None);
    assert_eq!(behind_us("the device ticks every soon us"), None);
}

#[test]
fn the_free_running_firmware_under_qemu_holds_the_loop_in_real_time() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    if !available("hil run --target qemu-free") {
        return;
    }
    let Some(out) = start(
        "the free-running QEMU run",
        &RunOptions {
            target: Target::QemuFree,
            scenario: SCENARIO.into(),
            control: hil::run::Law::Passive,
            ..RunOptions::default()
        },
    ) else {
        return;
    };
    let r = &out.report;
    let tr = r
        .transport
        .as_ref()
        .expect("the real-time transport's report");
    let periods = r.timing.periods.max(1) as f64;
    let host_missed = tr["host"]["missed_deadlines"].as_u64().unwrap();
    let t = r.timing.period_ns as f64;
    eprintln!(
        "qemu-free: {} Hz, periods {}, host missed {host_missed}, device missed {}, latency \
         mean/p99/max {:.0}/{:.0}/{:.0} us ({:.2}/{:.2}/{:.2} T), jitter {:.1} us, pre-run {}, \
         sync {}, realtime {}, load {}",
        1e9 / t,
        r.timing.periods,
        r.timing.missed_ticks,
        r.timing.latency_ns.mean * 1e-3,
        r.timing.latency_ns.p99 * 1e-3,
        r.timing.latency_ns.max * 1e-3,
        r.timing.latency_ns.mean / t,
        r.timing.latency_ns.p99 / t,
        r.timing.latency_ns.max / t,
        r.timing.jitter_max_ns.unwrap_or(0.0) * 1e-3,
        r.frames.pre_run,
        tr["sync"],
        tr["realtime"],
        loadavg()
    );
    eprintln!("qemu-free: QEMU launched {}", tr["device_process"]);
    assert_eq!(r.target, "qemu-free");
    assert_eq!(tr["pace"], "realtime");
    // The device ticked on its own clock at the rate configured over the wire.
    let period = 1e9 / f64::from(QEMU_FREE_RATE_HZ);
    assert_eq!(r.timing.period_ns as f64, period);
    let measured = tr["sync"]["device_period_ns"].as_f64().unwrap();
    assert!((measured - period).abs() < 0.1 * period, "{measured}");
    // It talked before the run: those frames are discarded and counted apart; the
    // run's own frames add up from the firmware's Status frame.
    assert!(r.frames.pre_run > 0, "{:?}", r.frames);
    assert_eq!(r.frames.pre_run, tr["sync"]["pre_run"].as_u64().unwrap());
    assert_eq!(r.frames.source, "device-status");
    assert!(r.frames.adds_up, "{:?}", r.frames);
    assert_eq!(r.frames.up.rejected + r.frames.down.rejected, 0);
    assert_eq!(
        tr["host"]["periods"].as_u64(),
        Some(r.timing.periods),
        "host periods = run periods"
    );
    // Exec is SysTick counts of the emulated 25 MHz clock, not instructions.
    assert_eq!(r.timing.exec_unit, "cycles");
    // The loop holds: passive control on no drive outputs nothing that can diverge, so
    // the numerics pass whenever every period was answered in time.
    assert_eq!(
        r.numerics.verdict,
        Verdict::Pass,
        "{}",
        serde_json::to_string_pretty(&r.numerics).unwrap()
    );
    if !common::judge_timing() {
        eprintln!(
            "qemu-free: timing not judged (JUDGE_TIMING=1 on a quiet machine judges it): \
             host missed {host_missed}, device missed {} of {} periods, latency p99 {:.0} us \
             of a {:.0} us period (load {})",
            r.timing.missed_ticks,
            r.timing.periods,
            r.timing.latency_ns.p99 * 1e-3,
            t * 1e-3,
            loadavg()
        );
        return;
    }
    if host_missed as f64 >= 0.01 * periods {
        eprintln!(
            "qemu-free: timing not judged: the host's own deadline loop missed {host_missed} \
             of {} periods (the machine disturbed it; load {})",
            r.timing.periods,
            loadavg()
        );
        return;
    }
    // The latency within two periods at the 99th percentile (the bar for a board), the device
    // under 5 % missed (the module docs).
    assert!(
        (r.timing.missed_ticks as f64) < 0.05 * periods,
        "device missed {} of {} (load {})",
        r.timing.missed_ticks,
        r.timing.periods,
        loadavg()
    );
    assert!(
        r.timing.latency_ns.p99 < 2.0 * t,
        "latency p99 {:.0} us of a {:.0} us period (load {})",
        r.timing.latency_ns.p99 * 1e-3,
        t * 1e-3,
        loadavg()
    );
}

/// `hil run --target qemu-free --device-fault stall:0.5`: the harness sends InjectStall
/// at 0.5 s (the scenario lasts 3 s), the firmware's watchdog resets the device 2 s later,
/// the host sees its tick counter go back and sends its Config again; the device's
/// closing Status is the new boot's: boot 2, cause watchdog, fault latched.
#[test]
fn a_stall_injected_by_the_harness_resets_the_device_and_the_host_reconfigures_it() {
    let _one = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    if !available("hil run --device-fault stall:0.5") {
        return;
    }
    let Some(out) = start(
        "the stalled run",
        &RunOptions {
            target: Target::QemuFree,
            scenario: SCENARIO.into(),
            device_fault: "stall:0.5".parse().unwrap(),
            control: hil::run::Law::Passive,
            ..RunOptions::default()
        },
    ) else {
        return;
    };
    let r = &out.report;
    // The run goes to its end: nothing diverges without the drive.
    let run_s = out.trajectory.records.last().map_or(0.0, |x| x.t_s);
    assert!(run_s > 2.9, "the run lasted {run_s:.2} s of 3 s");
    eprintln!(
        "qemu-free stall: resets {}, first at {:?} s, status {:?}",
        r.device_resets, r.first_reset_s, r.device_status
    );
    assert_eq!(r.device_resets, 1, "one stall, one reset");
    let at = r.first_reset_s.expect("when");
    // The stall at 0.5 s, the watchdog's 2 s (+20 ms to the reset), the boot: the run's
    // clock is the host's, so later on a loaded machine, never sooner.
    assert!(at > 2.4, "reset seen at {at} s");
    let st = r.device_status.expect("the new boot's Status");
    assert_eq!(
        (st.boot_count, st.reset_cause),
        (2, wheelset_proto::reset_cause::WATCHDOG)
    );
    assert!(st.flags.has(wheelset_proto::Flags::FAULT_LATCHED));
    let text = hil::report::markdown(&out, "hil run --device-fault stall:0.5");
    assert!(text.contains("Device resets seen by the host: 1"), "{text}");
    assert!(
        text.contains("boot 2 (last reset: watchdog), fault latched"),
        "{text}"
    );
}
