//! The closed-loop adapter: a device behind any [`Transport`] as the plant's
//! [`SampledController`]: at `t_k` a Sensor frame out, until `t_k + T` receive, then the
//! latest actuation applied (ZOH; before the first, zero torque and the back-EMF voltage
//! `K_m theta_m'`). With `d` ticks of delay ([`LoopSetup::delay_ticks`]) sample `k` acts
//! from `t_k + d T`; [`Transport::pipelined`]: two exchanges in flight
//! ([`SampledController::take_deferred`]). See docs/closed-loop.md.

use indicatif::ProgressBar;
use wheelset_control::InputCodes;
use wheelset_proto::{
    encode, encode_vec, Actuation, Command, Config, Decoder, Flags, FrameError, Lateral,
    LateralSensing, Message, Sensor, SensorSi, Status, MAX_FRAME,
};

use crate::drive::drive;
use crate::transport::{Transport, TransportError};
use wheelset_plant::control::{Actuation as SiActuation, Measurements, SampledController};
use wheelset_plant::scenario::Scenario;
use wheelset_plant::sim::{SimError, Trajectory};

/// Status requests [`DeviceController::finish`] makes before it gives up.
pub const STATUS_TRIES: usize = 20;

/// Periods of receiving after each status request.
pub const STATUS_WAIT_PERIODS: u64 = 3;

/// One Actuation frame as the host received it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RxActuation {
    /// Arrival of its last byte on the transport's clock, ns.
    pub at_ns: u64,
    /// Its length on the wire, bytes (delimiter included).
    pub wire_bytes: usize,
    /// The sample index `k` it echoes (unwrapped `seq_echo - 1`), if any sample was used.
    pub echo: Option<u64>,
    /// The frame.
    pub frame: Actuation,
}

/// One control period as the host saw it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Period {
    /// Sample instant `t_k`, ns.
    pub t_ns: u64,
    /// Bytes of the Sensor frame sent.
    pub sensor_bytes: usize,
    /// Arrival of the actuation echoing this period's sample, if it came by the deadline.
    pub echo_at_ns: Option<u64>,
}

/// One period's link record (the CSV's link columns).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LinkSample {
    /// Sample instant, ns.
    pub t_ns: u64,
    /// Sequence number of the Sensor frame sent at `t_ns`.
    pub seq: u16,
    /// `seq_echo` of the actuation in force from `t_ns + T`.
    pub seq_echo: u16,
    /// Age of that actuation's sample, periods: `seq - seq_echo`.
    pub age: u16,
    /// Its flags (the bits of [`Flags`]).
    pub flags: u16,
    /// A new valid Actuation frame arrived in this period.
    pub fresh: bool,
}

/// The link columns appended to the standard CSV.
pub const LINK_COLUMNS: [&str; 5] = ["seq", "seq_echo", "frame_age", "flags", "fresh"];

/// Host-side frame counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HostCounts {
    /// Frames the host sent (Config, Sensor, Command).
    pub sent: u64,
    /// Bytes the host sent.
    pub bytes_sent: u64,
    /// Valid frames the host decoded, up to and including the Status frame.
    pub received: u64,
    /// Frames the host's decoder rejected, up to the Status frame.
    pub rejected: u64,
    /// Bytes received.
    pub bytes_received: u64,
    /// Inputs clamped while quantising to wire counts.
    pub clamped: u64,
}

/// What a closed loop records besides the plant's trajectory.
#[derive(Debug, Default)]
pub struct LoopRecords {
    /// Every period.
    pub periods: Vec<Period>,
    /// Every Actuation frame received, in order.
    pub actuations: Vec<RxActuation>,
    /// One link record per period.
    pub log: Vec<LinkSample>,
    /// The sensor samples sent, in wire codes, one per period (velocity sensing only).
    pub sent_codes: Vec<InputCodes>,
    /// Host-side counts.
    pub host: HostCounts,
    /// The device's counters, if its Status frame arrived.
    pub status: Option<Status>,
    /// The first transport error; the loop holds the last actuation after it.
    pub error: Option<TransportError>,
    /// The first actuation after the Config frame carried `CMD_REFUSED`.
    pub config_refused: bool,
    /// When `Command::ClearFaults` went out, ns.
    pub clear_faults_sent_ns: Option<u64>,
    /// When `Command::InjectStall` went out, ns.
    pub stall_sent_ns: Option<u64>,
    /// Device resets seen (tick counter back, or `FAULT_LATCHED` at a lower tick).
    pub device_resets: u32,
    /// When the first reset was seen, ns.
    pub first_reset_ns: Option<u64>,
}

/// The device as a sampled controller of the plant, through a transport.
pub struct DeviceController<'a> {
    tr: &'a mut dyn Transport,
    /// Back-EMF gain, V s/rad.
    k_m: f64,
    setup: LoopSetup<'a>,
    deferred: bool,
    /// What the loop records.
    pub rec: LoopRecords,
    run: RunState,
}

#[derive(Default)]
struct RunState {
    config_sent: bool,
    decoder: Decoder,
    k: u64,
    held: Option<(SiActuation, Actuation)>,
    /// Actuations received and not yet in force, with the sample each echoes, in order.
    early: std::collections::VecDeque<(Option<u64>, SiActuation, Actuation)>,
    /// The sample count of the step whose actuation is being received (`answer`).
    answering: u64,
    fresh: bool,
    /// The frames of one [`DeviceController::receive`]: arrival, bytes on the wire, result.
    rx_frames: Vec<(u64, usize, Result<Message, FrameError>)>,
    frame_bytes: usize,
    config_echo_pending: bool,
    status_seen: bool,
    last_tick: u16,
    last_latched: bool,
    /// The steps sent whose actuation is not taken yet, oldest first (two in flight).
    awaiting: std::collections::VecDeque<Awaiting>,
}

/// A step whose actuation is still to be taken ([`DeviceController::take_deferred`]).
#[derive(Debug, Clone, Copy)]
struct Awaiting {
    /// Its sample instant, ns.
    t_ns: u64,
    /// Its sample count (1 for the first sample).
    k: u64,
    /// The measured motor speed, rad/s (for the back-EMF voltage before the first).
    w_m: f64,
}

impl<'a> DeviceController<'a> {
    /// The device behind `tr` as `setup` says (its `yaw_spring` and `label` are the
    /// plant's); `k_m` (V s/rad): back-EMF gain.
    pub fn new(tr: &'a mut dyn Transport, k_m: f64, setup: LoopSetup<'a>) -> Self {
        Self {
            deferred: tr.pipelined(),
            tr,
            k_m,
            setup,
            rec: LoopRecords::default(),
            run: RunState::default(),
        }
    }

    fn delay_ticks(&self) -> u64 {
        u64::from(self.setup.delay_ticks.max(1))
    }

    /// Reserves the per-period records for `periods` periods.
    pub fn reserve(&mut self, periods: usize) {
        self.rec.log.reserve(periods);
        if self.setup.records == Records::All {
            self.rec.periods.reserve(periods);
            self.rec.actuations.reserve(periods);
            self.rec.sent_codes.reserve(periods);
        }
    }

    fn send(&mut self, t_ns: u64, m: &Message) {
        let Ok(frame) = encode_vec(m) else { return };
        self.send_frame(t_ns, &frame);
    }

    /// Sends one encoded frame (delimiter included) and counts it.
    fn send_frame(&mut self, t_ns: u64, frame: &[u8]) {
        let n = frame.len();
        self.rec.host.sent += 1;
        self.rec.host.bytes_sent += n as u64;
        if self.rec.error.is_none() {
            if let Err(e) = self.tr.send(t_ns, frame) {
                self.rec.error = Some(e);
            }
        }
    }

    fn receive(&mut self, deadline_ns: u64) {
        if self.rec.error.is_some() {
            return;
        }
        let mut frames = std::mem::take(&mut self.run.rx_frames);
        frames.clear();
        let (dec, frame_bytes, received) = (
            &mut self.run.decoder,
            &mut self.run.frame_bytes,
            &mut self.rec.host.bytes_received,
        );
        if let Err(e) = self.tr.recv_frames(deadline_ns, dec, &mut |at, taken, r| {
            *received += taken as u64;
            *frame_bytes += taken;
            if let Some(r) = r {
                frames.push((at, std::mem::take(frame_bytes), r));
            }
        }) {
            self.rec.error = Some(e);
        }
        for &(at, n, r) in &frames {
            self.on_frame(at, n, r);
        }
        self.run.rx_frames = frames;
    }

    fn on_frame(&mut self, at_ns: u64, wire_bytes: usize, r: Result<Message, FrameError>) {
        // Counted up to the Status, as the Status's counters are.
        if !self.run.status_seen {
            match r {
                Ok(_) => self.rec.host.received += 1,
                Err(_) => self.rec.host.rejected += 1,
            }
        }
        match r {
            Ok(Message::Actuation(a)) => {
                // Unwrap the 16-bit echo against the host's own sample count.
                let echo = (a.seq_echo != 0 || self.run.k > 0xffff).then(|| {
                    let diff = (self.run.k as u16).wrapping_sub(a.seq_echo);
                    self.run.k.saturating_sub(u64::from(diff))
                });
                let echo = echo.map(|e| e.saturating_sub(1));
                if self.setup.records == Records::All {
                    self.rec.actuations.push(RxActuation {
                        at_ns,
                        wire_bytes,
                        echo,
                        frame: a,
                    });
                }
                self.note_tick(at_ns, &a);
                if std::mem::take(&mut self.run.config_echo_pending) {
                    self.rec.config_refused |= a.flags.has(Flags::CMD_REFUSED);
                }
                let si = a.to_si();
                let si = SiActuation {
                    t_psi: si.t_psi,
                    u_a: si.u_a,
                };
                // An answer to no sample (the Config's): the start-up output stands.
                if echo.is_some() || self.run.answering >= self.delay_ticks() {
                    self.run.early.push_back((echo, si, a));
                }
                // The period's echo, if it came by its deadline t_e + d T.
                let due = self.delay_ticks() * self.setup.period_ns;
                let p = echo.and_then(|e| self.rec.periods.get_mut(usize::try_from(e).ok()?));
                if let Some(p) = p.filter(|p| p.echo_at_ns.is_none() && at_ns <= p.t_ns + due) {
                    p.echo_at_ns = Some(at_ns);
                }
            }
            Ok(Message::Status(s)) => {
                self.rec.status = Some(s);
                self.run.status_seen = true;
            }
            _ => {}
        }
    }

    /// Watches the tick counter for a reset ([`Self::device_resets`]).
    fn note_tick(&mut self, at_ns: u64, a: &wheelset_proto::Actuation) {
        let latched = a.flags.has(Flags::FAULT_LATCHED);
        // Tick 0 is the safe frame of a handler (no tick ran), not a new boot's.
        if a.tick != 0 {
            let back = self.run.last_tick.wrapping_sub(a.tick);
            let went_back = a.tick < self.run.last_tick;
            if went_back && (back < 0x8000 || (latched && !self.run.last_latched)) {
                self.rec.device_resets += 1;
                self.rec.first_reset_ns.get_or_insert(at_ns);
                if self.setup.config.is_some() || self.setup.reset_config.is_some() {
                    self.run.config_sent = false;
                }
            }
            self.run.last_tick = a.tick;
            self.run.last_latched = latched;
        }
    }

    /// Ends the run at `t_ns`: fetches the Status, up to [`STATUS_TRIES`] requests.
    pub fn finish(&mut self, t_ns: u64) {
        let mut t = t_ns;
        for _ in 0..STATUS_TRIES {
            self.send(t, &Message::Command(Command::RequestStatus));
            for _ in 0..STATUS_WAIT_PERIODS {
                t += self.setup.period_ns;
                self.receive(t);
            }
            if self.run.status_seen || self.rec.error.is_some() {
                break;
            }
        }
        if let Some(pb) = &self.setup.progress {
            pb.finish_and_clear();
        }
    }
}

impl SampledController for DeviceController<'_> {
    fn period_ns(&self) -> u64 {
        self.setup.period_ns
    }

    fn step(&mut self, t_ns: u64, m: &Measurements) -> SiActuation {
        if let (Some(cfg), false) = (
            self.setup.config.or(self.setup.reset_config),
            self.run.config_sent,
        ) {
            self.run.config_sent = true;
            self.run.config_echo_pending = true;
            self.send(t_ns, &Message::Config(cfg));
        }
        self.run.k += 1;
        let sample = SensorSi {
            y_dot: m.yd_mps,
            y_ddot: m.ydd_mps2,
            i_a: m.i_a,
            w_m: m.w_m,
            demand_nm: m.demand_nm,
            v_ref: m.v_mps,
        };
        let q = Sensor::from_si(self.run.k as u16, t_ns, &sample, self.setup.lateral);
        self.rec.host.clamped += u64::from(q.clamped);
        let sensor = q.msg;
        let all = self.setup.records == Records::All;
        if let (Lateral::Velocity(v), true) = (sensor.lateral, all) {
            self.rec.sent_codes.push(InputCodes {
                y_dot: v,
                current: sensor.i_a_ma,
                speed: sensor.omega_m_mrad_s,
                demand: sensor.demand_nm,
            });
        }
        let mut frame = [0u8; MAX_FRAME];
        let n = encode(&Message::Sensor(sensor), &mut frame).unwrap_or(0);
        self.send_frame(t_ns, frame.get(..n).unwrap_or(&[]));
        if all {
            self.rec.periods.push(Period {
                t_ns,
                sensor_bytes: n,
                echo_at_ns: None,
            });
        }
        // After the Sensor frame, so this period's sample is on time.
        let due =
            |at: Option<u64>, sent: Option<u64>| at.is_some_and(|t| t_ns >= t) && sent.is_none();
        if due(self.setup.clear_faults_at_ns, self.rec.clear_faults_sent_ns) {
            self.rec.clear_faults_sent_ns = Some(t_ns);
            self.send(t_ns, &Message::Command(Command::ClearFaults));
        }
        if due(self.setup.stall_at_ns, self.rec.stall_sent_ns) {
            self.rec.stall_sent_ns = Some(t_ns);
            self.send(t_ns, &Message::Command(Command::InjectStall));
        }
        if let Some(pb) = &self.setup.progress {
            if self.run.k.is_multiple_of(1024) {
                pb.set_position(t_ns / 1_000_000);
            }
        }
        let step = Awaiting {
            t_ns,
            k: self.run.k,
            w_m: m.w_m,
        };
        if self.deferred {
            // Taken at `t_ns + T` (`take_deferred`), after the next sample went out.
            self.run.awaiting.push_back(step);
            return SiActuation::default();
        }
        self.answer(step)
    }

    fn defers(&self) -> bool {
        self.deferred
    }

    fn take_deferred(&mut self, _due_ns: u64) -> SiActuation {
        match self.run.awaiting.front().copied() {
            Some(step) => {
                let a = self.answer(step);
                self.run.awaiting.pop_front();
                a
            }
            None => self.run.held.map_or(SiActuation::default(), |(si, _)| si),
        }
    }
}

impl DeviceController<'_> {
    /// Receives until `step.t_ns + T`, logs the period; the actuation in force from then.
    fn answer(&mut self, step: Awaiting) -> SiActuation {
        self.run.fresh = false;
        self.run.answering = step.k;
        self.receive(step.t_ns + self.setup.period_ns);
        // Sample `e` (0-based) acts from t_e + d T, i.e. when e + d <= k (k from 1).
        while let Some(&(e, si, a)) = self.run.early.front() {
            if e.is_some_and(|e| e + self.delay_ticks() > step.k) {
                break;
            }
            self.run.early.pop_front();
            self.run.held = Some((si, a));
            self.run.fresh = true;
        }
        let (seq_echo, flags) = self
            .run
            .held
            .as_ref()
            .map_or((0, 0), |(_, a)| (a.seq_echo, a.flags.0));
        let seq = step.k as u16;
        self.rec.log.push(LinkSample {
            t_ns: step.t_ns,
            seq,
            seq_echo,
            age: seq.wrapping_sub(seq_echo),
            flags,
            fresh: self.run.fresh,
        });
        self.run.held.map_or(
            SiActuation {
                t_psi: 0.0,
                u_a: self.k_m * step.w_m,
            },
            |(si, _)| si,
        )
    }
}

/// Which per-period records [`close_loop`] keeps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Records {
    /// Every record (what `hil run`'s checks read).
    #[default]
    All,
    /// The link log only ([`LoopRecords::log`]; `sim-host run --loop device`).
    LinkLog,
}

/// How [`close_loop`] runs.
#[derive(Debug, Clone, Default)]
pub struct LoopSetup<'l> {
    /// The device's control period `T`, ns.
    pub period_ns: u64,
    /// The plant keeps its passive yaw spring (the passive law).
    pub yaw_spring: bool,
    /// What the Sensor frames carry of the lateral motion.
    pub lateral: LateralSensing,
    /// A Config frame to send before the first Sensor frame.
    pub config: Option<Config>,
    /// Send `Command::ClearFaults` once, at the first sample at or after this time, ns.
    pub clear_faults_at_ns: Option<u64>,
    /// Send `Command::InjectStall` once, at the first sample at or after this time, ns.
    pub stall_at_ns: Option<u64>,
    /// A Config frame sent again after a device reset (besides `config`).
    pub reset_config: Option<Config>,
    /// Ticks from a sample to its actuation taking effect (0 or 1: lock-step).
    pub delay_ticks: u32,
    /// A progress bar to advance (simulated ms).
    pub progress: Option<ProgressBar>,
    /// Which records to keep.
    pub records: Records,
    /// The trajectory's label.
    pub label: &'l str,
}

/// A finished closed loop: the plant's trajectory and [`DeviceController`]'s records.
#[derive(Debug)]
pub struct ClosedLoop {
    /// The plant's trajectory.
    pub trajectory: Trajectory,
    /// What the loop recorded.
    pub rec: LoopRecords,
}

/// Runs `sc` with the device behind `tr` as its controller, then fetches its counters.
pub fn close_loop(
    sc: &Scenario,
    tr: &mut dyn Transport,
    setup: LoopSetup<'_>,
) -> Result<ClosedLoop, SimError> {
    let (period_ns, yaw_spring, label) = (setup.period_ns, setup.yaw_spring, setup.label);
    let mut ctrl = DeviceController::new(tr, sc.params.k_m, setup);
    // One record per period, reserved once; capped for a very long scenario.
    let periods = (sc.duration_ns / period_ns.max(1)).min(1 << 22);
    ctrl.reserve(usize::try_from(periods).unwrap_or(0).saturating_add(2));
    let trajectory = drive(sc, &mut ctrl, 1, yaw_spring, label, |_, _, _| {})?;
    let t_end = ctrl.rec.log.last().map_or(0, |p| p.t_ns + period_ns);
    ctrl.finish(t_end);
    Ok(ClosedLoop {
        trajectory,
        rec: std::mem::take(&mut ctrl.rec),
    })
}

#[cfg(test)]
mod reset_tests;
