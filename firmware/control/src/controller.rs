//! The multi-rate controller: input clamps, the yaw loop (passive / gain / lead), the
//! traction loop (ramped reference + PI), output limits, the safe state, counters.

use crate::compiled::Compiled;
use crate::config::{Config, ConfigError, YawMode};
use crate::lead::LeadState;
use crate::pi::PiState;
use crate::sample::{Fx, Sample};
use crate::wsp::WspState;

mod signals;
mod supervisory;

use signals::event;

pub use signals::{
    Codec, Counters, InputCodes, Inputs, OutputCodes, Outputs, SignalCounts, TickEvents,
};

/// The controller: configuration, filter states, counters.
#[derive(Clone, Debug)]
pub struct Controller<T: Sample> {
    law: Compiled<T>,
    mode: YawMode,
    traction: bool,
    safe: bool,
    /// The integrator has been preset since traction was (re)enabled.
    armed: bool,
    yaw_phase: u16,
    traction_phase: u16,
    lead_state: LeadState<T>,
    pi_state: PiState<T>,
    /// Ramped current reference, pu.
    iref: T,
    torque_lim: T,
    /// A law change is being slewed: at most `torque_step` per yaw step towards the new law.
    slewing: bool,
    /// Last clamped y' (the predictor's `y'[n-1]`; a bumpless switch into the lead).
    last_y_dot: T,
    out: Outputs<T>,
    counters: Counters,
    events: TickEvents,
    wsp_on: bool,
    wsp: WspState<T>,
    wsp_acting: bool,
    /// The next tick may try the fast path (normal running: see [`Self::tick`]).
    fast: bool,
    fast_off: bool,
    /// The configuration meets the fast path's preconditions (checked in [`Self::new`]).
    fast_ok: bool,
    /// `g_half` and `Kp` in [`Sample::pre_coeff`] form (the fast path's products).
    g_half_pre: T::Coeff,
    kp_pre: T::Coeff,
    /// The ramp has settled on `settled_demand`: `iref` equals its target.
    ramp_settled: bool,
    settled_demand: T,
    i_err: T,
}

/// The project's production controller: Q4.28 signals, Q1.31 coefficients.
pub type FixedController = Controller<Fx>;
/// The FPU build.
pub type F32Controller = Controller<f32>;
/// The reference.
pub type F64Controller = Controller<f64>;

impl<T: Sample> Controller<T> {
    /// Validate, discretise and quantise ([`Compiled::try_new`]), then [`Self::new`].
    pub fn try_new(config: &Config) -> Result<Self, ConfigError> {
        Ok(Self::new(&Compiled::try_new(config)?))
    }

    /// A controller running `law` (no float maths), states zero, the integrator to be preset
    /// to the back-EMF by the first traction step (bumpless).
    pub fn new(law: &Compiled<T>) -> Self {
        // The fast path's preconditions: its short products are exact for every reachable state.
        let g_half_pre = T::pre_coeff(law.lead.g_half);
        let kp_pre = T::pre_coeff(law.pi.kp);
        let fast_ok = g_half_pre.is_some()
            && kp_pre.is_some()
            && law.y_dot_max < T::two_pu()
            && law.y_dot_pred_max <= T::two_pu()
            && law.demand_max <= T::two_pu()
            && law.yaw_divisor == 1
            && law.traction_divisor == 1;
        let mut c = Self {
            law: *law,
            mode: law.yaw_mode,
            traction: law.traction_enabled,
            safe: false,
            armed: false,
            yaw_phase: 0,
            traction_phase: 0,
            lead_state: LeadState::default(),
            pi_state: PiState::default(),
            iref: T::ZERO,
            torque_lim: law.torque_max,
            slewing: false,
            last_y_dot: T::ZERO,
            out: Outputs::default(),
            counters: Counters::default(),
            events: TickEvents::NONE,
            wsp_on: law.wsp.enabled,
            wsp: WspState::default(),
            wsp_acting: false,
            fast: false,
            fast_off: false,
            fast_ok,
            g_half_pre: g_half_pre.unwrap_or(law.lead.g_half),
            kp_pre: kp_pre.unwrap_or(law.pi.kp),
            ramp_settled: false,
            settled_demand: T::ZERO,
            i_err: T::ZERO,
        };
        c.refresh();
        c
    }

    /// Recomputes whether the fast path applies (normal running on a suitable configuration).
    #[inline(always)]
    fn refresh(&mut self) {
        self.fast = self.fast_ok
            && !self.fast_off
            && !self.safe
            && !self.slewing
            && self.mode == YawMode::Lead
            && self.traction
            && self.armed
            && !(self.wsp_on && (self.wsp.active || self.wsp.sched))
            && self.torque_lim == self.law.torque_max;
    }

    /// One base-rate tick: inputs sanitised and clamped (counted), the yaw loop every
    /// `yaw_divisor` ticks, the traction loop every `traction_divisor`; never panics. The fast
    /// path declines to the general one, state untouched, where a clamp would engage.
    #[inline]
    pub fn tick(&mut self, inp: &Inputs<T>) -> Outputs<T> {
        T::controller_tick(self, inp)
    }

    /// [`Self::tick`]'s body (called through [`Sample::controller_tick`]).
    #[inline(always)]
    pub(crate) fn tick_impl(&mut self, inp: &Inputs<T>) -> Outputs<T> {
        if !self.fast {
            return self.general_tick(inp);
        }
        // Normal running: neither loop changes a state `refresh` reads.
        let k = &mut self.counters;
        k.ticks = k.ticks.wrapping_add(1);
        k.yaw_steps = k.yaw_steps.wrapping_add(1);
        k.traction_steps = k.traction_steps.wrapping_add(1);
        let mut ev = 0u32;
        if !self.fast_yaw(inp.y_dot, &mut ev) {
            ev = self.yaw_general(inp.y_dot);
        }
        // One copy of the traction fast path per setting of the protection.
        let fast = if self.wsp_on {
            self.fast_traction::<true>(inp)
        } else {
            self.fast_traction::<false>(inp)
        };
        if !fast {
            ev |= self.traction_general(inp);
            self.refresh();
        }
        if ev != 0 {
            self.counters.record(ev);
        }
        self.events = TickEvents(ev);
        self.out
    }

    /// What the latest [`Self::tick`] counted, one bit per counter.
    #[inline(always)]
    pub fn tick_events(&self) -> TickEvents {
        self.events
    }

    /// The yaw loop's fast path: `false`, nothing changed, if the `y'` or predictor clamp
    /// would engage. Exact: `|y'| < 2` so `|y'[n] - y'[n-1]| < 4`; `x, x[n-1]` within 2 pu and
    /// `|g/2| <= 0.5 - 2^-30` keep `z` below 2 pu, so `|e| < 4` and `|x - z| < 4`.
    #[inline(always)]
    fn fast_yaw(&mut self, y: T, ev: &mut u32) -> bool {
        let law = &self.law;
        if !y.abs_within(law.y_dot_max) {
            return false;
        }
        let d = y.sat_sub(self.last_y_dot).mul_c_small(law.predict_half);
        let x = y.sat_add(d).sat_add(d);
        if !x.abs_within(law.y_dot_pred_max) {
            return false;
        }
        let LeadState { x1, z } = self.lead_state;
        let e = x.sat_add(x1).mul_pre(self.g_half_pre).sat_sub(z);
        let z = z.sat_add(e.mul_c_small(law.lead.kappa));
        let t = x.sat_sub(z).mul_c_small(law.lead.k_hf);
        self.last_y_dot = y;
        self.lead_state = LeadState { x1: x, z };
        // The torque limit can engage in normal running: applied and counted here.
        let tmax = law.torque_max;
        self.out.yaw_torque = if t.abs_within(tmax) {
            t
        } else {
            *ev |= 1 << event::TORQUE;
            t.limit(T::ZERO.sat_sub(tmax), tmax).0
        };
        true
    }

    /// The traction loop's fast path: `false`, nothing changed, if a clamp would engage.
    /// Exact: `|demand| <= 2`, and `Kp` by [`Self::new`]'s precondition.
    #[inline(always)]
    fn fast_traction<const WSP: bool>(&mut self, inp: &Inputs<T>) -> bool {
        let law = &self.law;
        let i = inp.current;
        if !i.abs_within(law.current_max) {
            return false;
        }
        let dm = inp.demand;
        if self.ramp_settled && dm == self.settled_demand {
            let Some(w) = self.fast_wsp::<WSP>(inp.speed, self.iref) else {
                return false;
            };
            if !self.fast_pi(self.iref.sat_sub(i)) {
                return false;
            }
            self.fast_wsp_commit(w);
            return true;
        }
        if !dm.abs_within(law.demand_max) {
            return false;
        }
        let target = dm.mul_c_small(law.demand_to_iref);
        let delta = target.sat_sub(self.iref);
        if !delta.abs_within(law.iref_step) {
            return false;
        }
        let iref = self.iref.sat_add(delta);
        let Some(w) = self.fast_wsp::<WSP>(inp.speed, iref) else {
            return false;
        };
        if !self.fast_pi(iref.sat_sub(i)) {
            return false;
        }
        self.fast_wsp_commit(w);
        self.ramp_settled = iref == target;
        self.settled_demand = dm;
        self.iref = iref;
        true
    }

    /// The protection's fast step: `None` on a clamp, NaN or a detection; else what
    /// [`Self::fast_wsp_commit`] stores.
    #[inline(always)]
    fn fast_wsp<const WSP: bool>(&self, speed: T, iref: T) -> Option<Option<(T, T)>> {
        if !WSP {
            return Some(None);
        }
        let law = &self.law;
        if !speed.abs_within(law.speed_max) {
            return None;
        }
        let w_ref = self.wsp.w_ref;
        let slip = speed.sat_sub(w_ref);
        let dw = speed.sat_sub(self.wsp.w_prev);
        if law.wsp.detects(w_ref, slip, dw, iref, law.iref_step) {
            return None;
        }
        Some(Some((speed, slip)))
    }

    /// Commits [`Self::fast_wsp`]'s step: what `Wsp::process` stores while it does not act.
    #[inline(always)]
    fn fast_wsp_commit(&mut self, w: Option<(T, T)>) {
        if let Some((speed, slip)) = w {
            self.wsp.w_prev = speed;
            self.wsp.slip_prev = slip;
            self.wsp.known = self.wsp.w_ref != T::ZERO;
            self.wsp_acting = false;
        }
    }

    /// The fast PI on `e`: `false`, nothing changed, if the integrator or output clamp would engage.
    #[inline(always)]
    fn fast_pi(&mut self, e: T) -> bool {
        let law = &self.law;
        let mut residue = self.pi_state.residue;
        let integ =
            self.pi_state
                .integ
                .sat_add(e.mul_c_acc_shr(law.pi.ki, law.pi.ki_shift, &mut residue));
        let (u_min, u_max) = (law.pi.u_min, law.pi.u_max);
        if !integ.within(u_min, u_max) {
            return false;
        }
        let u = e.mul_pre(self.kp_pre).sat_add(integ);
        if !u.within(u_min, u_max) {
            return false;
        }
        self.i_err = e;
        self.pi_state = PiState { integ, residue };
        self.out.voltage = u;
        true
    }

    #[inline(never)]
    fn general_tick(&mut self, inp: &Inputs<T>) -> Outputs<T> {
        self.counters.ticks = self.counters.ticks.wrapping_add(1);
        let mut ev = 0u32;
        if self.yaw_phase == 0 {
            self.yaw_phase = self.law.yaw_divisor - 1;
            self.counters.yaw_steps = self.counters.yaw_steps.wrapping_add(1);
            ev = self.yaw_general(inp.y_dot);
        } else {
            self.yaw_phase -= 1;
        }
        if self.traction_phase == 0 {
            self.traction_phase = self.law.traction_divisor - 1;
            self.counters.traction_steps = self.counters.traction_steps.wrapping_add(1);
            ev |= self.traction_general(inp);
        } else {
            self.traction_phase -= 1;
        }
        if ev != 0 {
            self.counters.record(ev);
        }
        self.events = TickEvents(ev);
        self.refresh();
        self.out
    }

    /// [`Self::yaw_step`], one copy for both paths; returns its events.
    #[inline(never)]
    fn yaw_general(&mut self, y_dot: T) -> u32 {
        let mut ev = 0;
        self.yaw_step(y_dot, &mut ev);
        ev
    }

    /// [`Self::traction_step`], one copy for both paths; returns its events.
    #[inline(never)]
    fn traction_general(&mut self, inp: &Inputs<T>) -> u32 {
        let mut ev = 0;
        self.ramp_settled = false;
        self.traction_step(inp, &mut ev);
        ev
    }

    /// Tick on wire codes: decode, [`Self::tick`], encode.
    #[inline]
    pub fn tick_codes(&mut self, inp: &InputCodes) -> OutputCodes {
        let i = self.law.codec.decode(inp);
        let o = self.tick(&i);
        self.law.codec.encode(&o)
    }

    /// Sanitise and clamp an input; events at bits `bit` (invalid) and `bit + 1` (clamped).
    #[inline(always)]
    fn input(x: T, max: T, bit: u32, ev: &mut u32) -> T {
        let (x, bad) = x.sanitize();
        let (x, sat) = x.limit(T::ZERO.sat_sub(max), max);
        *ev |= ((bad as u32) | ((sat as u32) << 1)) << bit;
        x
    }

    #[inline(always)]
    fn yaw_step(&mut self, y_dot: T, ev: &mut u32) {
        let law = &self.law;
        let y = Self::input(y_dot, law.y_dot_max, event::Y_DOT, ev);
        // x = y + alpha (y - y_prev) as two adds of (y - y_prev) alpha/2, so the coefficient
        // stays in Q1.31; clamped to 2 pu (the range analysis), counted with the y' clamps.
        let d = y.sat_sub(self.last_y_dot).mul_c(law.predict_half);
        let (x, sat) = y
            .sat_add(d)
            .sat_add(d)
            .limit(T::ZERO.sat_sub(law.y_dot_pred_max), law.y_dot_pred_max);
        *ev |= (sat as u32) << (event::Y_DOT + 1);
        self.last_y_dot = y;
        let raw = match self.mode {
            YawMode::Passive => T::ZERO,
            YawMode::Gain => x.mul_c(law.gain),
            YawMode::Lead => {
                let d = law.lead.advance(&mut self.lead_state, x);
                if self.wsp.sched {
                    d.sat_sub(self.lead_state.z.mul_c(law.wsp.lead_rho))
                        .mul_c(law.wsp.lead_k_hf)
                } else {
                    d.mul_c(law.lead.k_hf)
                }
            }
        };
        let raw = if self.slewing {
            let step = law.torque_step;
            let (d, limited) = raw
                .sat_sub(self.out.yaw_torque)
                .limit(T::ZERO.sat_sub(step), step);
            self.slewing = limited;
            self.out.yaw_torque.sat_add(d)
        } else {
            raw
        };
        // The torque limit, ramped to 0 in the safe state and back; either clamp is a saturation.
        let lim = if self.safe {
            self.torque_lim
                .sat_sub(law.torque_step)
                .limit(T::ZERO, law.torque_max)
                .0
        } else if self.torque_lim != law.torque_max {
            self.torque_lim
                .sat_add(law.torque_step)
                .limit(T::ZERO, law.torque_max)
                .0
        } else {
            law.torque_max
        };
        self.torque_lim = lim;
        let (t, sat) = raw.limit(T::ZERO.sat_sub(lim), lim);
        *ev |= (sat as u32) << event::TORQUE;
        self.out.yaw_torque = t;
    }

    #[inline(always)]
    fn traction_step(&mut self, inp: &Inputs<T>, ev: &mut u32) {
        let law = &self.law;
        if !self.traction {
            let w = Self::input(inp.speed, law.speed_max, event::SPEED, ev);
            self.out.voltage = w.mul_c(law.back_emf).limit(law.pi.u_min, law.pi.u_max).0;
            self.armed = false;
            self.i_err = T::ZERO;
            return;
        }
        let i = Self::input(inp.current, law.current_max, event::CURRENT, ev);
        let d = Self::input(inp.demand, law.demand_max, event::DEMAND, ev);
        if !self.armed {
            let w = Self::input(inp.speed, law.speed_max, event::SPEED, ev);
            law.pi.preset(&mut self.pi_state, w.mul_c(law.back_emf));
            self.wsp.w_prev = w;
            self.armed = true;
        }
        let (target, step) = if self.safe {
            (T::ZERO, law.iref_safe_step)
        } else {
            (d.mul_c(law.demand_to_iref), law.iref_step)
        };
        let delta = target
            .sat_sub(self.iref)
            .limit(T::ZERO.sat_sub(step), step)
            .0;
        self.iref = self.iref.sat_add(delta);
        let mut iref = self.iref;
        self.wsp_acting = false;
        if self.wsp_on & !self.safe {
            let w = Self::input(inp.speed, law.speed_max, event::SPEED, ev);
            let (r, acting, new) = law.wsp.process(&mut self.wsp, w, iref, law.iref_step);
            iref = r;
            self.wsp_acting = acting;
            *ev |= ((acting as u32) << event::WSP_ACTING) | ((new as u32) << event::WSP_STARTED);
        } else {
            self.wsp.active = false;
            self.wsp.sched = false;
        }
        let e = iref.sat_sub(i);
        self.i_err = e;
        let (u, f) = law.pi.process_flags(&mut self.pi_state, e);
        *ev |= ((f.integ as u32) << event::INTEGRATOR) | ((f.output as u32) << event::VOLTAGE);
        self.out.voltage = u;
    }
}
