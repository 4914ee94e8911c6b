//! The [`Runtime`]: its state, start, tick and accessors (the receive side: `receive`).

mod receive;

use crate::Designs;
use wheelset_control::{
    Compiled, Controller, InputCodes, Monitor, MonitorState, Sample, SampleBits, TickEvents,
};
use wheelset_proto::{encode, Decoder, FrameError, Message, RefuseReason};

use crate::{
    AccBits, Actuation, Command, Flags, HoldPolicy, RuntimeBits, RuntimeConfig, RuntimeError,
    SafeChange, Status, TX_CAPACITY,
};

/// A receive event worth a log record: a rejected frame or a refused request.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum RxEvent {
    /// A frame rejected by the decoder: CRC, COBS, version, length or postcard.
    Rejected(FrameError),
    /// A Config or Command refused, with the reason (the Status `refuse_reason`).
    Refused(RefuseReason),
}

/// What the device drives when it has nothing valid to say (before any sample, and the
/// panic handler's frame): zero torque, zero voltage, flag `SAFE` (the tick sets its own).
pub const SAFE_ACTUATION: Actuation = Actuation {
    seq_echo: 0,
    tick: 0,
    exec: 0,
    flags: Flags(Flags::SAFE),
    t_psi_dnm: 0,
    u_a_cv: 0,
};

/// Control core + frame decoder + fault policy + counters. See the crate docs.
#[derive(Debug, Clone)]
pub struct Runtime<T: Sample> {
    core: Controller<T>,
    /// [`CompiledBits::fingerprint`] of the core's rate-independent part.
    fingerprint: u32,
    designs: Designs,
    /// An active yaw law is designed at the current rates (the boot core's: yes).
    yaw_ok: bool,
    hold_ticks: u16,
    decoder: Decoder,
    sample: Option<InputCodes>,
    /// The reference speed code held while the protection (its only reader) is off.
    v_ref_held: Option<i32>,
    /// The latest sample carried only `y''` (codes of 0.1 mm/s^2): integrate it.
    acc: Option<i32>,
    /// `y'` estimate from `y''`, um/s in Q32.
    vel_q32: i64,
    /// What the estimate washes out towards, um/s in Q32: 0 or the measured `y'` (`Both`).
    acc_ref_q32: i64,
    /// [`AccBits`]' `gain_q32` and `leak_q32`, checked.
    acc_gain_q32: i64,
    leak_q32: i64,
    seq: u16,
    fresh: bool,
    hold: HoldPolicy,
    enabled: bool,
    rx_error: bool,
    refused: bool,
    refuse_reason: RefuseReason,
    rx_event: Option<RxEvent>,
    rx_events_after: u32,
    monitor: Monitor<T>,
    mon: MonitorState<T>,
    monitor_safe: bool,
    /// The safe state is held until `Command::ClearFaults` (an alarm, or a fault reset).
    alarm_safe: bool,
    fault_latched: bool,
    status_requested: bool,
    injected: Option<Command>,
    watchdog: bool,
    ticks: u32,
    max_rate_hz: u32,
    counters: Status,
    tx: [u8; TX_CAPACITY],
}

impl<T: SampleBits> Runtime<T> {
    /// Builds the core and an idle runtime ([`RuntimeBits::try_new`], [`Self::from_bits`]).
    pub fn try_new(cfg: RuntimeConfig) -> Result<Self, RuntimeError> {
        Self::from_bits(&RuntimeBits::try_new::<T>(&cfg)?)
    }

    /// An idle runtime running exactly `bits` (validated; integer work): the device's start.
    pub fn from_bits(bits: &RuntimeBits) -> Result<Self, RuntimeError> {
        let base = bits.control.schedule.base_rate_hz;
        Self::with_core(
            &Compiled::from_bits(&bits.control)?,
            bits.control.fingerprint(),
            bits.acc,
            bits.hold_ticks,
            bits.enable,
            Monitor::from_bits(&bits.monitor, base)?,
            &bits.designs,
        )
    }

    /// An idle runtime on an already validated core with fingerprint `fingerprint`: the start
    /// from build-time constants ([`Self::from_bits`] after validation).
    pub fn with_core(
        law: &Compiled<T>,
        fingerprint: u32,
        acc: AccBits,
        hold_ticks: u16,
        enable: bool,
        monitor: Monitor<T>,
        designs: &Designs,
    ) -> Result<Self, RuntimeError> {
        let core = Controller::new(law);
        let (acc_gain_q32, leak_q32) = acc.check()?;
        Ok(Self {
            core,
            fingerprint,
            designs: *designs,
            yaw_ok: true,
            hold_ticks,
            decoder: Decoder::new(),
            sample: None,
            v_ref_held: None,
            acc: None,
            vel_q32: 0,
            acc_ref_q32: 0,
            acc_gain_q32,
            leak_q32,
            seq: 0,
            fresh: false,
            hold: HoldPolicy::default(),
            enabled: enable,
            rx_error: false,
            refused: false,
            refuse_reason: RefuseReason::None,
            rx_event: None,
            rx_events_after: 0,
            monitor,
            mon: MonitorState::default(),
            monitor_safe: false,
            alarm_safe: false,
            fault_latched: false,
            status_requested: false,
            injected: None,
            watchdog: false,
            ticks: 0,
            max_rate_hz: u32::MAX,
            counters: Status::default(),
            tx: [0; TX_CAPACITY],
        })
    }

    /// The board's link limit: a Config above `max_rate_hz` is refused (`u32::MAX`: none).
    pub fn set_link_limit(&mut self, max_rate_hz: u32) {
        self.max_rate_hz = max_rate_hz;
    }

    /// The board runs a watchdog (default `false`): only then is [`Command::InjectStall`]
    /// honoured, since without one a stalled task never ends.
    pub fn set_watchdog(&mut self, running: bool) {
        self.watchdog = running;
    }

    /// One base-rate tick: the Actuation frame, then a Status frame if requested;
    /// `last_exec` is the previous tick's execution time. Never panics.
    pub fn tick(&mut self, last_exec: u32) -> &[u8] {
        self.ticks = self.ticks.wrapping_add(1);
        let fresh = core::mem::replace(&mut self.fresh, false);
        let mut flags = Flags::default();
        let c = &mut self.counters;
        c.ticks = c.ticks.wrapping_add(1);
        let step = self.hold.step(
            fresh,
            self.sample.is_some(),
            self.hold_ticks,
            self.alarm_safe,
        );
        if step.holding {
            // Held, in the safe state or not: HOLDING and `held_ticks` alike.
            c.held_ticks = c.held_ticks.wrapping_add(1);
            flags.set(Flags::HOLDING, true);
        }
        if let Some(change) = step.change {
            let enter = change == SafeChange::Enter;
            self.core.set_safe(enter);
            if enter {
                c.safe_entries = c.safe_entries.wrapping_add(1);
            } else {
                c.safe_exits = c.safe_exits.wrapping_add(1);
                if let Some(s) = self.sample {
                    // Bumpless restart of traction from the back-EMF, reference ramping up from zero.
                    let speed = self.core.compiled().codec().decode(&s).speed;
                    self.core.preset_back_emf(speed);
                }
            }
        }
        if step.safe {
            c.safe_ticks = c.safe_ticks.wrapping_add(1);
            flags.set(Flags::SAFE, true);
        }
        if let (Some(a), Some(s)) = (self.acc, self.sample.as_mut()) {
            // Integrate on every tick with the latest y'' (held when frames are missing).
            let v = {
                let err = self.vel_q32.saturating_sub(self.acc_ref_q32);
                let leak = ((i128::from(err) * i128::from(self.leak_q32)) >> 32) as i64;
                let step = i64::from(a).saturating_mul(self.acc_gain_q32);
                let lim = i64::from(i32::MAX) << 32;
                self.vel_q32 = self
                    .vel_q32
                    .saturating_sub(leak)
                    .saturating_add(step)
                    .clamp(-lim, lim);
                (self.vel_q32 >> 32) as i32
            };
            s.y_dot = v;
        }
        let inp = self.sample.map(|s| self.core.compiled().codec().decode(&s));
        if let Some(inp) = &inp {
            let commanding = self.enabled
                && !self.hold.is_safe()
                && self.core.mode() != wheelset_control::YawMode::Passive;
            let ev = self.monitor.tick(
                &mut self.mon,
                inp.y_dot,
                commanding,
                self.core.applied_ref(),
            );
            if ev.hunting_rose | ev.actuator_rose {
                self.on_alarm(ev.hunting_rose, ev.actuator_rose, false);
            }
            flags.set(Flags::HUNTING, ev.hunting);
            flags.set(Flags::ACTUATOR_FAULT, ev.actuator);
        }
        let mut events = TickEvents::NONE;
        let (t_psi, u_a) = match (inp, self.enabled) {
            (Some(mut inp), true) => {
                if self.hold.is_safe() {
                    // Stale current: do not integrate it (policy item 3).
                    self.core.preset_back_emf(inp.speed);
                    inp.current = T::ZERO;
                }
                let out = self.core.tick(&inp);
                events = self.core.tick_events();
                if self.core.traction_stepped()
                    && self
                        .monitor
                        .drive_step(&mut self.mon, self.core.current_error())
                {
                    self.on_alarm(false, false, true);
                }
                let o = self.core.compiled().codec().encode(&out);
                (o.yaw_torque, o.voltage)
            }
            (Some(inp), false) => {
                // Outputs disabled: zero torque, zero current (the back-EMF; 0 V would short the motor).
                let speed = inp.speed;
                let o = self
                    .core
                    .compiled()
                    .codec()
                    .encode(&wheelset_control::Outputs {
                        yaw_torque: T::ZERO,
                        voltage: self.core.back_emf(speed),
                    });
                (o.yaw_torque, o.voltage)
            }
            (None, _) => (SAFE_ACTUATION.t_psi_dnm, SAFE_ACTUATION.u_a_cv),
        };
        if events.any() {
            self.count_events(events);
        }
        flags.set(Flags::ENABLED, self.enabled);
        flags.set(Flags::YAW_SAT, events.yaw_saturated());
        flags.set(Flags::TRACTION_SAT, events.traction_saturated());
        flags.set(Flags::NO_SAMPLE, self.sample.is_none());
        flags.set(
            Flags::RX_ERROR,
            core::mem::replace(&mut self.rx_error, false),
        );
        flags.set(Flags::CMD_REFUSED, self.refused);
        flags.set(Flags::WHEEL_SLIP, self.core.wheel_slip());
        flags.set(Flags::DRIVE_OSC, self.mon.ev.drive);
        flags.set(Flags::FAULT_LATCHED, self.fault_latched);
        self.counters.flags = flags;
        let act = Actuation {
            seq_echo: self.seq,
            tick: self.ticks as u16,
            exec: last_exec,
            flags,
            t_psi_dnm: t_psi,
            u_a_cv: u_a,
        };
        // MAX_FRAME always fits (the proto tests prove every message encodes within it).
        let mut n = encode(&Message::Actuation(act), &mut self.tx).unwrap_or(0);
        if core::mem::replace(&mut self.status_requested, false) {
            if let Some(rest) = self.tx.get_mut(n..) {
                n += encode(&Message::Status(self.counters), rest).unwrap_or(0);
            }
        }
        self.tx.get(..n).unwrap_or(&[])
    }

    /// The core's events into the runtime's counters (cold: normal running has none).
    #[cold]
    #[inline(never)]
    fn count_events(&mut self, ev: TickEvents) {
        let c = &mut self.counters;
        c.yaw_sat = c.yaw_sat.wrapping_add(u32::from(ev.yaw_saturated()));
        c.traction_sat = c
            .traction_sat
            .wrapping_add(u32::from(ev.traction_saturated()));
        c.input_clamped = c.input_clamped.wrapping_add(ev.inputs());
        c.wsp_ticks = c.wsp_ticks.wrapping_add(u32::from(ev.wsp_acting()));
        c.wsp_events = c.wsp_events.wrapping_add(u32::from(ev.wsp_started()));
    }

    /// A monitor alarm rose: counted, latched, and with `monitor_safe` the safe state held.
    #[inline(never)]
    fn on_alarm(&mut self, hunting: bool, actuator: bool, drive: bool) {
        let c = &mut self.counters;
        c.hunt_alarms = c.hunt_alarms.wrapping_add(u32::from(hunting));
        c.act_alarms = c.act_alarms.wrapping_add(u32::from(actuator));
        c.drive_alarms = c.drive_alarms.wrapping_add(u32::from(drive));
        // 0 means "none": an alarm on the tick whose count wrapped to 0 is recorded as 1.
        let at = c.ticks.max(1);
        if c.first_alarm_tick == 0 {
            c.first_alarm_tick = at;
        }
        if drive && c.first_drive_alarm_tick == 0 {
            c.first_drive_alarm_tick = at;
        }
        self.fault_latched = true;
        if self.monitor_safe {
            self.alarm_safe = true;
        }
    }

    /// Starts the counters and the tick count at `start` (a host soak crosses the wrap).
    pub fn preset_counters(&mut self, start: &Status) {
        self.counters = Status {
            flags: self.counters.flags,
            ..*start
        };
        self.ticks = start.ticks;
    }

    /// The counters.
    pub fn counters(&self) -> &Status {
        &self.counters
    }

    /// The board's own counters since its previous call (added, wrapping).
    pub fn note_board(&mut self, late: u32, missed: u32, rx_overrun: u32, tx_dropped: u32) {
        let c = &mut self.counters;
        c.ticks_late = c.ticks_late.wrapping_add(late);
        c.ticks_missed = c.ticks_missed.wrapping_add(missed);
        c.rx_overrun = c.rx_overrun.wrapping_add(rx_overrun);
        c.tx_dropped = c.tx_dropped.wrapping_add(tx_dropped);
    }

    /// The board's boot record, once before the first tick. A watchdog or fault reset latches
    /// [`Flags::FAULT_LATCHED`] and holds zero torque until [`crate::Command::ClearFaults`]: a
    /// device that has just crashed drives nothing until acknowledged.
    pub fn set_boot(&mut self, boot_count: u32, reset_cause: u8) {
        self.counters.boot_count = boot_count;
        self.counters.reset_cause = reset_cause;
        if matches!(
            reset_cause,
            wheelset_proto::reset_cause::WATCHDOG | wheelset_proto::reset_cause::FAULT
        ) {
            self.fault_latched = true;
            self.alarm_safe = true;
            self.core.set_safe_at(true, T::ZERO);
        }
    }

    /// The fault injection received since the last call (`fault-inject` only).
    pub fn take_injected(&mut self) -> Option<Command> {
        self.injected.take()
    }

    /// The first receive event since the previous call and the number after it.
    pub fn take_rx_event(&mut self) -> Option<(RxEvent, u32)> {
        let e = self.rx_event.take()?;
        Some((e, core::mem::take(&mut self.rx_events_after)))
    }

    /// Keep `e` for [`Self::take_rx_event`] if none is held, else count it.
    pub(crate) fn note_rx_event(&mut self, e: RxEvent) {
        if self.rx_event.is_none() {
            self.rx_event = Some(e);
        } else {
            self.rx_events_after = self.rx_events_after.wrapping_add(1);
        }
    }

    /// The stack's high-water mark in bytes, as the board measured it.
    pub fn set_stack_peak(&mut self, bytes: u32) {
        self.counters.stack_peak = bytes;
    }

    /// The control core (read only: coefficients, states, its own counters).
    pub fn core(&self) -> &Controller<T> {
        &self.core
    }

    /// The base (tick) rate in force, Hz.
    pub fn base_rate_hz(&self) -> u32 {
        self.core.compiled().base_rate_hz()
    }

    /// Ticks bridged by the held sample before the safe state, in force.
    pub fn hold_ticks(&self) -> u16 {
        self.hold_ticks
    }

    /// In the safe state?
    pub fn is_safe(&self) -> bool {
        self.hold.is_safe()
    }

    /// Why the latest refused Config or Command was refused.
    pub fn refuse_reason(&self) -> RefuseReason {
        self.refuse_reason
    }
}
