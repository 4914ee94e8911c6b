//! What Linux grants a real-time loop: `SCHED_FIFO`, `mlockall`, a pinned core and a 1 ns
//! timer slack (the default 50 us would exceed the spin window). What was obtained is
//! reported ([`Obtained`]); without privilege the loop still runs. Also a thread held on
//! one CPU beside a lock-step QEMU ([`hold_on`]). The harness's only `unsafe`: libc calls.
#![allow(unsafe_code)]

use serde::{Deserialize, Serialize};

/// What a real-time loop asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Want {
    /// `SCHED_FIFO` at this priority (1-99); `None`: the normal scheduler.
    pub fifo_priority: Option<i32>,
    /// Lock every current and future page in memory (no page fault in the loop).
    pub lock_memory: bool,
    /// Pin the calling thread to this CPU.
    pub cpu: Option<usize>,
    /// Timer slack of the calling thread, ns (`None`: the kernel's default, 50 us).
    pub timer_slack_ns: Option<u64>,
}

impl Want {
    /// Everything: `SCHED_FIFO` priority 50, locked memory, and the given core.
    #[must_use]
    pub fn all(cpu: Option<usize>) -> Self {
        Self {
            fifo_priority: Some(50),
            lock_memory: true,
            cpu,
            timer_slack_ns: Some(1),
        }
    }

    /// Nothing (the normal scheduler, pageable memory, any core).
    #[must_use]
    pub fn none() -> Self {
        Self::default()
    }
}

/// What was obtained (the `realtime` section of a run's JSON).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize, Default)]
pub struct Obtained {
    /// `SCHED_FIFO` priority obtained, if any.
    pub sched_fifo: Option<i32>,
    /// Whether `mlockall(MCL_CURRENT | MCL_FUTURE)` succeeded.
    pub mlockall: bool,
    /// The CPU the thread is pinned to, if any.
    pub pinned_cpu: Option<usize>,
    /// The timer slack set, ns, if any.
    pub timer_slack_ns: Option<u64>,
    /// Why something asked for was not obtained.
    pub refused: Vec<String>,
}

impl std::fmt::Display for Obtained {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let mut got = Vec::new();
        if let Some(p) = self.sched_fifo {
            got.push(format!("SCHED_FIFO {p}"));
        }
        if self.mlockall {
            got.push("memory locked".to_string());
        }
        if let Some(c) = self.pinned_cpu {
            got.push(format!("pinned to CPU {c}"));
        }
        if let Some(s) = self.timer_slack_ns {
            got.push(format!("timer slack {s} ns"));
        }
        if got.is_empty() {
            f.write_str("nothing")?;
        } else {
            f.write_str(&got.join(", "))?;
        }
        if !self.refused.is_empty() {
            write!(f, "; refused: {}", self.refused.join("; "))?;
        }
        Ok(())
    }
}

/// Clears `O_NONBLOCK` on an open file (a FIFO end opened without waiting, then used
/// blocking).
pub fn set_blocking(f: &std::fs::File) -> std::io::Result<()> {
    use std::os::fd::AsRawFd;
    let fd = f.as_raw_fd();
    // SAFETY: `fcntl` on a descriptor `f` owns; no memory is passed.
    let flags = unsafe { libc::fcntl(fd, libc::F_GETFL) };
    // SAFETY: as above.
    if flags < 0 || unsafe { libc::fcntl(fd, libc::F_SETFL, flags & !libc::O_NONBLOCK) } < 0 {
        return Err(std::io::Error::last_os_error());
    }
    Ok(())
}

/// The CPUs this process may run on (empty if unknown).
#[must_use]
pub fn allowed_cpus() -> Vec<usize> {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: `set` is a plain bit set of the size passed; the kernel writes it.
        let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
        // SAFETY: pid 0 = the calling thread; the size and pointer describe `set`.
        let r = unsafe {
            libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &raw mut set)
        };
        if r != 0 {
            return Vec::new();
        }
        (0..libc::CPU_SETSIZE as usize)
            // SAFETY: `cpu` < CPU_SETSIZE, within `set`.
            .filter(|&cpu| unsafe { libc::CPU_ISSET(cpu, &set) })
            .collect()
    }
    #[cfg(not(target_os = "linux"))]
    Vec::new()
}

/// The calling thread kept on one CPU ([`hold_on`]); dropped by any thread, it gets its CPUs back.
#[derive(Debug)]
pub struct HeldOn {
    #[cfg(target_os = "linux")]
    tid: libc::pid_t,
    before: Vec<usize>,
}

/// Keeps the calling thread on `cpu` until the value returned is dropped; `None` if refused.
#[must_use]
pub fn hold_on(cpu: usize) -> Option<HeldOn> {
    #[cfg(target_os = "linux")]
    {
        let before = Some(allowed_cpus()).filter(|c| !c.is_empty())?;
        // SAFETY: no arguments; returns the calling thread's id.
        let tid = unsafe { libc::gettid() };
        set_cpus(0, &[cpu]).ok()?;
        Some(HeldOn { tid, before })
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = cpu;
        None
    }
}

impl Drop for HeldOn {
    fn drop(&mut self) {
        #[cfg(target_os = "linux")]
        let _ = set_cpus(self.tid, &self.before);
    }
}

/// Sets the CPUs thread `tid` (0: the calling one) may run on.
#[cfg(target_os = "linux")]
fn set_cpus(tid: libc::pid_t, cpus: &[usize]) -> Result<(), String> {
    // SAFETY: a zeroed bit set, then bits below CPU_SETSIZE set in it.
    let mut set: libc::cpu_set_t = unsafe { std::mem::zeroed() };
    for &cpu in cpus {
        if cpu >= libc::CPU_SETSIZE as usize {
            return Err(format!("cpu {cpu}: out of range"));
        }
        // SAFETY: `cpu` < CPU_SETSIZE (checked above).
        unsafe { libc::CPU_SET(cpu, &mut set) };
    }
    // SAFETY: `tid` is a thread of this process or 0; size and pointer describe `set`.
    let r = unsafe {
        libc::sched_setaffinity(tid, std::mem::size_of::<libc::cpu_set_t>(), &raw const set)
    };
    if r == 0 {
        Ok(())
    } else {
        let list: Vec<String> = cpus.iter().map(ToString::to_string).collect();
        Err(format!(
            "pin to cpu {}: {}",
            list.join(","),
            std::io::Error::last_os_error()
        ))
    }
}

/// Asks for `want` on the calling thread; never fails (refusals are reported).
#[must_use]
pub fn obtain(want: Want) -> Obtained {
    let mut got = Obtained::default();
    #[cfg(target_os = "linux")]
    {
        let err = || std::io::Error::last_os_error().to_string();
        if let Some(cpu) = want.cpu {
            match set_cpus(0, &[cpu]) {
                Ok(()) => got.pinned_cpu = Some(cpu),
                Err(e) => got.refused.push(e),
            }
        }
        if let Some(ns) = want.timer_slack_ns {
            // SAFETY: PR_SET_TIMERSLACK takes the slack, ns (0: the default); the rest 0.
            let r = unsafe {
                libc::prctl(
                    libc::PR_SET_TIMERSLACK,
                    libc::c_ulong::try_from(ns.max(1)).unwrap_or(1),
                    0 as libc::c_ulong,
                    0 as libc::c_ulong,
                    0 as libc::c_ulong,
                )
            };
            if r == 0 {
                got.timer_slack_ns = Some(ns.max(1));
            } else {
                got.refused.push(format!("timer slack {ns} ns: {}", err()));
            }
        }
        if want.lock_memory {
            // SAFETY: no pointer arguments; flags are libc's constants.
            let r = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
            if r == 0 {
                got.mlockall = true;
            } else {
                got.refused.push(format!("mlockall: {}", err()));
            }
        }
        if let Some(prio) = want.fifo_priority {
            let param = libc::sched_param {
                sched_priority: prio,
            };
            // SAFETY: pid 0 = the calling thread; `param` outlives the call.
            let r = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &raw const param) };
            if r == 0 {
                got.sched_fifo = Some(prio);
            } else {
                got.refused
                    .push(format!("SCHED_FIFO priority {prio}: {}", err()));
            }
        }
    }
    #[cfg(not(target_os = "linux"))]
    {
        if want != Want::none() {
            got.refused
                .push("real-time scheduling: only on Linux".to_string());
        }
    }
    got
}

/// Back to `SCHED_OTHER` and pageable memory on the calling thread; the pinning stays.
pub fn release() {
    #[cfg(target_os = "linux")]
    {
        let param = libc::sched_param { sched_priority: 0 };
        // SAFETY: pid 0 = the calling thread; `param` outlives the call.
        let _ = unsafe { libc::sched_setscheduler(0, libc::SCHED_OTHER, &raw const param) };
        // SAFETY: no arguments.
        let _ = unsafe { libc::munlockall() };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn asking_for_nothing_obtains_nothing_and_refuses_nothing() {
        assert_eq!(obtain(Want::none()), Obtained::default());
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_held_thread_runs_on_its_cpu_and_gets_its_cpus_back_when_released() {
        std::thread::spawn(|| {
            let before = allowed_cpus();
            let cpu = *before.last().expect("some CPU");
            let held = hold_on(cpu).expect("an allowed CPU is granted");
            assert_eq!(allowed_cpus(), vec![cpu]);
            drop(held);
            assert_eq!(allowed_cpus(), before);
            assert!(hold_on(libc::CPU_SETSIZE as usize).is_none());
            assert_eq!(allowed_cpus(), before);
        })
        .join()
        .expect("the test thread");
    }

    #[test]
    fn pinning_to_an_allowed_cpu_is_obtained_or_refused_with_a_reason() {
        let cpus = allowed_cpus();
        let Some(&cpu) = cpus.last() else { return };
        // In a thread of its own: the pin stays with that thread.
        let got = std::thread::spawn(move || {
            obtain(Want {
                cpu: Some(cpu),
                ..Want::none()
            })
        })
        .join()
        .unwrap_or_default();
        assert!(
            got.pinned_cpu == Some(cpu) || !got.refused.is_empty(),
            "{got:?}"
        );
        let bad = obtain(Want {
            cpu: Some(1 << 20),
            ..Want::none()
        });
        assert_eq!(bad.pinned_cpu, None);
        assert_eq!(bad.refused.len(), 1);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn the_timer_slack_is_set_and_read_back_by_the_kernel() {
        let (got, read_back) = std::thread::spawn(|| {
            let got = obtain(Want {
                timer_slack_ns: Some(1),
                ..Want::none()
            });
            // SAFETY: PR_GET_TIMERSLACK takes no argument and returns the slack, ns.
            let ns = unsafe { libc::prctl(libc::PR_GET_TIMERSLACK, 0, 0, 0, 0) };
            (got, ns)
        })
        .join()
        .unwrap_or_default();
        assert_eq!(got.timer_slack_ns, Some(1), "{got:?}");
        assert_eq!(read_back, 1);
    }
}
