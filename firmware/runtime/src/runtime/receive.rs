//! The receive side of [`Runtime`]: frames decoded, counted, applied or refused.

use wheelset_control::{Controller, InputCodes, MonitorState, SampleBits, ScheduleBits};
use wheelset_proto::{FrameError, Lateral, RefuseReason, Request, Sensor, YawMode};

use crate::validate;
use crate::{AccBits, Command, Config, Rates, Runtime, RxEvent, Status};

impl<T: SampleBits> Runtime<T> {
    /// Takes received bytes in any chunking. Never panics.
    pub fn receive(&mut self, bytes: &[u8]) {
        // Frame by frame, the decoder a field of `self` (a callback would copy its buffer).
        let mut rest = bytes;
        while !rest.is_empty() {
            let (r, more) = self.decoder.next_request(rest);
            rest = more;
            if let Some(r) = r {
                self.on_frame(r);
            }
        }
    }

    fn on_frame(&mut self, r: Result<Request, FrameError>) {
        let c = &mut self.counters;
        let m = match r {
            Ok(m) => m,
            Err(e) => {
                let n = match e {
                    FrameError::Crc => &mut c.rx_crc,
                    FrameError::Cobs => &mut c.rx_cobs,
                    FrameError::Version => &mut c.rx_version,
                    FrameError::Length => &mut c.rx_length,
                    FrameError::Postcard => &mut c.rx_postcard,
                };
                *n = n.wrapping_add(1);
                self.rx_error = true;
                self.note_rx_event(RxEvent::Rejected(e));
                return;
            }
        };
        if matches!(m, Request::Unexpected) {
            c.rx_unexpected = c.rx_unexpected.wrapping_add(1);
            return;
        }
        c.rx_ok = c.rx_ok.wrapping_add(1);
        // `CMD_REFUSED` marks the latest Config or Command; `RequestStatus`, a read, leaves it.
        if matches!(m, Request::Command(c) if c != Command::RequestStatus) {
            self.refused = false;
        }
        match m {
            Request::Sensor(s) => self.on_sensor(s),
            Request::Config(cfg) => self.on_config(&cfg),
            Request::Command(Command::ResetCounters) => {
                // The board's boot record and stack measurement are not counters.
                let keep = (c.boot_count, c.reset_cause, c.stack_peak);
                *c = Status::default();
                (c.boot_count, c.reset_cause, c.stack_peak) = keep;
                self.core.reset_counters();
                self.refuse_reason = RefuseReason::None;
            }
            Request::Command(Command::RequestStatus) => self.status_requested = true,
            Request::Command(Command::ClearFaults) => {
                self.fault_latched = false;
                self.alarm_safe = false;
            }
            Request::Command(c @ (Command::InjectStall | Command::InjectHardFault)) => {
                let ends = self.watchdog || c == Command::InjectHardFault;
                if cfg!(feature = "fault-inject") && ends {
                    self.injected = Some(c);
                } else {
                    self.refuse(RefuseReason::Unsupported);
                }
            }
            Request::Unknown => self.refuse(RefuseReason::UnknownRequest),
            Request::Unexpected => {}
        }
    }

    fn on_sensor(&mut self, s: Sensor) {
        let y_dot = match s.lateral {
            Lateral::Both {
                vel_um_s: v,
                acc_dmm_s2: a,
            } if self.leak_q32 != 0 => {
                if self.acc.is_none() {
                    self.vel_q32 = i64::from(v) << 32;
                }
                self.acc = Some(a);
                self.acc_ref_q32 = i64::from(v) << 32;
                (self.vel_q32 >> 32) as i32
            }
            Lateral::Velocity(v) | Lateral::Both { vel_um_s: v, .. } => {
                // A measured velocity also re-seeds the integrator (bumpless switch).
                self.acc = None;
                self.vel_q32 = i64::from(v) << 32;
                v
            }
            Lateral::Acceleration(a) => {
                self.acc = Some(a);
                self.acc_ref_q32 = 0;
                (self.vel_q32 >> 32) as i32
            }
        };
        if self.sample.is_some() && s.seq != self.seq.wrapping_add(1) {
            self.counters.seq_gaps = self.counters.seq_gaps.wrapping_add(1);
        }
        self.seq = s.seq;
        // The protection is the reference speed's only reader: converted only while it is on.
        if self.core.wsp_enabled() {
            self.core.set_v_ref_code(s.v_ref_mm_s);
        } else {
            self.v_ref_held = Some(s.v_ref_mm_s);
        }
        self.sample = Some(InputCodes {
            y_dot,
            current: s.i_a_ma,
            speed: s.omega_m_mrad_s,
            demand: s.demand_nm,
        });
        self.fresh = true;
    }

    #[inline(never)]
    fn on_config(&mut self, c: &Config) {
        let active = c.mode != YawMode::Passive;
        let checked = match &c.rates {
            Some(r) => self.apply_rates(r, c.hold_ticks, active),
            None if active && !self.yaw_ok => Err(RefuseReason::YawNotDesigned),
            None => validate::check_hold(c.hold_ticks, self.base_rate_hz()),
        };
        if let Err(why) = checked {
            self.refuse(why);
            return;
        }
        if c.enable && !self.enabled {
            // Re-enabled: the torque slews up from 0, the PI restarts from the back-EMF.
            self.core.continue_from(T::ZERO);
            self.core.set_traction(false);
        }
        self.core.set_mode(c.mode);
        self.core.set_traction(c.traction);
        self.core.set_wsp(c.wsp);
        if c.wsp {
            if let Some(code) = self.v_ref_held.take() {
                self.core.set_v_ref_code(code);
            }
        }
        self.monitor_safe = c.monitor_safe;
        self.enabled = c.enable;
        self.hold_ticks = c.hold_ticks;
        self.refused = false;
    }

    /// A refused request: counted, flagged, the reason kept; nothing else changes.
    fn refuse(&mut self, why: RefuseReason) {
        self.refused = true;
        self.counters.cmd_refused = self.counters.cmd_refused.wrapping_add(1);
        self.refuse_reason = why;
        self.counters.refuse_reason = why as u8;
        self.note_rx_event(RxEvent::Refused(why));
    }

    /// Validates `r` against this core and its designs, then restarts the core on it (the
    /// caller sets the modes and the protection after).
    #[inline(never)]
    fn apply_rates(
        &mut self,
        r: &Rates,
        hold_ticks: u16,
        active_yaw: bool,
    ) -> Result<(), RefuseReason> {
        if r.numeric != T::NUMERIC {
            return Err(RefuseReason::Numeric);
        }
        if r.fingerprint != self.fingerprint {
            return Err(RefuseReason::Fingerprint);
        }
        if r.base_rate_hz > self.max_rate_hz {
            return Err(RefuseReason::BaseRate);
        }
        let design = validate::check_rates(r, &self.designs.rates)?;
        validate::check_hold(hold_ticks, r.base_rate_hz)?;
        let yaw_ok = self.designs.yaw.get(design).copied().unwrap_or(false);
        if active_yaw && !yaw_ok {
            return Err(RefuseReason::YawNotDesigned);
        }
        let bits = RefuseReason::Bits;
        let (g, l) = AccBits {
            gain_q32: r.acc_gain_q32,
            leak_q32: r.acc_leak_q32,
        }
        .check()
        .map_err(|_| bits)?;
        let law = self
            .core
            .compiled()
            .with_schedule(&ScheduleBits {
                base_rate_hz: r.base_rate_hz,
                yaw_divisor: r.yaw_div,
                traction_divisor: r.traction_div,
                delay_ticks: r.delay_ticks,
                kappa: u64::from(r.kappa),
                lead_k_hf: u64::from(r.lead_k_hf),
                wsp_lead_k_hf: u64::from(r.wsp_lead_k_hf),
                kp: u64::from(r.kp),
                ki_shift: r.ki_shift,
                ki: u64::from(r.ki),
                predict_half: u64::from(r.predict_half),
                iref_step: u64::from(r.iref_step),
                iref_safe_step: u64::from(r.iref_safe_step),
                torque_step: u64::from(r.torque_step),
            })
            .map_err(|_| bits)?;
        let t_psi = self.core.outputs().yaw_torque;
        // The safe state and its torque limit go on (a boot-held zero limit stays zero).
        let (safe, limit) = (self.core.is_safe(), self.core.torque_limit());
        self.core = Controller::new(&law);
        self.v_ref_held = None;
        self.core.continue_from(t_psi);
        self.monitor.retime(r.base_rate_hz);
        self.mon = MonitorState::default();
        self.acc_gain_q32 = g;
        self.leak_q32 = l;
        self.core.set_safe_at(safe, limit);
        self.yaw_ok = yaw_ok;
        Ok(())
    }
}
