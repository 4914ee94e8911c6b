//! The free-running firmware under QEMU soaked in real time (`hil soak --target
//! qemu-free --minutes M`): `hil run --target qemu-free` on a generated track of `M`
//! minutes (curves and straights repeated, no traction drive, the passive law: the
//! free-running build's 500 Hz cannot hold the drive's current loop, see
//! `tests/data/short-nodrive.toml`), then the soak's own checks on the firmware's
//! closing Status: no reset (the host saw none, one boot, no watchdog or fault cause, no
//! latched fault: no missed watchdog feed), every frame accounted for, and the deadline
//! misses counted (the device's late and missed ticks, the host's missed periods).

use std::fmt::Write as _;
use std::path::PathBuf;

use wheelset_proto::{reset_cause, Flags};

use crate::run::{run, Law, RunError, RunOptions, Target, QEMU_FREE_RATE_HZ};

/// The result of a QEMU soak.
#[derive(Debug, Clone, serde::Serialize)]
pub struct QemuSoak {
    /// Real time soaked, s (the scenario's length).
    pub duration_s: f64,
    /// Control periods of the run.
    pub periods: u64,
    /// Periods without an answer echoing their own sample in time (the host's view).
    pub missed_periods: u64,
    /// Device resets the host saw.
    pub device_resets: u32,
    /// The firmware's closing Status, if it arrived.
    pub status: Option<wheelset_proto::Status>,
    /// Frames sent, both directions, and whether they add up (from the Status).
    pub frames_sent: u64,
    /// Every frame accounted for.
    pub frames_add_up: bool,
    /// What broke (empty: clean).
    pub failures: Vec<String>,
}

impl QemuSoak {
    /// Clean: nothing broke.
    #[must_use]
    pub fn clean(&self) -> bool {
        self.failures.is_empty()
    }

    /// The summary `hil soak --target qemu-free` prints.
    #[must_use]
    pub fn summary(&self) -> String {
        let st = self.status.as_ref();
        let mut s = format!(
            "hil soak qemu-free: {:.0} s of real time at {} Hz, {} periods\n\
             \x20 device: ticks {}, boot {}, reset cause {}, resets seen {}, fault latched {}\n\
             \x20 deadlines: device ticks late {}, missed {}; host periods without their answer {} ({:.3} %)\n\
             \x20 frames: {} sent, {}\n",
            self.duration_s,
            QEMU_FREE_RATE_HZ,
            self.periods,
            st.map_or(0, |s| s.ticks),
            st.map_or(0, |s| s.boot_count),
            st.map_or(0, |s| s.reset_cause),
            self.device_resets,
            st.is_some_and(|s| s.flags.has(Flags::FAULT_LATCHED)),
            st.map_or(0, |s| s.ticks_late),
            st.map_or(0, |s| s.ticks_missed),
            self.missed_periods,
            100.0 * self.missed_periods as f64 / self.periods.max(1) as f64,
            self.frames_sent,
            if self.frames_add_up {
                "every one accounted for"
            } else {
                "DO NOT ADD UP"
            }
        );
        if self.failures.is_empty() {
            s.push_str("soak: clean\n");
        }
        for f in &self.failures {
            let _ = writeln!(s, "soak FAILED: {f}");
        }
        s
    }
}

/// The generated track, per minute: 10 s straight, 10 s into R = 2300 m (6 deg of cant),
/// 20 s of curve, 10 s out, 10 s straight; no drive, RK4 at 0.1 ms, records every 10 ms.
#[must_use]
pub fn track_toml(minutes: u32) -> String {
    let mut s = format!(
        "name = \"soak-qemu\"\ndescription = \"{minutes} min of curves and straights, no traction drive\"\n\
         duration_s = {}.0\n\n[sim]\ndt_s = 1e-4\noutput_dt_s = 1e-2\n\n[plant]\naxle = \"flexible\"\ndrive = false\n",
        u64::from(minutes) * 60
    );
    for m in 0..u64::from(minutes) {
        let t0 = m * 60;
        for (dt, curve) in [(0, false), (10, false), (20, true), (40, true), (50, false)] {
            let _ = write!(s, "\n[[track]]\nt_s = {}.0\n", t0 + dt);
            if curve {
                s.push_str("radius_m = 2300.0\ncant_deg = 6.0\n");
            }
        }
    }
    s
}

/// Soaks the free-running QEMU build for `minutes` of real time.
pub fn soak_qemu(minutes: u32) -> Result<QemuSoak, RunError> {
    let path: PathBuf =
        std::env::temp_dir().join(format!("hil-soak-qemu-{}.toml", std::process::id()));
    std::fs::write(&path, track_toml(minutes))
        .map_err(|e| RunError::Input(format!("{}: {e}", path.display())))?;
    let opts = RunOptions {
        target: Target::QemuFree,
        scenario: path.display().to_string(),
        control: Law::Passive,
        ..RunOptions::default()
    };
    let out = run(&opts);
    let _ = std::fs::remove_file(&path);
    let out = out?;
    let r = &out.report;
    let mut failures = Vec::new();
    let status = r.device_status;
    match &status {
        None => failures.push("no closing Status frame from the device".to_string()),
        Some(s) => {
            if s.boot_count != 1
                || matches!(s.reset_cause, reset_cause::WATCHDOG | reset_cause::FAULT)
            {
                failures.push(format!(
                    "the device reset: boot {}, reset cause {} (a watchdog reset is a missed feed)",
                    s.boot_count, s.reset_cause
                ));
            }
            if s.flags.has(Flags::FAULT_LATCHED) {
                failures.push("the device latched a fault".into());
            }
            let alarms = s.hunt_alarms + s.act_alarms + s.drive_alarms;
            if alarms != 0 {
                failures.push(format!("{alarms} stability alarm(s) on a healthy run"));
            }
        }
    }
    if r.device_resets != 0 {
        failures.push(format!("the host saw {} device reset(s)", r.device_resets));
    }
    if !r.frames.adds_up {
        failures.push(format!("frames do not add up: {:?}", r.frames));
    }
    if r.numerics.verdict == wheelset_report::Verdict::Fail {
        failures.push("the closed loop's numerics failed against the reference".into());
    }
    Ok(QemuSoak {
        duration_s: f64::from(minutes) * 60.0,
        periods: r.timing.periods,
        missed_periods: r.timing.missed_ticks,
        device_resets: r.device_resets,
        status,
        frames_sent: r.frames.total.sent,
        frames_add_up: r.frames.adds_up,
        failures,
    })
}
