//! Wheel-slip protection (WSP) of the traction loop, generic over the sample type
//! (`f64` reference, `f32`, fixed point [`crate::Fx`]) like the lead and the PI: one
//! implementation, configuration split from state, no division, no panic.
//!
//! # Signals
//! Everything is in motor-speed per unit (`scales.speed`), so the slip needs no unit
//! conversion on the tick:
//!
//! ```text
//! w      = theta_m'                         motor speed (Sensor), pu
//! w_ref  = n v_ref / r0                     vehicle reference speed seen at the motor, pu
//! slip   = w - w_ref                        = (n/r0) (omega_m r0/n - v_ref): the wheel's
//!                                           slip velocity omega_m r0/n - v_ref, m/s, times n/r0
//! dw     = w[k] - w[k-1]                    wheel acceleration over one traction step
//! ```
//!
//! `v_ref` is the vehicle speed from unpowered axles or radar (the Sensor frame's
//! `v_ref_mm_s`; the simulation sends the plant's `v`). Positive slip = the wheel turns
//! faster than the vehicle runs (motoring). The protection acts in traction only
//! (`i_ref > 0`); slide protection in braking is not part of it.
//!
//! # Law (per traction step, after the reference ramp)
//!
//! ```text
//! detect   = slip > slip_on  or  (slip > slip_hold and dw > a_on T n/r0)
//! idle:    detect and i_ref > 0  ->  active, cap = cut i_ref (instantaneous), one event
//! active (working band slip_target .. slip_hold):
//!          slip > slip_hold      ->  cap -= 2 r T      (cut at twice the reference slew)
//!          slip < slip_target    ->  cap += r_up T     (re-apply: re-adhesion)
//!          calm (no slip > slip_hold) for probe_after  ->  probing
//!            (timer += r_up T each calm step; probing once timer >= r_up probe_after - r_up T/2)
//! probing: cap += r_up T whatever the slip; detect -> cap = cut cap, back to the band
//! release: 2 cap >= 2 i_ref - r_up T (the rail carries the demand again; half a
//!          re-apply step below the reference, so the sum's rounding cannot move it)
//! output:  min(i_ref, cap) while active, i_ref otherwise
//! ```
//!
//! The slip thresholds are compiled half a motor-speed code above their values, and the
//! two sums (probe timer, release) decide half a re-apply step below their levels
//! ("Exact decisions" below).
//!
//! `r` is the reference slew limit (`limits.current_ref_rate`, per step `iref_step`),
//! `r_up` the re-apply rate. Every per-step quantity is the schedule's `iref_step` times a
//! rate-independent coefficient (`a_on n/r0 / r`, `r_up / r`; the probe timer sums the
//! re-apply steps up to `r_up probe_after`), so a new schedule
//! ([`crate::Compiled::with_schedule`]) keeps the protection's rates in SI with no
//! discretisation on the device.
//!
//! # Exact decisions
//! Every decision compares a quantity built from the wire's integers with a level, and on
//! the same Sensor codes the fixed-point, f32 and f64 builds must take it on the same
//! tick (`hil run --scenario low-adhesion` judges the Q4.28 device against the f64 core).
//! Where the exact quantity can land *on* the level, each build's rounding decides, so
//! every level is moved off the lattice the quantity lives on:
//!
//! - The slip `w - w_ref` is `c_w a - c_v b`, `c_w` the motor-speed code (`a` = 1 mrad/s
//!   in pu), `c_v` the reference-speed code (`b` = 1 mm/s at the rim = `100/9` mrad/s at
//!   the motor with `n/r0 = 5/0.45`). So the slip is a multiple of `a/9`, and a threshold
//!   in whole mm/s is a multiple of `b`: `c_w a = (c_v + 60) b` whenever 9 divides
//!   `c_v + 60`, and the slip then *equals* `slip_hold`. On the codes of `low-adhesion`
//!   that happened at 7.585 s (`slip_hold`: f32 cut, Q4.28 and f64 did not) and at
//!   7.714 s (`slip_target`: f64 re-applied, Q4.28 did not). Half a code above, `theta +
//!   a/2`, no slip equals a threshold (`18 c_w = 200 (c_v + N) + 9` has no integer
//!   solution: even against odd), the nearest lies `a/18` = 5.6e-8 pu away: 7 times the
//!   Q4.28 error of a slip (two code x scale products, each within 2^-28 of exact, 7.5e-9
//!   pu together) and far beyond f64's. An f32 slip near 0.9 pu carries up to 6e-8 pu of
//!   rounding, as much as the margin: the f32 build is not guaranteed to agree. Moving a
//!   threshold by 0.045 mm/s at the rim changes nothing a rail notices.
//! - The acceleration `dw` is a difference of speed codes, `k a` for an integer `k`,
//!   against `a_on T n/r0` = 6.67 `a` at 5 kHz: a third of a code from the nearest `k`.
//! - The probe timer and the cap sum whole re-apply steps; with the default parameters
//!   their levels are whole numbers of steps (4 000 for the timer; the reference
//!   579.6 A = 1 932 x 0.3 A on `low-adhesion`), so both decide half a step below.
//!
//! Exact decisions make the builds agree on the *same* codes
//! (`sim-host/tests/adhesion.rs`, `every_build_takes_the_same_decisions_on_the_same_codes`).
//! A device in a closed loop is another matter: its plant run and the reference's part
//! by an LSB (on `low-adhesion` the first differing speed code is at 1.17 s), and a
//! decision then falls a tick apart where the codes differ (the slip crossing `slip_on`
//! at 14.0520 s in Q4.28 and 14.0522 s in f64, the speed codes 14 LSBs apart). The
//! harness's numerics judge such a cut
//! within their time tolerance on the reference recorded at the control period
//! (`hil::numerics`, "The tube at the control period").
//!
//! # The slip bound on `low-adhesion`
//! The worst disturbance of the scenario is its first: at 6.0 s the rail drops from dry
//! to `low` under the full demand `T_d` = 12.4 kN m at the wheel (`mu_d` = 0.250). The
//! wheel slip velocity (the plant's `slip_mps`, the mean wheel) stays below
//!
//! ```text
//! s_peak <= s0 + r0 dT / (J_w w_g) + r0 dT t_total / J            = 0.479 m/s
//!   s0       the dry rail's slip at mu_d (Polach, pure longitudinal)  0.165 m/s
//!   dT       T_d (1 - mu_low(s0) / mu_d): the torque the low rail     9.6 kN m
//!            no longer carries (its characteristic rises from s0 to
//!            its peak at 0.60 m/s, so it carries at least mu_low(s0) = 0.056)
//!   J_w, J   2 I_w = 70 and J_w + n^2 I_m = 345 kg m^2 at the wheel
//!   w_g      sqrt(k_gear (1/J_w + 1/(n^2 I_m))) = 279 rad/s: wheelset against motor
//!   t_total  t_detect + t_current = 2.9 + 4.4 ms: the protection's response
//! ```
//!
//! Two inertias, the wheelset and the motor (through the gear spring), and the adhesion
//! torque falling by `dT` at `t = 0` while the motor torque stays `<= T_d`: the wheel's
//! speed rises by `dT/J [t + (n^2 I_m / (J_w w_g)) sin(w_g t)]`, the rigid part and the
//! torsion of the gear. The motor's torque acts on the wheel through the impulse
//! response `(1 - cos w_g t)/J >= 0`, so a smaller motor torque never raises the wheel's
//! speed; once it is below the low rail's torque (from `t_total` on) it takes back at
//! least `dT/J [(t - t_total) - sin(w_g (t - t_total))/w_g]`. Together the rise is at
//! most `dT/J [t_total + 1/w_g + n^2 I_m/(J_w w_g)] = dT [t_total/J + 1/(J_w w_g)]`: the
//! torsion term (0.221 m/s at the rim) and the rigid one over the response (0.092 m/s).
//! The response, from the protection's thresholds and rates:
//!
//! - `t_detect` = 2.9 ms: the slip is above `slip_hold` already (`s0`), so the
//!   acceleration test detects once the motor's rim acceleration `r0 dT/J (1 - cos w_g
//!   t)` reaches `a_on` = 3 m/s^2 (2.5 ms), plus one traction step to measure it and one
//!   period until the cut acts (0.2 ms each at 5 kHz);
//! - `t_current` = 4.4 ms: the cut to `cut_fraction` x 580 A at once, then `2 r` =
//!   40 kA/s down to the current whose torque the low rail carries (`mu_low(s0)/mu_d` x
//!   580 A = 130 A), plus the current loop's lag `L_a / K_p` = 0.4 ms.
//!
//! Measured: 0.425 m/s at 6.007 s (`sim-host run --scenario low-adhesion --loop core
//! --wsp on`; test `the_core_with_protection_holds_the_wheel_and_without_it_runs_away`
//! in `sim-host/tests/adhesion.rs` computes the bound from the parameters and asserts
//! the measured peak below it). `s0` omits the curve's lateral creepage, which takes a
//! little of the adhesion (0.166 m/s measured before the drop), well inside the margin.
//! The later disturbances take less torque away (dry to wet at 13 s: the wet rail is the same
//! shape as `low` with `mu0` 0.30 instead of 0.08; the probes re-apply at 1 500 A/s from the band
//! instead of a step), measured peaks 0.282 m/s on wet, 0.163-0.166 m/s on dry. The bound
//! lies below every characteristic's peak slip (0.60 m/s on `low`, 0.9-1.2 on dry and
//! wet), so a protected wheel never works on the falling side, where it would spin up.
//!
//! # Why the working band is so low (0.03 .. 0.06 m/s)
//!
//! Polach's characteristics at 83.3 m/s peak at 0.6 (low), 0.9 (dry), 1.2 m/s (wet) of
//! slip (`sim-host adhesion`), but the paper's lead yaw damper does not stay stable that
//! close to the peak: the longitudinal creep slope there (the tangent of the
//! characteristic, which damps the yaw) falls far below the ~1.5 MN the lead loop needs
//! (crate docs' rate analysis; the paper's Fig. 4), and the yaw actuator's 20 kN m then
//! outweighs the adhesion-limited yaw moment `2 Lg mu Q` (5 kN m on the `low` rail).
//! With the continuous reference controllers at a constant demand the yaw loop diverges
//! above about 0.7 of the peak on wet rail and 0.8 on dry, and below 0.5 on `low`
//! (`sim-host run` on the `low-adhesion` track with the demand set to that fraction). So
//! the protection detects a slip early (`slip_on` = 0.25 m/s is above the 0.17 m/s a dry
//! rail needs for the full demand, so dry running is not touched), cuts at once, and
//! then works low on the characteristic where the creep slope still damps the yaw. The
//! price is adhesion utilisation (README, `sim-host run --scenario low-adhesion`).
//!
//! ```
//! use wheelset_control::{Config, F64Controller, Inputs};
//! let mut cfg = Config::default();
//! cfg.wsp.enabled = true;
//! let mut c = F64Controller::try_new(&cfg).unwrap();
//! let s = cfg.scales;
//! // 83.3 m/s: motor 925.6 rad/s; the wheel slips 2 m/s (motor 22 rad/s faster).
//! c.set_v_ref(83.3 * 5.0 / 0.45 / s.speed);
//! let inp = Inputs::<f64>::from_si(&s, 0.0, 0.0, 925.6 + 22.2, 12_400.0);
//! for _ in 0..100 {
//!     c.tick(&inp);
//! }
//! assert!(c.wheel_slip() && c.counters().wsp_events == 1);
//! ```

use crate::compiled::ScaleBits;
use crate::config::{ConfigError, FullScales, Limits, Motor};
use crate::lead::LeadParams;
use crate::sample::{Sample, SampleBits};

/// Wheel-slip protection parameters (SI). Validated by [`Wsp::try_new`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WspParams {
    /// On at start (default **off**: the device enables it with a `Config`, which the
    /// host sends with `wsp = true` unless `--wsp off`; a Sensor frame without a valid
    /// `v_ref` would otherwise read as a slipping wheel).
    pub enabled: bool,
    /// Slip velocity that detects a slip and starts the protection, m/s (0.25).
    pub slip_on_mps: f64,
    /// Slip velocity above which the acceleration test detects, m/s (0.06;
    /// `slip_accel < slip_on`).
    pub slip_accel_mps: f64,
    /// Wheel acceleration (at the rim) that detects a slip once the slip is above
    /// `slip_accel`, m/s^2 (3.0).
    pub accel_on_mps2: f64,
    /// Fraction of the reference kept at the moment a slip is detected (0.3): the
    /// first, instantaneous cut, where the slip regulator starts.
    pub cut_fraction: f64,
    /// Slip set point at zero cap, m/s (0.1): `s_sp = slip_sp + slip_sp_per_a cap`
    /// (`slip_sp < slip_on`).
    pub slip_sp_mps: f64,
    /// Slip set point per ampere of cap, m/s per A (8e-4: 0.56 m/s at 580 A).
    pub slip_sp_per_a: f64,
    /// Slip regulator's proportional gain, A per m/s (300).
    pub kp_a_per_mps: f64,
    /// Slip regulator's integral gain, A/s per m/s (3000).
    pub ki_a_per_s_per_mps: f64,
    /// Zero of the scheduled yaw lead, rad/s (15, below the lead's `w1` = 37; the pole
    /// kept, `|w1 - w1'| < w2 - w1`): the lead while the wheel works at the limit
    /// (module docs).
    pub lead_w1_rad_s: f64,
    /// Gain of the scheduled yaw lead as a fraction of the lead's (0.3).
    pub lead_gain: f64,
    /// Wheel radius `r0`, m (0.45): `w_ref = n v_ref / r0`.
    pub r0_m: f64,
    /// LSB of the reference speed code, m/s (1e-3, `wheelset_proto::units`).
    pub v_ref_lsb_m_per_s: f64,
}

impl Default for WspParams {
    fn default() -> Self {
        Self {
            enabled: false,
            slip_on_mps: 0.25,
            slip_accel_mps: 0.06,
            accel_on_mps2: 3.0,
            cut_fraction: 0.3,
            slip_sp_mps: 0.1,
            slip_sp_per_a: 8e-4,
            kp_a_per_mps: 300.0,
            ki_a_per_s_per_mps: 3000.0,
            lead_w1_rad_s: 15.0,
            lead_gain: 0.3,
            r0_m: 0.45,
            v_ref_lsb_m_per_s: 1e-3,
        }
    }
}

/// The compiled protection for sample type `T` (immutable while running).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wsp<T: Sample> {
    pub(crate) enabled: bool,
    /// `slip_on`, motor-speed pu.
    pub(crate) slip_on: T,
    /// `slip_accel`, motor-speed pu.
    pub(crate) slip_accel: T,
    /// Acceleration threshold per traction step over `iref_step`.
    pub(crate) accel_ratio: T::Coeff,
    /// Fraction kept at detection.
    pub(crate) cut: T::Coeff,
    /// Half the set point at zero cap, motor-speed pu.
    pub(crate) sp_half: T,
    /// Half the set point's slope, speed pu per current pu.
    pub(crate) sp_half_slope: T::Coeff,
    /// `kp' / 2^kp_shift`, current pu per speed pu.
    pub(crate) kp: T::Coeff,
    pub(crate) kp_shift: u8,
    /// `ki' / 2^ki_shift`, current pu per speed pu and per unit of `iref_step`.
    pub(crate) ki: T::Coeff,
    pub(crate) ki_shift: u8,
    /// The scheduled lead's `K_hf'` (pu).
    pub(crate) lead_k_hf: T::Coeff,
    /// The scheduled lead's `rho`.
    pub(crate) lead_rho: T::Coeff,
    /// Reference-speed code -> motor-speed pu: `lsb n / (r0 scales.speed)`.
    pub(crate) v_ref: T::Scale,
}

/// The exact bits of a [`Wsp`] (part of [`crate::CompiledBits`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WspBits {
    /// On at start.
    pub enabled: bool,
    /// `slip_on`, pu signal in `(0, 2]`.
    pub slip_on: u64,
    /// `slip_accel`, pu signal in `(0, slip_on)`.
    pub slip_accel: u64,
    /// Acceleration ratio, coefficient in `(0, 1)`.
    pub accel_ratio: u64,
    /// Fraction kept at detection, coefficient in `(0, 1)`.
    pub cut: u64,
    /// Half the set point at zero cap, pu signal in `(0, slip_on)`.
    pub sp_half: u64,
    /// Half the set point's slope, coefficient in `[0, 1)`.
    pub sp_half_slope: u64,
    /// Regulator's proportional coefficient, in `(0, 1)`.
    pub kp: u64,
    /// `kp`'s shift (`<= 16`).
    pub kp_shift: u8,
    /// Regulator's integral coefficient, in `(0, 1)`.
    pub ki: u64,
    /// `ki`'s shift (`<= 16`).
    pub ki_shift: u8,
    /// Scheduled lead `K_hf'`, a coefficient (signed, as the lead's).
    pub lead_k_hf: u64,
    /// Scheduled lead `rho`, a coefficient (`|rho| < 1`).
    pub lead_rho: u64,
    /// The reference-speed scale.
    pub v_ref: ScaleBits,
}

/// The protection's state.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WspState<T: Sample> {
    /// Current-reference cap, pu (meaningful while active).
    pub cap: T,
    /// Acting.
    pub active: bool,
    /// Motor speed at the previous traction step, pu.
    pub w_prev: T,
    /// Reference speed as motor speed, pu.
    pub w_ref: T,
    /// Slip at the previous traction step, pu (the regulator's proportional term).
    pub slip_prev: T,
    /// The scheduled yaw lead runs: acting, and the slip above half its set point.
    pub sched: bool,
    /// The integral's sub-LSB remainder: the sum of its increments is exact to an LSB
    /// ([`Sample::mul_c_acc`]).
    pub residue: T::Residue,
}

fn check(
    field: &'static str,
    value: f64,
    ok: bool,
    reason: &'static str,
) -> Result<(), ConfigError> {
    if !value.is_finite() {
        return Err(ConfigError::NotFinite { field });
    }
    if ok {
        Ok(())
    } else {
        Err(ConfigError::Range {
            field,
            value,
            reason,
        })
    }
}

/// The largest shift of the regulator's gains (`2^16`).
const MAX_SHIFT: u8 = 16;

/// `x 2^s` by exact doublings, saturating.
#[inline(always)]
fn shl<T: Sample>(mut x: T, s: u8) -> T {
    let mut i = 0;
    while i < s {
        x = x.sat_add(x);
        i += 1;
    }
    x
}

impl<T: Sample> Wsp<T> {
    /// Validate `p` against the motor, scales, limits and the yaw lead `lead` (the
    /// scheduled lead shares its pole and state), and quantise; `speed_lsb` is the
    /// wire's motor-speed LSB, rad/s (`Config.wire.speed`): the slip thresholds sit half
    /// of it above their values (module docs, "Exact decisions").
    pub fn try_new(
        p: &WspParams,
        motor: &Motor,
        s: &FullScales,
        l: &Limits,
        speed_lsb: f64,
        lead: &LeadParams,
    ) -> Result<Self, ConfigError> {
        check(
            "wsp.r0_m",
            p.r0_m,
            p.r0_m > 0.1 && p.r0_m <= 2.0,
            "must be in (0.1, 2] m",
        )?;
        check(
            "wsp.slip_on_mps",
            p.slip_on_mps,
            p.slip_on_mps > 0.0 && p.slip_on_mps <= 10.0,
            "must be in (0, 10] m/s",
        )?;
        check(
            "wsp.slip_accel_mps",
            p.slip_accel_mps,
            p.slip_accel_mps > 0.0 && p.slip_accel_mps < p.slip_on_mps,
            "must be in (0, slip_on_mps)",
        )?;
        check(
            "wsp.accel_on_mps2",
            p.accel_on_mps2,
            p.accel_on_mps2 > 0.0 && p.accel_on_mps2 <= 100.0,
            "must be in (0, 100] m/s^2",
        )?;
        check(
            "wsp.cut_fraction",
            p.cut_fraction,
            p.cut_fraction > 0.0 && p.cut_fraction < 1.0,
            "must be in (0, 1)",
        )?;
        check(
            "wsp.slip_sp_mps",
            p.slip_sp_mps,
            p.slip_sp_mps > 0.0 && p.slip_sp_mps < p.slip_on_mps,
            "must be in (0, slip_on_mps)",
        )?;
        check(
            "wsp.slip_sp_per_a",
            p.slip_sp_per_a,
            p.slip_sp_per_a >= 0.0 && p.slip_sp_per_a * s.current <= 1.0,
            "must be in [0, 1 m/s per scales.current]",
        )?;
        check(
            "wsp.kp_a_per_mps",
            p.kp_a_per_mps,
            p.kp_a_per_mps > 0.0 && p.kp_a_per_mps <= 1e4,
            "must be in (0, 1e4] A per m/s",
        )?;
        check(
            "wsp.ki_a_per_s_per_mps",
            p.ki_a_per_s_per_mps,
            p.ki_a_per_s_per_mps > 0.0 && p.ki_a_per_s_per_mps <= 1e5,
            "must be in (0, 1e5] A/s per m/s",
        )?;
        check(
            "wsp.lead_w1_rad_s",
            p.lead_w1_rad_s,
            p.lead_w1_rad_s > 0.0 && p.lead_w1_rad_s < lead.w2,
            "must be in (0, lead.w2): a phase lead with the lead's pole",
        )?;
        check(
            "wsp.lead_gain",
            p.lead_gain,
            p.lead_gain > 0.0 && p.lead_gain <= 1.0,
            "must be in (0, 1]",
        )?;
        check(
            "wsp.v_ref_lsb_m_per_s",
            p.v_ref_lsb_m_per_s,
            p.v_ref_lsb_m_per_s > 0.0 && p.v_ref_lsb_m_per_s <= 1.0,
            "must be in (0, 1] m/s",
        )?;
        // m/s at the rim -> motor-speed pu.
        let pu = motor.n / (p.r0_m * s.speed);
        let slip_on = p.slip_on_mps * pu;
        check(
            "wsp.slip_on_mps",
            p.slip_on_mps,
            slip_on <= 0.5,
            "is more than 0.5 pu of motor speed",
        )?;
        let q = |name: &'static str, v: f64| {
            T::quantise(v)
                .filter(|_| v > 0.0 && v < 1.0)
                .ok_or(ConfigError::Coefficient { name, value: v })
        };
        // A gain `g > 0` as `c 2^s`, `c` in [1/2, 1) (or `s = 0` and `c = g < 1`).
        let split = |name: &'static str, g: f64| {
            let mut sh = 0u8;
            let mut c = g;
            while c >= 1.0 && sh < MAX_SHIFT {
                c *= 0.5;
                sh += 1;
            }
            q(name, c).map(|c| (c, sh))
        };
        let slew = l.current_ref_rate / s.current; // pu/s
                                                   // Half a motor-speed code above each threshold (module docs, "Exact decisions").
        let half = 0.5 * speed_lsb / s.speed;
        check(
            "wire.speed",
            speed_lsb,
            speed_lsb > 0.0 && 2.0 * half <= p.slip_accel_mps * pu,
            "must be positive and at most wsp.slip_accel_mps at the motor",
        )?;
        // The regulator in pu (module docs, "Law"): kp' = kp / (pu scales.current),
        // ki' = ki / (pu current_ref_rate), the integral per step `ki' iref_step e`.
        let (kp, kp_shift) = split(
            "wsp kp / (n/r0 scales.current)",
            p.kp_a_per_mps / (pu * s.current),
        )?;
        let (ki, ki_shift) = split(
            "wsp ki / (n/r0 current_ref_rate)",
            p.ki_a_per_s_per_mps / (pu * l.current_ref_rate),
        )?;
        let slope = 0.5 * p.slip_sp_per_a * s.current * pu;
        let sp_half_slope = if slope == 0.0 {
            T::quantise(0.0)
        } else {
            T::quantise(slope).filter(|_| slope < 1.0)
        }
        .ok_or(ConfigError::Coefficient {
            name: "wsp slip_sp_per_a scales.current n/r0 / 2",
            value: slope,
        })?;
        // The scheduled lead `lead_gain K a (s + w1')/(s + w2)` on the lead's state: its
        // low-pass gain `g' = (w2 - w1')/w2 = g (1 + rho)`, `rho = (w1 - w1')/(w2 - w1)`.
        let k_hf = lead.k * lead.a * s.y_dot / s.torque;
        let rho = (lead.w1 - p.lead_w1_rad_s) / (lead.w2 - lead.w1);
        Ok(Self {
            enabled: p.enabled,
            slip_on: T::from_f64(slip_on + half),
            slip_accel: T::from_f64(p.slip_accel_mps * pu + half),
            accel_ratio: q(
                "wsp accel_on n/r0 / current_ref_rate",
                p.accel_on_mps2 * pu / slew,
            )?,
            cut: q("wsp.cut_fraction", p.cut_fraction)?,
            sp_half: T::from_f64(0.5 * p.slip_sp_mps * pu),
            sp_half_slope,
            kp,
            kp_shift,
            ki,
            ki_shift,
            // Signed, as the lead's own K_hf (a negative K is a sign test's lead).
            lead_k_hf: T::quantise(p.lead_gain * k_hf).ok_or(ConfigError::Coefficient {
                name: "wsp lead_gain lead.k a (pu)",
                value: p.lead_gain * k_hf,
            })?,
            lead_rho: T::quantise(rho).filter(|_| rho.abs() < 1.0).ok_or(
                ConfigError::Coefficient {
                    name: "wsp lead rho = (w1 - w1')/(w2 - w1)",
                    value: rho,
                },
            )?,
            v_ref: T::scale_in(p.v_ref_lsb_m_per_s * pu).ok_or(ConfigError::Coefficient {
                name: "wsp v_ref lsb n/(r0 scales.speed)",
                value: p.v_ref_lsb_m_per_s * pu,
            })?,
        })
    }

    /// Half the slip set point at cap `cap`: `h = (slip_sp + slip_sp_per_a cap)/2`, pu.
    #[inline(always)]
    pub fn half_set_point(&self, cap: T) -> T {
        self.sp_half.sat_add(cap.mul_c(self.sp_half_slope))
    }

    /// One traction step: `w` the clamped motor speed, `iref` the ramped current
    /// reference, `step` the reference slew per step (pu). Returns the reference to use,
    /// whether the protection acts on this step, and whether it started acting. Sets
    /// `st.sched` (the scheduled yaw lead) for the next yaw steps.
    #[inline(always)]
    pub fn process(&self, st: &mut WspState<T>, w: T, iref: T, step: T) -> (T, bool, bool) {
        let slip = w.sat_sub(st.w_ref);
        let dw = w.sat_sub(st.w_prev);
        st.w_prev = w;
        let d_slip = slip.sat_sub(st.slip_prev);
        st.slip_prev = slip;
        let new = !st.active;
        if new {
            let detect = slip > self.slip_on
                || (slip > self.slip_accel && dw > step.mul_c(self.accel_ratio));
            st.sched = false;
            if !(detect && iref > T::ZERO) {
                return (iref, false, false);
            }
            // Detected: the instantaneous cut, where the regulator starts.
            st.active = true;
            st.cap = iref.mul_c(self.cut);
        } else {
            // The slip regulator, velocity form, on the cap:
            // cap += -kp' (slip - slip_prev) + ki' step (2 h - slip).
            // The integral's rounding is fed back (`mul_c_acc`): its inputs repeat for
            // many steps (the same codes), and a rounding to nearest would bias every
            // step the same way. Its first product rounds by half an LSB of `ki' e`,
            // which the slew per step (4e-3 pu) then scales down. The proportional
            // increments are zero while the codes repeat and sum to `kp' (s - s0)`.
            let h = self.half_set_point(st.cap);
            let p = shl(d_slip, self.kp_shift).mul_c(self.kp);
            let e = h.sat_add(h).sat_sub(slip);
            let i = shl(e, self.ki_shift)
                .mul_c(self.ki)
                .mul_c_acc(step.to_coeff_sat(), &mut st.residue);
            let raw = st.cap.sat_sub(p).sat_add(i);
            // Release where the regulator asks for the whole reference (the rail carries
            // the demand again).
            if raw >= iref {
                st.active = false;
                st.sched = false;
                return (iref, true, false);
            }
            st.cap = raw.limit(T::ZERO, iref).0;
        }
        // The scheduled lead while the slip is above half its set point.
        st.sched = slip > self.half_set_point(st.cap);
        (st.cap, true, new)
    }

    /// The reference speed code (`v_ref` LSBs) as motor-speed pu.
    #[inline(always)]
    pub fn w_ref(&self, code: i32) -> T {
        T::from_code(code, &self.v_ref)
    }
}

impl<T: SampleBits> Wsp<T> {
    /// The exact bits.
    pub fn to_bits(&self) -> WspBits {
        let (mul, shift) = T::scale_to_bits(&self.v_ref);
        WspBits {
            enabled: self.enabled,
            slip_on: self.slip_on.to_bits64(),
            slip_accel: self.slip_accel.to_bits64(),
            accel_ratio: T::coeff_to_bits64(self.accel_ratio),
            cut: T::coeff_to_bits64(self.cut),
            sp_half: self.sp_half.to_bits64(),
            sp_half_slope: T::coeff_to_bits64(self.sp_half_slope),
            kp: T::coeff_to_bits64(self.kp),
            kp_shift: self.kp_shift,
            ki: T::coeff_to_bits64(self.ki),
            ki_shift: self.ki_shift,
            lead_k_hf: T::coeff_to_bits64(self.lead_k_hf),
            lead_rho: T::coeff_to_bits64(self.lead_rho),
            v_ref: ScaleBits { mul, shift },
        }
    }

    /// From exact bits, validated: thresholds `0 < slip_accel < slip_on <= 2` pu and
    /// `0 < sp_half < slip_on`, coefficients in `(0, 1)` (the set point's slope in
    /// `[0, 1)`, the scheduled lead's any), shifts at most 16, a valid scale.
    pub fn from_bits(b: &WspBits) -> Result<Self, crate::BitsError> {
        let e = |field| crate::BitsError { field };
        let sig = |field, v| {
            T::from_bits64(v)
                .filter(|x| *x > T::ZERO && *x <= T::MAX_LIMIT)
                .ok_or(e(field))
        };
        let unit = |field, v, zero_ok| {
            T::coeff_from_bits64(v)
                .filter(|c| T::coeff_in_unit(*c, zero_ok))
                .ok_or(e(field))
        };
        let shift = |field, s: u8| if s <= MAX_SHIFT { Ok(s) } else { Err(e(field)) };
        let slip_on = sig("wsp.slip_on", b.slip_on)?;
        let slip_accel = sig("wsp.slip_accel", b.slip_accel)?;
        let sp_half = sig("wsp.sp_half", b.sp_half)?;
        if slip_accel >= slip_on {
            return Err(e("wsp.slip_accel"));
        }
        if sp_half >= slip_on {
            return Err(e("wsp.sp_half"));
        }
        Ok(Self {
            enabled: b.enabled,
            slip_on,
            slip_accel,
            accel_ratio: unit("wsp.accel_ratio", b.accel_ratio, false)?,
            cut: unit("wsp.cut", b.cut, false)?,
            sp_half,
            sp_half_slope: unit("wsp.sp_half_slope", b.sp_half_slope, true)?,
            kp: unit("wsp.kp", b.kp, false)?,
            kp_shift: shift("wsp.kp_shift", b.kp_shift)?,
            ki: unit("wsp.ki", b.ki, false)?,
            ki_shift: shift("wsp.ki_shift", b.ki_shift)?,
            lead_k_hf: T::coeff_from_bits64(b.lead_k_hf).ok_or(e("wsp.lead_k_hf"))?,
            lead_rho: T::coeff_from_bits64(b.lead_rho).ok_or(e("wsp.lead_rho"))?,
            v_ref: T::scale_from_bits(b.v_ref.mul, b.v_ref.shift).ok_or(e("wsp.v_ref"))?,
        })
    }
}
