//! Pinning each QEMU to one core: round robin over the cores this process may use
//! ([`allowed_cpus`]). `WHEELSET_QEMU_PIN`: `off` pins nothing, `qemu` pins QEMU alone; by
//! default the thread that starts a lock-step QEMU is held on its core too ([`beside`]).

use std::process::{Command, Stdio};

use crate::realtime::os::allowed_cpus;

/// The core the next QEMU is pinned to (QEMUs of parallel tests spread over the cores);
/// `None` with `WHEELSET_QEMU_PIN=off`, without `taskset`, or without the core list.
pub(super) fn next_core() -> Option<usize> {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::OnceLock;
    static CORES: OnceLock<Option<Vec<usize>>> = OnceLock::new();
    static NEXT: AtomicUsize = AtomicUsize::new(0);
    if std::env::var("WHEELSET_QEMU_PIN").is_ok_and(|v| v == "off") {
        return None;
    }
    let cores = CORES
        .get_or_init(|| {
            let taskset = Command::new("taskset")
                .arg("-V")
                .stdout(Stdio::null())
                .stderr(Stdio::null())
                .status()
                .is_ok_and(|s| s.success());
            Some(allowed_cpus()).filter(|c| taskset && !c.is_empty())
        })
        .as_ref()?;
    let k = NEXT.fetch_add(1, Ordering::Relaxed);
    cores.get(k % cores.len()).copied()
}

/// Whether the thread starting a lock-step QEMU is held on QEMU's core (not with
/// `WHEELSET_QEMU_PIN=qemu`): host and device take turns, so each hand-over is a switch on
/// one core, not a cross-core wake-up (an inter-processor interrupt, dear on a VM).
pub(super) fn beside() -> bool {
    std::env::var("WHEELSET_QEMU_PIN").map_or(true, |v| v != "qemu")
}

/// The core of a free-running QEMU: the first this process may use (the real-time host
/// loop takes the last: they never share one); `None` as for [`next_core`].
pub(super) fn free_run_core() -> Option<usize> {
    if std::env::var("WHEELSET_QEMU_PIN").is_ok_and(|v| v == "off") {
        return None;
    }
    allowed_cpus().first().copied()
}

/// The real-time priority a free-running QEMU runs at (`SCHED_RR`, below the host loop's
/// `SCHED_FIFO` 50): round robin, so QEMU's own threads (the main loop that moves the
/// UART's bytes, the vCPU) share its core even while the guest spins.
pub const FREE_RUN_RR: u8 = 40;

/// Whether `chrt -r` may be used here (it exists and this process may set real-time
/// priorities; checked once on `true`); `WHEELSET_QEMU_RT=off` turns it off.
pub(super) fn free_run_rr() -> bool {
    use std::sync::OnceLock;
    static OK: OnceLock<bool> = OnceLock::new();
    if std::env::var("WHEELSET_QEMU_RT").is_ok_and(|v| v == "off") {
        return false;
    }
    *OK.get_or_init(|| {
        Command::new("chrt")
            .args(["-r", &FREE_RUN_RR.to_string(), "true"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status()
            .is_ok_and(|s| s.success())
    })
}
