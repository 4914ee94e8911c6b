//! The controller's supervisory interface: mode switches, presets, read access (none on
//! the per-tick path).

use super::{Controller, Counters};
use crate::compiled::Compiled;
use crate::config::YawMode;
use crate::lead::LeadState;
use crate::pi::PiState;
use crate::sample::Sample;
use crate::wsp::WspState;

use super::Outputs;

impl<T: Sample> Controller<T> {
    /// Turns the fast path off or back on; the general path gives the same results bit for bit.
    pub fn set_fast_path(&mut self, on: bool) {
        self.fast_off = !on;
        self.refresh();
    }
    /// Whether the next tick may take the fast path.
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

    /// Enter (`true`) or leave the safe state: the torque limit ramps to 0 over `safe.yaw_s`
    /// and back, the current reference to 0 over at most `safe.traction_s`.
    pub fn set_safe(&mut self, safe: bool) {
        self.safe = safe;
        self.refresh();
    }
    /// In the safe state?
    pub fn is_safe(&self) -> bool {
        self.safe
    }
    /// The present yaw torque limit, pu (`torque_max`, or ramping in and out of the safe state).
    pub fn torque_limit(&self) -> T {
        self.torque_lim
    }
    /// [`Self::set_safe`] with the torque limit at `torque_limit` (pu, clamped to
    /// `[0, torque_max]`): a core continuing another's state, or a boot after a fault (0).
    pub fn set_safe_at(&mut self, safe: bool, torque_limit: T) {
        let max = self.law.torque_max;
        self.torque_lim = torque_limit.sanitize().0.limit(T::ZERO, max).0;
        self.set_safe(safe);
    }

    /// Change the yaw mode, bumpless: the lead starts from its steady state, and the torque
    /// slews at most `torque_step` per yaw step (`limits.torque / safe.yaw_s`).
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

    /// Continue from a yaw torque `t_psi` (pu) of another core, slewing as a law change does.
    pub fn continue_from(&mut self, t_psi: T) {
        self.out.yaw_torque = t_psi;
        self.slewing = true;
        self.refresh();
    }

    /// The back-EMF `K_m omega_m` of `speed` (pu), clamped to the voltage limits.
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

    /// Traction loop on/off. Off: `u_a = K_m omega_m` (zero current; 0 V would short the
    /// motor at speed), integrator disarmed; on again: preset to the back-EMF (bumpless).
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
    /// The reference speed as motor speed `n v_ref / r0`, pu (held, sanitised, clamped; 0 unknown).
    pub fn set_v_ref(&mut self, w_ref: T) {
        let m = self.law.speed_max;
        self.wsp.w_ref = w_ref.sanitize().0.limit(T::ZERO.sat_sub(m), m).0;
    }
    /// [`Self::set_v_ref`] from the Sensor frame's code (1 mm/s; 0: unknown).
    pub fn set_v_ref_code(&mut self, code: i32) {
        self.set_v_ref(self.law.wsp.w_ref(code));
    }
    /// The protection's state.
    pub fn wsp_state(&self) -> &WspState<T> {
        &self.wsp
    }

    /// Bumpless start: the PI integrator to the back-EMF of `speed` (pu), the reference to 0.
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
    /// protection's cap while it acts (what [`crate::Monitor::tick`] takes as `iref`).
    pub fn applied_ref(&self) -> T {
        if self.wsp.active {
            self.wsp.cap
        } else {
            self.iref
        }
    }
    /// The latest traction step's error `i_ref - i_a` (pu, + when the current is below its
    /// reference), as the PI took it; 0 with traction off.
    pub fn current_error(&self) -> T {
        self.i_err
    }
    /// Whether the latest tick ran a traction step.
    pub fn traction_stepped(&self) -> bool {
        self.traction_phase == self.law.traction_divisor.saturating_sub(1)
    }
    /// The outputs held from the last tick.
    pub fn outputs(&self) -> Outputs<T> {
        self.out
    }
}
