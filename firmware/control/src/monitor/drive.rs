//! The drive check: a current-loop limit cycle, or any sustained oscillation of the
//! traction drive, seen in the current error's ripple at the traction rate.
//!
//! # The signal
//!
//! The current error of each traction step, `e[n] = i_ref[n] - i_a[n]` (pu of
//! `scales.current` = 1000 A; positive when the current is below its reference), as the
//! PI takes it ([`crate::Controller::current_error`]: the reference after the wheel-slip
//! protection's cap, the clamped measurement). Its **ripple** is the first difference
//! `r[n] = e[n] - e[n-1]`.
//!
//! # Mean square, persistence, alarm
//!
//! ```text
//! r[n] = e[n] - e[n-1]
//! q[n] = q[n-1] + k_d (r[n]^2 - q[n-1])        exponential mean square, k_d = 1 - exp(-1/N)
//! run  = q > thr^2 ? run + 1 : 0
//! DRIVE_OSC rises when run >= P, falls when q < (release thr)^2
//! ```
//!
//! **Why the ripple.** A limit cycle of the sampled current loop has the frequency of its
//! unstable pair, `theta/(2 pi)` of the traction rate with `z = rho e^{+-j theta}`: about a
//! fifth of the rate and above (the inductance faults at 5 kHz: `theta` near 67 deg, 0.93
//! kHz; the 5 kHz gains at 1 kHz: near 200 Hz), where the first difference passes
//! `2 sin(theta/2)` of the error's amplitude (1.1 at 67 deg, 0.6 at 36 deg). What the
//! loop does on purpose, the first difference rejects: a steady error (the voltage at
//! its limit, a cap by the protection), the tracking error of a ramped reference (a few
//! amperes: `L_a` times the ramp's slope over `Kp`), the back-EMF's slow swings with the
//! gear and axle modes (20-40 Hz, passed at 2-5 %). A single step of the reference (the
//! protection's cut, the start of the safe state's ramp) is one large ripple sample and
//! the loop's damped answer, a few steps long; the mean square's window spreads it over
//! `N` steps and the persistence asks for `P` steps above the level.
//!
//! **Why not the saturation duty.** A drive held at its voltage limit (a demand above
//! what the back-EMF leaves, a stuck measurement) saturates on every step without
//! oscillating; a limit cycle large enough to saturate the voltage swings the measured
//! current from one clamp to the other (`limits.current`, 2 kA), a ripple of kA that
//! this check sees anyway. The duty adds a state and a second alarm rule for nothing the
//! ripple misses.
//!
//! **The window in steps, not seconds.** The limit cycle's period is a few traction steps
//! at every rate (its frequency scales with the rate), so `N` and `P` count steps: the
//! same statistics at every rate, with no coefficient to recompute when the rates change
//! (the device does no float maths).
//!
//! # Thresholds (defaults, [`super::MonitorParams::default`])
//!
//! - `N` = 64 steps: 12.8 ms at 5 kHz. A limit cycle of period 5 steps fills the window
//!   with 13 periods; a single ripple sample `r0` adds `k_d r0^2` = `r0^2/64.5` to `q`
//!   (an RMS of `r0/8`).
//! - `thr` = 300 A (0.3 pu, `q` on at 0.09 pu^2): a limit cycle whose measured current
//!   swings between the clamps has a ripple RMS above 1 kA; the healthy loop's largest
//!   ripple comes from the protection's cut, a burst (below) the persistence rides out
//!   (`hil/harness/tests/drive.rs`: no drive alarm on the normal scenarios).
//! - `P` = 64 steps (= `N`): a burst of ripple energy `E = sum r^2` over a few steps (a
//!   step of the reference and the loop's answer) raises `q` by `k_d E`, which then
//!   decays as `e^{-n/N}`; it stays above `thr^2` for `P` steps only if
//!   `k_d E > e^{P/N} thr^2`, i.e. `E > 175 thr^2`: a burst whose root-sum-square
//!   ripple is below 13 `thr` (4 kA) cannot raise the alarm, a sustained one of `thr`
//!   does within `P` steps of the mean square's rise.
//! - `release` = [`super::MonitorParams::release`] (0.7): the alarm falls once the ripple's
//!   RMS is below 210 A.
//!
//! # Fixed point
//!
//! `e` and `r` are Q4.28 (pu), `q` is in pu^2; `k_d` (1/64.5) is Q1.31. The square
//! saturates at 8 pu^2 (a ripple of 2.83 kA), far above the alarm's level: the alarm is
//! then due anyway. The mean square's increment uses the integrator's error feedback
//! ([`Sample::mul_c_acc`]): no dead band. Cost: one subtract, one square, one
//! multiply-accumulate and two compares per traction step (`cargo xtask fw-bench`).

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

/// Validates the drive check's fields of `p` (errors name the field) and computes its
/// coefficient and levels.
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
    /// One traction step of the drive check on the current error `e` (pu,
    /// [`crate::Controller::current_error`]), called once per traction step the core
    /// ran. Returns whether the alarm rose on this step; the alarm's state is
    /// `s.ev.drive`. Never fails, never panics; a monitor that is off (rate 0) never
    /// raises it.
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
