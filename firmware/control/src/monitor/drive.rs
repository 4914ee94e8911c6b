//! The drive check: a current-loop limit cycle seen in the ripple of the current error
//! `e = i_ref - i_a` (pu); the design and defaults: `docs/monitor.md`, "The drive check".
//!
//! ```text
//! r[n] = e[n] - e[n-1]
//! q[n] = q[n-1] + k_d (r[n]^2 - q[n-1])        exponential mean square, k_d = 1 - exp(-1/N)
//! run  = q > thr^2 ? run + 1 : 0
//! DRIVE_OSC rises when run >= P, falls when q < (release thr)^2
//! ```
//!
//! `N` and `P` count steps, so no coefficient changes with the rates.

use super::{exp_small, range, Monitor, MonitorParams, MonitorState};
use crate::config::ConfigError;
use crate::sample::Sample;

/// The drive check's coefficient and levels in f64 (pu^2), validated.
pub(super) struct DriveF64 {
    /// `k_d = 1 - exp(-1/N)`.
    pub k: f64,
    /// `thr^2`, pu^2.
    pub on: f64,
    /// `(release thr)^2`, pu^2.
    pub off: f64,
}

/// Validates the drive check's fields of `p` (errors name the field); its coefficient and levels.
pub(super) fn check_params(p: &MonitorParams) -> Result<DriveF64, ConfigError> {
    range(
        "monitor.current_scale_a",
        p.current_scale_a,
        p.current_scale_a.is_finite() && p.current_scale_a > 0.0,
        "the current scale must be a positive number of amperes",
    )?;
    range(
        "monitor.drive_window_steps",
        f64::from(p.drive_window_steps),
        (4..=4096).contains(&p.drive_window_steps),
        "the drive check's window must be 4 .. 4096 traction steps",
    )?;
    let thr = p.drive_ripple_a / p.current_scale_a;
    range(
        "monitor.drive_ripple_a",
        p.drive_ripple_a,
        thr.is_finite() && thr > 1e-3 && thr < 2.0,
        "the drive check's threshold must be between 1e-3 and 2 of the current scale",
    )?;
    range(
        "monitor.drive_persist_steps",
        f64::from(p.drive_persist_steps),
        p.drive_persist_steps >= 1,
        "at least one traction step",
    )?;
    let rel = p.release * p.release;
    Ok(DriveF64 {
        k: 1.0 - exp_small(-1.0 / f64::from(p.drive_window_steps)),
        on: thr * thr,
        off: thr * thr * rel,
    })
}

impl<T: Sample> Monitor<T> {
    /// One traction step of the drive check on `e` (pu): whether the alarm rose.
    #[inline(always)]
    pub fn drive_step(&self, s: &mut MonitorState<T>, e: T) -> bool {
        let r = e.sat_sub(s.drive_err);
        s.drive_err = e;
        let sq = r.square();
        s.drive_ms = s.drive_ms.sat_add(
            sq.sat_sub(s.drive_ms)
                .mul_c_acc(self.drive_k, &mut s.drive_res),
        );
        if s.ev.drive {
            s.ev.drive = s.drive_ms >= self.drive_off;
            return false;
        }
        if s.drive_ms > self.drive_on {
            s.drive_run = s.drive_run.saturating_add(1);
            if s.drive_run >= self.drive_persist && self.drive_persist > 0 {
                s.ev.drive = true;
                s.drive_run = 0;
                return true;
            }
        } else {
            s.drive_run = 0;
        }
        false
    }
}
