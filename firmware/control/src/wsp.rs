//! Wheel-slip protection (WSP) of the traction loop, in motor-speed pu:
//!
//! ```text
//! w = theta_m',  w_ref = n v_ref / r0,  slip = w - w_ref  (= n/r0 times the rim's slip velocity, m/s)
//! dw = w[k] - w[k-1]                     (over one traction step)
//! detect   = slip > slip_on  or  (slip > slip_accel and dw > a_on T n/r0)
//! idle:    detect and i_ref > 0  ->  active, cap = cut i_ref, one event
//! active:  s_sp = slip_sp + slip_sp_per_a cap
//!          raw  = cap - kp (slip[k] - slip[k-1]) + ki T (s_sp - slip[k])
//!          raw >= i_ref  ->  release;  cap = clamp(raw, 0, i_ref)
//! sched    = active and slip > s_sp / 2
//! output:  cap while active, i_ref otherwise
//! ```
//!
//! Positive slip: the wheel faster than the vehicle (motoring); traction only. Per-step
//! quantities are ratios to the schedule's `iref_step`, so a new rate needs no
//! discretisation on the device. Design and figures: `docs/adhesion.md`. An unknown
//! reference, `v_ref_mm_s = 0`, gives `w_ref = 0` exactly: no detection (a rolling wheel
//! would read as slipping, and the gear's twist alone trips the acceleration test) and no
//! regulation (a cap in force rises by `iref_step` per step and releases).
//!
//! While `sched`, the lead runs as `0.3 K a (s + 15)/(s + 274)` on its own state:
//!
//! ```text
//! y' = K_hf' (x - z - rho z),   K_hf' = lead_gain K_hf,   rho = (w1 - w1')/(w2 - w1) = 22/237
//! ```
//!
//! # Exact decisions
//!
//! The slip `c_w a - c_v b` (`a` = 1 mrad/s, `b` = 1 mm/s at the rim = `100/9` mrad/s)
//! is a multiple of `a/9`; the thresholds sit half a speed code above their values, so
//! no slip equals one and the builds decide on the same tick (f32 not guaranteed).
//!
//! # The slip bound on `low-adhesion`
//!
//! ```text
//! s_peak <= max(s_tr, slip_sp + slip_sp_per_a i_d)
//! s_tr    = s0 + r0 dT t_cut / J + (cut i_d - i_low) / kp + r0 dT / (J_w w_g) + r0 (1 - cut) T_d / (J_m w_g)
//!   s0 dry slip at mu_d;  dT = T_d (1 - mu_low(s0) / mu_d);  i_low = mu_low(s0) / mu_d i_d
//!   J_w = 2 I_w, J_m = n^2 I_m, J = J_w + J_m;  w_g = sqrt(k_gear (1/J_w + 1/J_m))
//!   t_cut = t_detect + L_a/K_p              (`sim-host/cli/tests/adhesion.rs` computes it)
//! ```

use crate::compiled::ScaleBits;
use crate::sample::Sample;

mod compile;

/// Wheel-slip protection parameters (SI). Validated by [`Wsp::try_new`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WspParams {
    /// On at start (default on, before any `Config`); idle while the reference speed is unknown.
    pub enabled: bool,
    /// Slip velocity that detects a slip and starts the protection, m/s (0.25).
    pub slip_on_mps: f64,
    /// Slip velocity above which the acceleration test detects, m/s (0.06; `< slip_on`).
    pub slip_accel_mps: f64,
    /// Rim acceleration that detects once the slip is above `slip_accel`, m/s^2 (3.0).
    pub accel_on_mps2: f64,
    /// Fraction of the reference kept at detection (0.3), where the regulator starts.
    pub cut_fraction: f64,
    /// Slip set point at zero cap, m/s (0.1; `< slip_on`).
    pub slip_sp_mps: f64,
    /// Slip set point per ampere of cap, m/s per A (8e-4: 0.56 m/s at 580 A).
    pub slip_sp_per_a: f64,
    /// Slip regulator's proportional gain, A per m/s (300).
    pub kp_a_per_mps: f64,
    /// Slip regulator's integral gain, A/s per m/s (3000).
    pub ki_a_per_s_per_mps: f64,
    /// Zero of the scheduled yaw lead, rad/s (15; the pole kept, `|w1 - w1'| < w2 - w1`).
    pub lead_w1_rad_s: f64,
    /// Gain of the scheduled yaw lead as a fraction of the lead's (0.3).
    pub lead_gain: f64,
    /// Wheel radius `r0`, m (0.45): `w_ref = n v_ref / r0`.
    pub r0_m: f64,
    /// LSB of the reference speed code, m/s ([`wheelset_proto::units::V_REF_LSB_M_PER_S`]).
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

/// The compiled protection for `T` (immutable while running); each field in `T` is the
/// [`WspBits`] field of that name, whose doc gives its unit and range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wsp<T: Sample> {
    pub(crate) enabled: bool,
    pub(crate) slip_on: T,
    pub(crate) slip_accel: T,
    pub(crate) accel_ratio: T::Coeff,
    pub(crate) cut: T::Coeff,
    pub(crate) sp_half: T,
    pub(crate) sp_half_slope: T::Coeff,
    pub(crate) kp: T::Coeff,
    pub(crate) kp_shift: u8,
    pub(crate) ki: T::Coeff,
    pub(crate) ki_shift: u8,
    /// The scheduled lead's `K_hf'` (pu; the schedule's bits carry it, `wsp_lead_k_hf`).
    pub(crate) lead_k_hf: T::Coeff,
    pub(crate) lead_rho: T::Coeff,
    pub(crate) v_ref: T::Scale,
}

/// The exact bits of a [`Wsp`] (part of [`crate::CompiledBits`]).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WspBits {
    /// On at start.
    pub enabled: bool,
    /// `slip_on`, motor-speed pu in `(0, 2]`.
    pub slip_on: u64,
    /// `slip_accel`, motor-speed pu in `(0, slip_on)`.
    pub slip_accel: u64,
    /// Acceleration threshold per traction step over `iref_step`, coefficient in `(0, 1)`.
    pub accel_ratio: u64,
    /// Fraction kept at detection, coefficient in `(0, 1)`.
    pub cut: u64,
    /// Half the set point at zero cap, motor-speed pu in `(0, slip_on)`.
    pub sp_half: u64,
    /// Half the set point's slope, speed pu per current pu in `[0, 1)`.
    pub sp_half_slope: u64,
    /// Regulator's `kp' / 2^kp_shift`, current pu per speed pu in `(0, 1)`.
    pub kp: u64,
    /// `kp`'s shift (`<= 16`).
    pub kp_shift: u8,
    /// Regulator's `ki' / 2^ki_shift`, current pu per speed pu and per unit of `iref_step`,
    /// in `(0, 1)`.
    pub ki: u64,
    /// `ki`'s shift (`<= 16`).
    pub ki_shift: u8,
    /// Scheduled lead `rho`, a coefficient (`|rho| < 1`).
    pub lead_rho: u64,
    /// Reference-speed code -> motor-speed pu: `lsb n / (r0 scales.speed)`.
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
    /// `w_ref != 0` on the previous step: the proportional term differences known slips only.
    pub known: bool,
    /// The integral's sub-LSB remainder ([`Sample::mul_c_acc`]).
    pub residue: T::Residue,
}

/// The largest shift of the regulator's gains (`2^16`).
const MAX_SHIFT: u8 = 16;

/// `x 2^s` by exact doublings, saturating.
#[inline(always)]
fn shl<T: Sample>(mut x: T, s: u8) -> T {
    for _ in 0..s {
        x = x.sat_add(x);
    }
    x
}

impl<T: Sample> Wsp<T> {
    /// Half the slip set point at cap `cap`: `h = (slip_sp + slip_sp_per_a cap)/2`, pu.
    #[inline(always)]
    pub fn half_set_point(&self, cap: T) -> T {
        self.sp_half.sat_add(cap.mul_c(self.sp_half_slope))
    }

    /// Detection on this step while idle (module docs); shared with the fast path.
    #[inline(always)]
    pub(crate) fn detects(&self, w_ref: T, slip: T, dw: T, iref: T, step: T) -> bool {
        let detect =
            slip > self.slip_on || (slip > self.slip_accel && dw > step.mul_c(self.accel_ratio));
        detect && iref > T::ZERO && w_ref != T::ZERO
    }

    /// One traction step (`w` motor speed, `iref` reference, `step` slew, pu): the reference
    /// to use, acting, started acting.
    #[inline(always)]
    pub fn process(&self, st: &mut WspState<T>, w: T, iref: T, step: T) -> (T, bool, bool) {
        let slip = w.sat_sub(st.w_ref);
        let dw = w.sat_sub(st.w_prev);
        st.w_prev = w;
        let known = st.w_ref != T::ZERO;
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
            st.active = true;
            st.cap = iref.mul_c(self.cut);
        } else {
            // cap += -kp' (slip - slip_prev) + ki' step (2 h - slip); the integral's rounding is
            // fed back (`mul_c_acc`): on repeated codes a rounding to nearest biases every step alike.
            let h = self.half_set_point(st.cap);
            let p = shl(d_slip, self.kp_shift).mul_c(self.kp);
            let e = h.sat_add(h).sat_sub(slip);
            let i = shl(e, self.ki_shift)
                .mul_c(self.ki)
                .mul_c_acc(step.to_coeff_sat(), &mut st.residue);
            let raw = st.cap.sat_sub(p).sat_add(i);
            if raw >= iref {
                st.active = false;
                st.sched = false;
                return (iref, true, false);
            }
            st.cap = raw.limit(T::ZERO, iref).0;
        }
        st.sched = slip > self.half_set_point(st.cap);
        (st.cap, true, new)
    }

    /// The reference unknown while a cap is in force: the cap rises by `step` to `iref`.
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

    /// The reference speed code as motor-speed pu; code 0 (unknown) is exactly zero.
    #[inline(always)]
    pub fn w_ref(&self, code: i32) -> T {
        T::from_code(code, &self.v_ref)
    }
}
