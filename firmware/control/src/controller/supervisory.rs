//! The controller's supervisory interface: the mode switches (safe state, yaw law,
//! traction, wheel-slip protection, fast path), the presets a caller makes before a law
//! change or the first tick, and read access to the states and counters. None of it runs
//! on the per-tick path ([`Controller::tick`], in the parent module); the runtime calls it
//! when a Config, a Command or a supervision event asks for it.

use super::{Controller, Counters};
use crate::compiled::Compiled;
use crate::config::YawMode;
use crate::lead::{Lead, LeadState};
use crate::pi::{Pi, PiState};
use crate::sample::Sample;
use crate::wsp::WspState;

use super::{Codec, Outputs};

impl<T: Sample> Controller<T> {
    /// Turns the fast path of [`Self::tick`] off (`false`) or back on (the default): the
    /// general path alone gives the same results bit for bit, only slower (the
    /// `fast_path` tests compare the two).
    pub fn set_fast_path(&mut self, on: bool) {
        self.fast_off = !on;
        self.refresh();
    }
    /// Whether the next tick may take the fast path (normal running on a configuration
    /// that meets its preconditions, and not turned off).
    pub fn fast_path_armed(&self) -> bool {
        self.fast
    }

    /// The counters.
    pub fn counters(&self) -> &Counters {
        &self.counters
    }
    /// Reset the counters to zero.
    pub fn reset_counters(&mut self) {
        self.counters = Counters::default();
    }

    /// Enter (`true`) or leave the safe state. Entering: the yaw torque limit ramps
    /// linearly to 0 over `safe.yaw_s` and the current reference to 0 over at most
    /// `safe.traction_s`; leaving: the torque limit ramps back up at the same rate and
    /// the reference follows the demand at its normal slew rate.
    pub fn set_safe(&mut self, safe: bool) {
        self.safe = safe;
        self.refresh();
    }
    /// In the safe state?
    pub fn is_safe(&self) -> bool {
        self.safe
    }
    /// The present yaw torque limit, pu: `torque_max` in normal running, ramping to 0 in
    /// the safe state and back up after it.
    pub fn torque_limit(&self) -> T {
        self.torque_lim
    }
    /// Enter (`true`) or leave the safe state with the yaw torque limit at `torque_limit`
    /// (pu, clamped to `[0, torque_max]`) instead of where it stands; it then ramps as
    /// [`Self::set_safe`] says. For a core that continues another core's state (new
    /// rates: its safe state and limit, so a safe state goes on ramping down where it
    /// was) or that starts where no torque may be driven (the safe state at a boot
    /// after a fault, limit 0: zero torque from the first tick).
    pub fn set_safe_at(&mut self, safe: bool, torque_limit: T) {
        let max = self.law.torque_max;
        self.torque_lim = torque_limit.sanitize().0.limit(T::ZERO, max).0;
        self.set_safe(safe);
    }

    /// Change the yaw mode, bumpless: switching into [`YawMode::Lead`] starts the lead
    /// from its steady state for the last `y'`, and any change of the law slews the
    /// torque from the old law's last output to the new law's at most `torque_step` per
    /// yaw step (the safe-state ramp's rate, `limits.torque / safe.yaw_s` = 2e5 N m/s by
    /// default: 40 N m per 200 us tick), until it has caught up with it.
    pub fn set_mode(&mut self, mode: YawMode) {
        if mode == YawMode::Lead && self.mode != YawMode::Lead {
            self.lead_state = self.law.lead.steady_state(self.last_y_dot);
        }
        if mode != self.mode {
            self.slewing = true;
        }
        self.mode = mode;
        self.refresh();
    }

    /// Continue from a yaw torque `t_psi` (pu) output before, e.g. by a core at other
    /// rates: the next yaw steps slew from it to this law's output (as a law change does).
    pub fn continue_from(&mut self, t_psi: T) {
        self.out.yaw_torque = t_psi;
        self.slewing = true;
        self.refresh();
    }

    /// The back-EMF `K_m omega_m` of the motor speed `speed` (pu, clamped to its limit),
    /// pu, clamped to the voltage limits: the motor voltage at which the armature current
    /// is zero (or as close as the limits allow).
    pub fn back_emf(&self, speed: T) -> T {
        let law = &self.law;
        speed
            .sanitize()
            .0
            .limit(T::ZERO.sat_sub(law.speed_max), law.speed_max)
            .0
            .mul_c(law.back_emf)
            .limit(law.pi.u_min, law.pi.u_max)
            .0
    }
    /// The yaw mode.
    pub fn mode(&self) -> YawMode {
        self.mode
    }

    /// Traction loop on/off. Off: `u_a = K_m omega_m`, the back-EMF of the present speed
    /// (zero current; 0 V would short the motor at speed), and the integrator is
    /// disarmed; on again: the next traction step presets it to the back-EMF (bumpless).
    pub fn set_traction(&mut self, on: bool) {
        self.traction = on;
        if !on {
            self.armed = false;
        }
        self.refresh();
    }
    /// Traction loop on?
    pub fn traction_enabled(&self) -> bool {
        self.traction
    }

    /// Wheel-slip protection on/off ([`crate::wsp`]); off releases it at once.
    pub fn set_wsp(&mut self, on: bool) {
        self.wsp_on = on;
        if !on {
            self.wsp.active = false;
            self.wsp.sched = false;
            self.wsp_acting = false;
        }
        self.refresh();
    }
    /// Wheel-slip protection on?
    pub fn wsp_enabled(&self) -> bool {
        self.wsp_on
    }
    /// The protection acted on the last traction step (the `WHEEL_SLIP` flag).
    pub fn wheel_slip(&self) -> bool {
        self.wsp_acting
    }
    /// The vehicle reference speed as motor speed `n v_ref / r0`, pu of `scales.speed`
    /// (held until the next call; sanitised and clamped to the speed limit). Zero (a NaN
    /// too, sanitised to zero) means unknown: the protection neither detects nor
    /// regulates ([`crate::wsp`], "An unknown reference").
    pub fn set_v_ref(&mut self, w_ref: T) {
        let m = self.law.speed_max;
        self.wsp.w_ref = w_ref.sanitize().0.limit(T::ZERO.sat_sub(m), m).0;
    }
    /// [`Self::set_v_ref`] from the Sensor frame's code (`v_ref` LSBs, 1 mm/s; 0:
    /// unknown).
    pub fn set_v_ref_code(&mut self, code: i32) {
        self.set_v_ref(self.law.wsp.w_ref(code));
    }
    /// The protection's state.
    pub fn wsp_state(&self) -> &WspState<T> {
        &self.wsp
    }

    /// Bumpless start: preset the PI integrator to the back-EMF `K_m omega_m` of the
    /// motor speed `speed` (pu), clamped to the voltage limits, and the reference to 0.
    pub fn preset_back_emf(&mut self, speed: T) {
        let u = self.back_emf(speed);
        self.law.pi.preset(&mut self.pi_state, u);
        self.iref = T::ZERO;
        self.ramp_settled = false;
        self.armed = true;
        self.refresh();
    }
    /// Preset the PI integrator to a voltage `u0` (pu), clamped to the limits.
    pub fn preset_integrator(&mut self, u0: T) {
        self.law.pi.preset(&mut self.pi_state, u0);
        self.armed = true;
        self.refresh();
    }

    /// The compiled (discretised, quantised) controller this runs.
    pub fn compiled(&self) -> &Compiled<T> {
        &self.law
    }
    /// The lead as quantised for `T`.
    pub fn lead(&self) -> &Lead<T> {
        &self.law.lead
    }
    /// The PI as quantised for `T`.
    pub fn pi(&self) -> &Pi<T> {
        &self.law.pi
    }
    /// The wire codec.
    pub fn codec(&self) -> &Codec<T> {
        &self.law.codec
    }
    /// The lead's state.
    pub fn lead_state(&self) -> &LeadState<T> {
        &self.lead_state
    }
    /// The PI's state.
    pub fn pi_state(&self) -> &PiState<T> {
        &self.pi_state
    }
    /// The ramped current reference, pu.
    pub fn current_ref(&self) -> T {
        self.iref
    }
    /// The current reference the PI follows, pu: the ramped reference, or the wheel-slip
    /// protection's cap while it acts. What the actuator check's traction-change rule
    /// watches ([`crate::Monitor::tick`]).
    pub fn applied_ref(&self) -> T {
        if self.wsp.active {
            self.wsp.cap
        } else {
            self.iref
        }
    }
    /// The current error `i_ref - i_a` (pu of `scales.current`, + when the current is
    /// below its reference) of the latest traction step: the reference after the
    /// wheel-slip protection's cap and the clamped measurement, as the PI took them;
    /// 0 while traction is off. What [`crate::Monitor::drive_step`] watches.
    pub fn current_error(&self) -> T {
        self.i_err
    }
    /// Whether the latest [`Controller::tick`] ran a traction step (every tick on the
    /// fast path; every `traction_divisor` ticks on the general one).
    pub fn traction_stepped(&self) -> bool {
        self.traction_phase == self.law.traction_divisor.saturating_sub(1)
    }
    /// The outputs held from the last tick.
    pub fn outputs(&self) -> Outputs<T> {
        self.out
    }
}
