//! The fixed-point firmware on a core without an FPU: `target/fw/wheelset-qemu-m3.elf`
//! (`cargo fw`, `thumbv7m-none-eabi`) on QEMU's `mps2-an385` (Cortex-M3) answers the
//! golden vectors bit for bit like the host's runtime and like the Cortex-M4F build on
//! `mps2-an386`. Skips when QEMU or the ELFs are missing, unless `REQUIRE_QEMU=1` (set by
//! `cargo xtest` after building the firmware): then it fails.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::panic)]

mod common;

use std::time::Duration;

use hil::golden::{compare, run_host, run_target, vectors};
use hil::run::DEFAULT_CPU_HZ;
use wheelset_runtime::RuntimeConfig;
use wheelset_targets::qemu::cmd::{qemu_args, SerialTo};
use wheelset_targets::qemu::target::QemuTarget;
use wheelset_targets::qemu::{Channel, Machine, QemuConfig};

fn available(test: &str, m: Machine) -> bool {
    common::can_run(&format!("{test} ({m})"), &QemuConfig::on(m))
}

/// The host's runtime and the Cortex-M4F build agree bit for bit on the full vectors
/// (`tests/qemu_run.rs`); here the Cortex-M3 build against both on the first
/// [`TICKS`] ticks of each vector (every vector's first event is within them).
const TICKS: usize = 500;

#[test]
fn the_cortex_m3_build_is_bit_identical_with_the_host_and_the_cortex_m4_build() {
    let test = "the_cortex_m3_build_is_bit_identical_with_the_host_and_the_cortex_m4_build";
    if !available(test, Machine::An385) || !available(test, Machine::An386) {
        return;
    }
    let period_ns = 200_000;
    let mut vs = vectors().unwrap();
    assert!(vs.len() >= 3);
    for v in &mut vs {
        v.samples.truncate(TICKS);
    }
    for (k, v) in vs.iter().enumerate() {
        let host = run_host(v, RuntimeConfig::default()).unwrap();
        let mut t = QemuTarget::start_with(
            Machine::An385,
            Channel::Uart,
            4_000_000,
            DEFAULT_CPU_HZ,
            Duration::from_secs(10),
        )
        .unwrap();
        let m3 = run_target(v, &mut t, period_ns).unwrap();
        let c = compare(v, &host, &m3);
        assert!(
            c.identical && c.ticks == v.samples.len(),
            "{}: Cortex-M3 vs host: {} mismatches, first {:?}",
            v.name,
            c.mismatches,
            c.first_mismatch
        );
        // One vector also directly against the Cortex-M4F build.
        if k == 0 {
            let mut t4 = QemuTarget::start_with(
                Machine::An386,
                Channel::Uart,
                4_000_000,
                DEFAULT_CPU_HZ,
                Duration::from_secs(10),
            )
            .unwrap();
            let m4 = run_target(v, &mut t4, period_ns).unwrap();
            assert_eq!(m3, m4, "{}: Cortex-M3 vs Cortex-M4", v.name);
        }
    }
}

#[test]
fn the_machine_picks_its_cpu_and_elf() {
    let m3 = QemuConfig::on(Machine::An385);
    assert!(m3.elf.ends_with("wheelset-qemu-m3.elf"), "{:?}", m3.elf);
    let (m, elf) = (Machine::An385, m3.elf.to_string_lossy());
    let args = qemu_args(m.name(), m.cpu(), &elf, SerialTo::Tcp(1));
    let after = |flag: &str| {
        args.iter()
            .position(|a| a == flag)
            .and_then(|i| args.get(i + 1))
            .cloned()
    };
    assert_eq!(after("-machine").as_deref(), Some("mps2-an385"));
    assert_eq!(after("-cpu").as_deref(), Some("cortex-m3"));
}
