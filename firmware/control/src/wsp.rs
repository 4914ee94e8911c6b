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
//! (`i_ref > 0`); slide protection in braking is not part of it. `w_ref = 0` exactly
//! means the reference is unknown (below, "An unknown reference").
//!
//! # Law (per traction step, after the reference ramp)
//!
//! ```text
//! detect   = slip > slip_on  or  (slip > slip_accel and dw > a_on T n/r0)
//! idle:    detect and i_ref > 0  ->  active, cap = cut i_ref (instantaneous), one event
//! active:  the slip regulator (a PI in velocity form on the cap):
//!          s_sp  = slip_sp + slip_sp_per_a cap               (0.1 m/s + 8e-4 m/s per A)
//!          raw   = cap - kp (slip[k] - slip[k-1]) + ki T (s_sp - slip[k])
//!          raw >= i_ref  ->  release (the regulator asks for the whole reference)
//!          cap   = clamp(raw, 0, i_ref)
//! sched    = active and slip > s_sp / 2   (the scheduled yaw lead, below)
//! output:  cap while active, i_ref otherwise
//! ```
//!
//! While the reference is unknown (`w_ref = 0`) neither test detects and the regulator
//! does not run: a cap in force rises by `iref_step` per step (the reference's own slew)
//! until it reaches `i_ref`, where the protection releases (below).
//!
//! `kp` = 300 A per m/s, `ki` = 3 000 A/s per m/s. The set point rises with the cap, to
//! 0.56 m/s at the full 580 A of `low-adhesion`: below every characteristic's peak slip
//! at 83.3 m/s (`low` 0.60, dry 0.91, wet 1.19 m/s), so the regulated wheel works on the
//! rising side of the characteristic, as near its peak as the demand needs. In pu the
//! gains are `kp' = kp / (n/r0 scales.current)` (27) and `ki' T = ki T / (n/r0
//! scales.current)`, held as `c 2^s` (`c` in [1/2, 1), `s` exact doublings); the
//! integral per step is `ki' / current_ref_rate` times the schedule's `iref_step` (the
//! slew per step, `r T / scales.current`), so a new schedule
//! ([`crate::Compiled::with_schedule`]) keeps the rates in SI with no discretisation on
//! the device, as the acceleration test (`a_on n/r0 / r` times `iref_step`). The
//! integral's rounding is fed back ([`Sample::mul_c_acc`]): on repeated codes a
//! rounding to nearest biases every step the same way.
//!
//! # An unknown reference
//!
//! The Sensor frame's `v_ref_mm_s = 0` says the vehicle's speed is not known (a speed
//! estimate that dropped out, a source that cannot resolve a crawl); the core gets
//! `w_ref = 0` exactly, in every build (`0 x scale = 0`), so the builds take the
//! same decisions. While it is unknown:
//!
//! - **no detection.** `slip = w - 0` would read a wheel rolling at line speed as
//!   slipping at 83 m/s and cut the traction for nothing. The acceleration test is idle
//!   too: its gate `slip > slip_accel` is what keeps it off the drive's own transients,
//!   and without a reference there is no gate. The motor's speed is not the wheel's:
//!   the gear (`w_g` = 279 rad/s) twists at every change of torque, and a demand step to
//!   the full 12.4 kN m on dry rail (the reference ramped at its 20 kA/s) makes the
//!   motor's speed code rise by up to 15 mrad/s in one 5 kHz step while the slip stays
//!   below `slip_accel`, against a threshold of 6.67: twice over it, with no slip at all
//!   (`sim-host/tests/adhesion.rs`,
//!   `the_acceleration_test_alone_would_cut_a_wheel_that_does_not_slip`). A test on the
//!   acceleration alone would need a threshold above the gear's transients and would
//!   then miss the slips this one catches, so the protection does not guess.
//! - **no regulation.** The regulator's error is a slip. A cap in force when the
//!   reference drops out is handed back: it rises by `iref_step` per traction step, the
//!   rate at which the reference follows a step of the demand, and the protection
//!   releases when it reaches `i_ref` (`WHEEL_SLIP` stays set while the cap holds the
//!   reference below the demand's). No step in the reference, so no step in the torque
//!   on a wheel that was slipping a moment ago.
//! - **the reference comes back**: the tests run again from that step on. The
//!   regulator, if a cap is in force, resumes from it; its proportional term starts
//!   from the first known slip (no difference against a slip of the unknown steps).
//!
//! So a start from standstill sent as `v_ref = 0` is not protected by this device: a
//! host whose source knows the vehicle is standing (rather than not knowing its speed)
//! sends 1 mm/s, which the slip tests treat as any known speed (1 mm/s is 250 times
//! below `slip_on`). The wire's convention is in `wheelset_proto::Sensor::v_ref_mm_s`.
//!
//! # The scheduled lead
//!
//! The paper's lead `K a (s + 37)/(s + 274)` (K = 1.05e5, a = 7.5) goes unstable when
//! the wheel works near the adhesion peak: the longitudinal creep slope, which damps the
//! yaw, falls there (modal analysis by central differences about a steady traction point:
//! unstable from 0.7 of the peak on wet, 0.6 on `low`). Scaling its gain is not enough.
//! `0.3 K a (s + 15)/(s + 274)` (zero moved, pole kept) is stable at 0.8-0.9 of the peak
//! on `low` and wet (oscillatory modes at -6 to -8 rad/s) but unstable at a high creep
//! slope (+7.7 rad/s at 0.05 of the peak), so it runs only while `sched`: the protection
//! acts and the slip is above half its set point. It runs on the lead's own state
//! ([`crate::lead`]: `y = K_hf (x - z)`, `z` the low-pass of `g x`, `g = (w2 - w1)/w2`):
//! its low-pass of `g' x`, `g' = (w2 - w1')/w2`, is `z g'/g = z (1 + rho)`, so
//!
//! ```text
//! y' = K_hf' (x - z - rho z),   K_hf' = lead_gain K_hf,   rho = (w1 - w1')/(w2 - w1) = 22/237
//! ```
//!
//! The switch is abrupt (a slewed switch rate-limited the torque and diverged at
//! 10.28 s). The fast path does not run with the protection on, so it is untouched.
//!
//! # Exact decisions
//! Every decision compares a quantity built from the wire's integers with a level, and on
//! the same Sensor codes the fixed-point, f32 and f64 builds should take it on the same
//! tick (`hil run --scenario low-adhesion` judges the Q4.28 device against the f64 core).
//! Where the exact quantity can land *on* the level, each build's rounding decides, so
//! the detection's levels are moved off the lattice the slip lives on:
//!
//! - The slip `w - w_ref` is `c_w a - c_v b`, `c_w` the motor-speed code (`a` = 1 mrad/s
//!   in pu), `c_v` the reference-speed code (`b` = 1 mm/s at the rim = `100/9` mrad/s at
//!   the motor with `n/r0 = 5/0.45`). So the slip is a multiple of `a/9`, and a threshold
//!   in whole mm/s is a multiple of `b`: `c_w a = (c_v + 60) b` whenever 9 divides
//!   `c_v + 60`, and the slip then *equals* the threshold (on the codes of
//!   `low-adhesion` that happened at 7.585 s with the earlier band law: f32 cut, Q4.28
//!   and f64 did not). Half a code above, `theta + a/2`, no slip equals a threshold
//!   (`18 c_w = 200 (c_v + N) + 9` has no integer solution: even against odd), the
//!   nearest lies `a/18` = 5.6e-8 pu away: 7 times the Q4.28 error of a slip (two code x
//!   scale products, each within 2^-28 of exact, 7.5e-9 pu together) and far beyond
//!   f64's. An f32 slip near 0.9 pu carries up to 6e-8 pu of rounding, as much as the
//!   margin: the f32 build is not guaranteed to agree. Moving a threshold by 0.045 mm/s
//!   at the rim changes nothing a rail notices.
//! - The acceleration `dw` is a difference of speed codes, `k a` for an integer `k`,
//!   against `a_on T n/r0` = 6.67 `a` at 5 kHz: a third of a code from the nearest `k`.
//! - The lead switch (`slip > s_sp/2`) and the release (`raw >= i_ref`) compare with
//!   levels that move with the cap, a sum of the regulator's products: not on a lattice,
//!   so a tie is a matter of chance, not of the codes' arithmetic. But the caps of two
//!   builds do not stay together on replayed codes: the set point rises with the cap, so
//!   with no rail to answer (open loop) a difference grows as `exp(ki slip_sp_per_a t)` =
//!   `exp(2.4 t/s)`; from the Q4.28 slip's bias (the reference-speed scale's rounding,
//!   3e-9 pu) the caps are 1e-5 pu apart 1.4 s after a cut. While they agree the builds
//!   switch and release on the same ticks.
//!
//! `sim-host/cli/tests/adhesion.rs`, `every_build_takes_the_same_decisions_on_the_same_codes`
//! replays the f64 core's codes of `low-adhesion` through the three builds: the same
//! detection ticks, the same switch and release while the caps agree within 1e-5 pu.
//! A device in a closed loop is another matter: the rail answers the cap, and its plant
//! run and the reference's part by an LSB (on `low-adhesion` the first differing speed
//! code is at 1.17 s), so a decision can fall a tick apart where the codes differ. The
//! harness's numerics judge such a cut within their time tolerance on the reference
//! recorded at the control period (`hil::check::numerics`, "The tube at the control period").
//!
//! # The slip bound on `low-adhesion`
//! The worst disturbance of the scenario is its first: at 6.0 s the rail drops from dry
//! to `low` under the full demand `T_d` = 12.4 kN m at the wheel (`mu_d` = 0.250, `i_d` =
//! 580 A). The wheel slip velocity (the plant's `slip_mps`, the mean wheel) stays below
//! the larger of the first transient and the regulator's set point at the full
//! reference:
//!
//! ```text
//! s_peak <= max(s_tr, slip_sp + slip_sp_per_a i_d) = max(0.624, 0.564) = 0.624 m/s
//! s_tr    = s0 + r0 dT t_cut / J + (cut i_d - i_low) / kp
//!              + r0 dT / (J_w w_g) + r0 (1 - cut) T_d / (J_m w_g)
//!   s0       the dry rail's slip at mu_d (Polach, pure longitudinal)  0.165 m/s
//!   dT       T_d (1 - mu_low(s0) / mu_d): the torque the low rail     9.6 kN m
//!            no longer carries (its characteristic rises from s0 to
//!            its peak at 0.60 m/s, so it carries at least mu_low(s0) = 0.056)
//!   i_low    mu_low(s0) / mu_d i_d: the current whose torque it       130 A
//!            carries
//!   J_w, J_m 2 I_w = 70 and n^2 I_m = 275 kg m^2 at the wheel; J = J_w + J_m
//!   w_g      sqrt(k_gear (1/J_w + 1/J_m)) = 279 rad/s: wheelset against motor
//!   t_cut    t_detect + L_a/K_p = 2.9 + 0.4 ms: the cut in the current
//! ```
//!
//! The terms, each a worst case:
//!
//! - **Until the cut** (`r0 dT t_cut / J` = 0.042 m/s): the adhesion torque falls by
//!   `dT` at `t = 0` while the motor torque stays `<= T_d`; the motor's speed rises by
//!   `dT/J [t - sin(w_g t)/w_g] <= dT t/J`. `t_detect` = 2.9 ms: the slip is above
//!   `slip_accel` already (`s0`), so the acceleration test detects once the motor's rim
//!   acceleration `r0 dT/J (1 - cos w_g t)` reaches `a_on` = 3 m/s^2 (2.5 ms), plus one
//!   traction step to measure it and one period until the cut acts (0.2 ms each at
//!   5 kHz); the current follows within the current loop's lag `L_a / K_p` = 0.4 ms.
//! - **The regulator** (`(cut i_d - i_low)/kp` = 0.145 m/s): after the cut to 0.3 x
//!   580 A = 174 A the motor torque still exceeds the low rail's by at most `(cut -
//!   mu_low(s0)/mu_d) T_d`. The proportional term takes `kp` = 300 A per m/s of the
//!   measured (motor) slip's rise off the cap, and the integral takes more while the slip
//!   is above its set point (0.24 m/s at 174 A, below the slip at the cut), so the motor's
//!   slip rises at most 0.145 m/s past its value at the cut before the cap is below
//!   `i_low`, where the rail's torque exceeds the motor's.
//! - **The gear's twist** (0.221 + 0.051 m/s): the plant's slip is the wheel's, the
//!   regulator sees the motor's. A torque step `dT` on one inertia of the two-mass gear
//!   twists it by a relative speed of amplitude `dT/(J_i w_g)` (the wheel's speed rises by
//!   `dT/J [t + (J_m/(J_w w_g)) sin(w_g t)]`, the motor's by `dT/J [t - sin(w_g t)/w_g]`):
//!   the rail's drop on the wheel, `r0 dT/(J_w w_g)`, and the cut on the motor, `r0 (1 -
//!   cut) T_d/(J_m w_g)`, both put the wheel ahead of the motor, 3 ms (0.9 rad of `w_g`)
//!   apart; their amplitudes are added.
//! - **The regulation** (0.564 m/s): at a steady state the regulator holds the slip on
//!   its set point, at most `slip_sp + slip_sp_per_a i_d` since the cap is at most the
//!   reference.
//!
//! Measured (`sim-host run --scenario low-adhesion --loop core --wsp on`): 0.423 m/s at
//! 6.007 s in the first transient, and the run's peak 0.454 m/s in the wet section's
//! regulation (14.0 s, the cap about 430 A, its set point 0.45 m/s); the test
//! `the_core_with_protection_holds_the_wheel_and_without_it_runs_away` in
//! `sim-host/cli/tests/adhesion.rs` computes the bound from the parameters and asserts the
//! measured peak below it. The set point at the full reference lies below the `low`
//! rail's peak slip (0.60 m/s), so a regulated wheel works on the rising side; the
//! transient's bound (0.624 m/s) does not exclude a brief excursion past the `low` peak,
//! which the regulator then takes back (the measured transient stays at 0.42 m/s).
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
use crate::sample::Sample;

mod compile;

/// Wheel-slip protection parameters (SI). Validated by [`Wsp::try_new`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WspParams {
    /// On at start (default **on**: the device boots with it, before any `Config`,
    /// which switches it; [`crate::Controller::set_wsp`]). Idle while the reference
    /// speed is unknown (module docs, "An unknown reference"), so a host that sends no
    /// `v_ref` sees no cut from it.
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
    /// LSB of the reference speed code, m/s
    /// ([`wheelset_proto::units::V_REF_LSB_M_PER_S`]).
    pub v_ref_lsb_m_per_s: f64,
}

impl Default for WspParams {
    fn default() -> Self {
        Self {
            enabled: true,
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
            v_ref_lsb_m_per_s: wheelset_proto::units::V_REF_LSB_M_PER_S,
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
    /// The reference speed was known (`w_ref != 0`) on the previous traction step: the
    /// regulator's proportional term takes the difference of two known slips only.
    pub known: bool,
    /// The integral's sub-LSB remainder: the sum of its increments is exact to an LSB
    /// ([`Sample::mul_c_acc`]).
    pub residue: T::Residue,
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
    /// Half the slip set point at cap `cap`: `h = (slip_sp + slip_sp_per_a cap)/2`, pu.
    #[inline(always)]
    pub fn half_set_point(&self, cap: T) -> T {
        self.sp_half.sat_add(cap.mul_c(self.sp_half_slope))
    }

    /// The protection, not acting, detects on this step (and cuts): the reference speed
    /// `w_ref` known (not 0), the slip `slip` above `slip_on`, or above `slip_accel`
    /// while the speed rose by `dw` more than `accel_ratio` reference slews `step`, with
    /// a positive reference `iref`. One rule for [`Self::process`] and the controller's
    /// fast path (which declines the step to the general one when it detects).
    #[inline(always)]
    pub(crate) fn detects(&self, w_ref: T, slip: T, dw: T, iref: T, step: T) -> bool {
        let detect =
            slip > self.slip_on || (slip > self.slip_accel && dw > step.mul_c(self.accel_ratio));
        detect && iref > T::ZERO && w_ref != T::ZERO
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
        let known = st.w_ref != T::ZERO;
        // The proportional term's difference, of two known slips only (module docs, "An
        // unknown reference").
        let d_slip = if st.known {
            slip.sat_sub(st.slip_prev)
        } else {
            T::ZERO
        };
        st.slip_prev = slip;
        st.known = known;
        if !known && st.active {
            return Self::hand_back(st, iref, step);
        }
        let new = !st.active;
        if new {
            st.sched = false;
            if !self.detects(st.w_ref, slip, dw, iref, step) {
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

    /// The reference speed unknown while a cap is in force: the cap rises by `step` (the
    /// reference's slew per step) and the protection releases once it would reach
    /// `iref`; no regulation, no scheduled lead (module docs, "An unknown reference").
    #[cold]
    #[inline(never)]
    fn hand_back(st: &mut WspState<T>, iref: T, step: T) -> (T, bool, bool) {
        st.sched = false;
        let cap = st.cap.sat_add(step);
        if cap >= iref {
            st.active = false;
            return (iref, true, false);
        }
        st.cap = cap;
        (cap, true, false)
    }

    /// The reference speed code (`v_ref` LSBs) as motor-speed pu; code 0 (unknown) is
    /// exactly zero.
    #[inline(always)]
    pub fn w_ref(&self, code: i32) -> T {
        T::from_code(code, &self.v_ref)
    }
}
