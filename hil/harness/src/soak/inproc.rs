//! The in-process soak: one `Runtime<Fx>`, never re-created, over the soak's line
//! ([`super::line`]) for hours of simulated service ([`super::service`]), streamed: the
//! state is the plant's, the device's and a handful of running counts, whatever the
//! length. Each period `T` is the exchange of `wheelset_loop::exchange` (the actuation
//! from `t_k + T`) on the flexible axle with the traction drive, RK4 at [`STEP_NS`].
//!
//! The checks are `docs/soak.md`'s: at every tick on the device's own output
//! (`after_tick`), at every Status (`check_status`), the plant's `|y|` and the peak RSS
//! (the limits below); the first failure stops the run, named with its simulated time
//! and the seed.

use std::collections::BTreeMap;
use std::fmt;
use std::time::Instant;

use rand::{Rng, SeedableRng};
use rand_pcg::Pcg64;
use wheelset_control::Fx;
use wheelset_loop::inproc::{rx_counts, DeviceFault};
use wheelset_plant::adhesion::{Adhesion, Condition};
use wheelset_plant::params::Params;
use wheelset_plant::plant::{ix, Fixed, Inputs, Plant, PlantConfig, State};
use wheelset_plant::scenario::{Axle, Scenario};
use wheelset_plant::sim::rk4_step;
use wheelset_proto::units::{TORQUE_LSB_NM, VOLTAGE_LSB_V};
use wheelset_proto::{
    encode_vec, Actuation, Command, Config, Decoder, Flags, FrameError, LateralSensing, Message,
    Sensor, SensorSi, Status,
};
use wheelset_runtime::{HoldPolicy, Runtime, SafeChange};

use super::line::{Fate, Line, LineCounts, LineFaults};
use super::service::{next_episode, Demand, Episode, ServiceOptions, Track};
use crate::run::{device_config, Law};
use crate::sweep::throughput::thread_cpu;

/// The plant's integration step, ns: the built-in scenarios' (`sim.dt_s = 1e-4`), a
/// whole number of steps in every period the soak moves between (1, 0.5, 0.4, 0.2 ms).
pub const STEP_NS: u64 = 100_000;
/// The line rate, baud (`wheelset_loop::sim_link::DEFAULT_BAUD`).
pub const BAUD: u32 = wheelset_loop::sim_link::DEFAULT_BAUD;
/// The device's tick after the sample instant, ns: the worst-case Sensor frame's wire
/// time plus the link latency (`wheelset_loop::inproc`'s tick phase).
pub const PHASE_NS: u64 = 45 * 2_000 + wheelset_loop::sim_link::DEFAULT_LATENCY_NS;
/// An actuator fault must be alarmed within this, ns: the failed wheelset's kinematic
/// mode grows at 19 1/s at the default conicity 0.2 (`docs/monitor.md`), from the
/// monitor's noise floor to its 30 mm/s threshold in under 1 s; 3 s is the bound.
pub const ALARM_DEADLINE_NS: u64 = 3_000_000_000;
/// Alarms stay expected this long after the actuator's repair or the end of a safe state
/// (whose zero yaw torque leaves the wheelset's kinematic mode free to grow), ns (the
/// monitor's mean square decays with tau = 0.6 s).
pub const ALARM_GRACE_NS: u64 = 5_000_000_000;
/// The plant has left the rails: `|y|` above this, m.
pub const Y_MAX_M: f64 = 0.02;
/// Growth of the peak RSS allowed between the first checkpoint and the end, KiB.
pub const RSS_GROWTH_MAX_KIB: u64 = 8 * 1024;
/// The device's tick count (and its count of valid frames) starts this far below its
/// wrap: crossed after 20 min at 5 kHz, 100 min at 1 kHz (the same start whatever the
/// run's length: the Status frame's length depends on the counts, and with it where the
/// line's faults fall, so a replay must start where the run did).
pub const START_TICKS_BEFORE_WRAP: u32 = 6_000_000;
/// The speed the service holds, m/s (the paper's 83.3 m/s): the running resistance
/// balances the demand plus `m_long (v - V0) / 30 s`.
const SPEED_HOLD_S: f64 = 30.0;

/// How the soak runs.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SoakOptions {
    /// Simulated service, ns.
    pub duration_ns: u64,
    /// Seed of every random choice.
    pub seed: u64,
    /// A deliberately broken device (`--defect`): `None` or `Corrupt` (the others are refused).
    pub defect: DeviceFault,
    /// Print a line per simulated hour on stderr.
    pub progress: bool,
    /// `hil soak --trace`: the episodes, repairs and adhesion onsets on stderr.
    pub trace: bool,
    /// What the service may do beyond its default day.
    pub service: ServiceOptions,
}

/// What broke, when, with which seed.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize)]
pub struct SoakFailure {
    /// Simulated time, ns.
    pub t_ns: u64,
    /// The run's seed.
    pub seed: u64,
    /// What broke.
    pub what: String,
    /// The run's options beyond the seed and length, as `hil soak` flags (for the replay).
    pub flags: String,
}

impl fmt::Display for SoakFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "at {} (t = {:.4} s), seed {}: {}",
            hms(self.t_ns),
            self.t_ns as f64 * 1e-9,
            self.seed,
            self.what
        )
    }
}

impl SoakFailure {
    /// The command that replays the run up to just past the failure.
    #[must_use]
    pub fn replay(&self) -> String {
        let minutes = (self.t_ns / 60_000_000_000) + 1;
        format!(
            "hil soak --seed {} --minutes {minutes}{}",
            self.seed, self.flags
        )
    }
}

/// `H:MM:SS.ssssss` of `t_ns`.
fn hms(t_ns: u64) -> String {
    let s = t_ns / 1_000_000_000;
    let us = (t_ns % 1_000_000_000) / 1_000;
    format!("{}:{:02}:{:02}.{us:06}", s / 3600, (s / 60) % 60, s % 60)
}

/// The figures of a soak.
#[derive(Debug, Clone, Default, serde::Serialize)]
pub struct SoakReport {
    /// The seed.
    pub seed: u64,
    /// Simulated service, s.
    pub simulated_s: f64,
    /// Device ticks (= control periods) run.
    pub ticks: u64,
    /// Host -> device frames.
    pub up: LineCounts,
    /// Device -> host frames.
    pub down: LineCounts,
    /// Status frames the host received and checked.
    pub statuses_checked: u64,
    /// Status frames requested that the line lost (either way).
    pub statuses_lost: u64,
    /// Link fault episodes: bit errors, drops, outages, bursts.
    pub link_episodes: [u64; 4],
    /// Adhesion patches.
    pub adhesion_patches: u64,
    /// Actuator faults (each alarmed, repaired and cleared).
    pub actuator_faults: u64,
    /// Alarms the device raised (rising edges: hunting, actuator, drive).
    pub alarms: [u64; 3],
    /// Configs applied.
    pub configs: u64,
    /// Of them, rate changes.
    pub rate_changes: u64,
    /// Safe-state entries.
    pub safe_entries: u64,
    /// Ticks held on the last sample.
    pub held_ticks: u64,
    /// When the device's 32-bit tick counter wrapped, s.
    pub tick_wrap_s: Option<f64>,
    /// Peak RSS at the first checkpoint, KiB.
    pub rss_first_kib: u64,
    /// When the first RSS figure was taken, s.
    pub rss_first_s: f64,
    /// Peak RSS at the end, KiB.
    pub rss_end_kib: u64,
    /// Wall time, s.
    pub wall_s: f64,
    /// CPU time of the soak's thread, s (0 where unknown).
    pub cpu_s: f64,
    /// The first failure (none: clean).
    pub failure: Option<SoakFailure>,
}

impl SoakReport {
    /// The summary `hil soak` prints.
    #[must_use]
    pub fn summary(&self) -> String {
        let lines =
            [("host -> device", &self.up), ("device -> host", &self.down)].map(|(name, c)| {
                let adds_up = if c.frames.adds_up() {
                    "adds up"
                } else {
                    "DOES NOT ADD UP"
                };
                format!(
                    "  {name}: {} ({adds_up}); {} touched by the line\n",
                    c.frames, c.touched
                )
            });
        let [ber, drop, outage, burst] = self.link_episodes;
        let [h, a, d] = self.alarms;
        let wrap = self
            .tick_wrap_s
            .map_or("its tick counter has not wrapped yet".into(), |t| {
                format!("its tick counter wrapped at {t:.1} s")
            });
        let end = match &self.failure {
            None => "soak: clean\n".to_string(),
            Some(f) => format!("soak FAILED {f}\nreplay: {}\n", f.replay()),
        };
        format!(
            "hil soak: seed {}, {} simulated ({} ticks)\n\
             \x20 time: {:.1} s wall, {:.1} s CPU ({:.0}x real time)\n{}{}\
             \x20 service: link faults {} (bit errors {ber}, drops {drop}, outages {outage}, bursts {burst}), adhesion patches {}, actuator faults {}, Configs {} ({} rate changes)\n\
             \x20 device: alarms {} (hunting {h}, actuator {a}, drive {d}), every one expected; safe entries {}, held ticks {}; {wrap}\n\
             \x20 Status frames checked {}, lost on the line {}\n\
             \x20 memory: peak RSS {} KiB at {:.0} s, {} KiB at the end\n{end}",
            self.seed,
            hms((self.simulated_s * 1e9) as u64),
            self.ticks,
            self.wall_s,
            self.cpu_s,
            self.simulated_s / self.wall_s.max(1e-9),
            lines[0],
            lines[1],
            ber + drop + outage + burst,
            self.adhesion_patches,
            self.actuator_faults,
            self.configs,
            self.rate_changes,
            h + a + d,
            self.safe_entries,
            self.held_ticks,
            self.statuses_checked,
            self.statuses_lost,
            self.rss_first_kib,
            self.rss_first_s,
            self.rss_end_kib
        )
    }
}

/// The actuator-fault episode's state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum ActState {
    /// Working; no fault since the grace ran out.
    Idle,
    /// Delivering nothing since `t_ns`; the alarm is due.
    Failed(u64),
    /// Repaired at `t_ns` (the host saw the alarm).
    Repaired(u64),
}

/// The harness's own account of what the device must be doing.
#[derive(Debug, Clone, Copy, Default)]
struct Account {
    sampled: bool,
    /// The runtime's own hold-then-safe policy, fed what the device should have seen.
    hold: HoldPolicy,
    safe_since_ns: u64,
    safe_exit_ns: u64,
    hold_ticks: u16,
    last_seq: u16,
    latched: bool,
    rate_hz: u32,
    statuses: u64,
    safe_ticks: u64,
    safe_exits: u64,
    seq_gaps: u64,
    alarm_flags: u16,
    first_alarm_tick: Option<u32>,
}

struct Soak {
    opts: SoakOptions,
    rt: Runtime<Fx>,
    start: Status,
    up: Line,
    down: Line,
    dev_dec: Decoder,
    host_dec: Decoder,
    plant: Plant,
    params: Params,
    x: State,
    v0: f64,
    held: (f64, f64),
    track: Track,
    demand: Demand,
    rng_track: Pcg64,
    rng_service: Pcg64,
    next: (u64, Episode),
    episode_end: Option<u64>,
    /// `--trace`: the start of the adhesion patch whose first second is traced, and the
    /// peak `|y'|` of the block so far (m/s).
    onset: Option<(u64, f64)>,
    act: ActState,
    config_pending: Option<(Config, u32)>,
    configs: BTreeMap<(u32, bool), Config>,
    status_next_ns: u64,
    status_pending: bool,
    clear_next_ns: u64,
    acc: Account,
    torque_max: i32,
    voltage: (i32, i32),
    safe_ramp_ns: u64,
    t_ns: u64,
    period_ns: u64,
    seq: u16,
    frames_out: u64,
    rss_at_ns: u64,
    report: SoakReport,
    failure: Option<SoakFailure>,
}

/// The peak resident set of this process, KiB (`VmHWM`; 0 where unknown).
#[must_use]
pub fn peak_rss_kib() -> u64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find_map(|l| l.strip_prefix("VmHWM:"))
                .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        })
        .unwrap_or(0)
}

impl Soak {
    fn new(opts: SoakOptions) -> Result<Self, String> {
        if !matches!(opts.defect, DeviceFault::None | DeviceFault::Corrupt { .. }) {
            return Err(format!("the soak has no defect `{}`", opts.defect));
        }
        let sc = Scenario::load("curve", &Params::default()).map_err(|e| e.to_string())?;
        let base = wheelset_loop::device_loop::runtime_config(&sc, Law::Lead, &Default::default());
        let mut rt = Runtime::<Fx>::try_new(base).map_err(|e| e.to_string())?;
        // Every design point of the service, computed once (`wheelset_runtime::rates_for`).
        let mut configs = BTreeMap::new();
        for &hz in &super::service::RATES_HZ {
            for lead in [false, true] {
                let mut r = base.designed(hz, 1).map_err(|e| e.to_string())?;
                r.control.yaw_mode = if lead { Law::Lead } else { Law::Gain }.into();
                let cfg = device_config(&r, true, false).map_err(|e| e.to_string())?;
                configs.insert((hz, lead), cfg);
            }
        }
        // The device's start: the run's Config (protection on, alarms reported) and every
        // 32-bit counter near its wrap (`START_TICKS_BEFORE_WRAP`; the others within a few
        // hundred events).
        let boot = wheelset_loop::device_loop::run_config(&base, true, false);
        let frame = encode_vec(&Message::Config(boot)).map_err(|e| format!("{e:?}"))?;
        rt.receive(&frame);
        if rt.counters().cmd_refused != 0 {
            return Err(format!(
                "the device refused the run's Config: {:?}",
                rt.refuse_reason()
            ));
        }
        let mut rng_service = Pcg64::seed_from_u64(opts.seed ^ 0x50a4_0001);
        let near = |r: &mut Pcg64| u32::MAX - r.random_range(0..300u32);
        let start = Status {
            ticks: u32::MAX - START_TICKS_BEFORE_WRAP,
            rx_ok: u32::MAX - START_TICKS_BEFORE_WRAP,
            rx_crc: near(&mut rng_service),
            rx_cobs: near(&mut rng_service),
            rx_version: near(&mut rng_service),
            rx_length: near(&mut rng_service),
            rx_postcard: near(&mut rng_service),
            rx_unexpected: near(&mut rng_service),
            seq_gaps: near(&mut rng_service),
            held_ticks: near(&mut rng_service),
            safe_ticks: near(&mut rng_service),
            safe_entries: near(&mut rng_service),
            safe_exits: near(&mut rng_service),
            yaw_sat: near(&mut rng_service),
            traction_sat: near(&mut rng_service),
            input_clamped: near(&mut rng_service),
            cmd_refused: near(&mut rng_service),
            wsp_ticks: near(&mut rng_service),
            wsp_events: near(&mut rng_service),
            hunt_alarms: near(&mut rng_service),
            act_alarms: near(&mut rng_service),
            drive_alarms: near(&mut rng_service),
            ..Status::default()
        };
        rt.preset_counters(&start);
        let start = *rt.counters();
        let params = sc.params;
        let plant = Plant::new(
            &params,
            PlantConfig {
                axle: Axle::Flexible,
                drive: true,
                yaw_spring: false,
            },
        );
        let x = plant.rolling_state(params.v);
        let lim = base.control.limits;
        let next = next_episode(&mut rng_service, 0, opts.service);
        let rss_at_ns = (opts.duration_ns / 4).min(3_600_000_000_000);
        Ok(Self {
            up: Line::new(Pcg64::seed_from_u64(opts.seed ^ 0x50a4_0002), BAUD),
            down: Line::new(Pcg64::seed_from_u64(opts.seed ^ 0x50a4_0003), BAUD),
            dev_dec: Decoder::new(),
            host_dec: Decoder::new(),
            held: (0.0, plant.back_emf(&x)),
            plant,
            v0: params.v,
            params,
            x,
            track: Track::default(),
            demand: Demand::new(opts.service.demand_steps),
            rng_track: Pcg64::seed_from_u64(opts.seed ^ 0x50a4_0004),
            rng_service,
            next,
            episode_end: None,
            onset: None,
            act: ActState::Idle,
            config_pending: None,
            configs,
            status_next_ns: 2_000_000_000,
            status_pending: false,
            clear_next_ns: 0,
            acc: Account {
                hold_ticks: boot.hold_ticks,
                rate_hz: rt.base_rate_hz(),
                ..Account::default()
            },
            torque_max: (lim.torque / TORQUE_LSB_NM).round() as i32,
            voltage: (
                (lim.voltage_min / VOLTAGE_LSB_V).round() as i32,
                (lim.voltage_max / VOLTAGE_LSB_V).round() as i32,
            ),
            safe_ramp_ns: (base.control.safe.yaw_s * 1e9) as u64,
            period_ns: 1_000_000_000 / u64::from(rt.base_rate_hz()),
            rt,
            start,
            t_ns: 0,
            seq: u16::MAX - 99,
            frames_out: 0,
            rss_at_ns,
            report: SoakReport {
                seed: opts.seed,
                ..SoakReport::default()
            },
            failure: None,
            opts,
        })
    }

    fn fail(&mut self, what: String) {
        if self.failure.is_none() {
            let x = &self.x;
            let o = &self.opts;
            let mut flags: String = [
                (o.service.low_adhesion, " --low-adhesion"),
                (o.service.demand_steps, " --demand-steps"),
                (o.service.gain_law, " --gain-law"),
            ]
            .into_iter()
            .filter_map(|(on, flag)| on.then_some(flag))
            .collect();
            if o.defect != DeviceFault::None {
                flags.push_str(&format!(" --defect {}", o.defect));
            }
            self.failure = Some(SoakFailure {
                flags,
                t_ns: self.t_ns,
                seed: self.opts.seed,
                what: format!(
                    "{what} [at {} Hz; plant: y {:.3} mm, y' {:.1} mm/s, psi {:.3} mrad, v {:.2} m/s]",
                    self.acc.rate_hz,
                    x[ix::Y] * 1e3,
                    x[ix::YD] * 1e3,
                    x[ix::PSI] * 1e3,
                    x[ix::V]
                ),
            });
        }
    }

    fn run(&mut self) {
        let t0 = Instant::now();
        let mut next_hour = 3_600_000_000_000u64;
        while self.t_ns < self.opts.duration_ns && self.failure.is_none() {
            self.period();
            if self.report.rss_first_kib == 0 && self.t_ns >= self.rss_at_ns {
                self.report.rss_first_kib = peak_rss_kib();
                self.report.rss_first_s = self.t_ns as f64 * 1e-9;
            }
            if self.opts.progress && self.t_ns >= next_hour {
                next_hour += 3_600_000_000_000;
                eprintln!(
                    "hil soak: {} simulated, {:.1} s wall, {} ticks, peak RSS {} KiB",
                    hms(self.t_ns),
                    t0.elapsed().as_secs_f64(),
                    self.report.ticks,
                    peak_rss_kib()
                );
            }
        }
    }

    /// The service's episodes at `t`: the one due starts, the one running ends.
    fn service(&mut self, t: u64) {
        if let Some(end) = self.episode_end {
            if t >= end {
                self.episode_end = None;
                self.up.set_faults(LineFaults::default(), t);
                self.down.set_faults(LineFaults::default(), t);
                self.plant.adhesion = None;
                self.next = next_episode(&mut self.rng_service, t, self.opts.service);
            }
            return;
        }
        if self.act != ActState::Idle || self.config_pending.is_some() || t < self.next.0 {
            return;
        }
        if self.opts.trace {
            eprintln!("{} {:?}", hms(t), self.next.1);
        }
        match self.next.1 {
            Episode::Link {
                faults,
                len_ns,
                kind,
            } => {
                self.report.link_episodes[kind] += 1;
                self.up.set_faults(faults, t);
                self.down.set_faults(faults, t);
                self.episode_end = Some(t + len_ns);
            }
            Episode::Adhesion { low, len_ns } => {
                self.report.adhesion_patches += 1;
                let c = if low { Condition::Low } else { Condition::Wet };
                self.plant.adhesion = Some(Adhesion::new(c, self.params.q()));
                self.episode_end = Some(t + len_ns);
                self.onset = self.opts.trace.then_some((t, 0.0));
            }
            Episode::Actuator => {
                self.report.actuator_faults += 1;
                self.act = ActState::Failed(t);
            }
            Episode::Config { rate_hz, lead } => {
                if let Some(&cfg) = self.configs.get(&(rate_hz, lead)) {
                    self.config_pending = Some((cfg, rate_hz));
                }
            }
        }
        if matches!(self.next.1, Episode::Actuator | Episode::Config { .. }) {
            // Drawn again when it ends (`after_tick`).
            self.next.0 = u64::MAX;
        }
    }

    /// `--trace`, over the first second of an adhesion patch: per 0.1 s, the peak `|y'|`,
    /// the rim's slip velocity `w_m r0 / n - v` and the armature current.
    fn trace_onset(&mut self, t: u64, si: &SensorSi) {
        const BLOCK_NS: u64 = 100_000_000;
        let Some((t0, peak)) = self.onset.as_mut() else {
            return;
        };
        *peak = peak.max(si.y_dot.abs());
        let since = t - *t0;
        if since > 0 && since % BLOCK_NS < self.period_ns {
            let slip = si.w_m * self.params.r0 / self.params.n_gear - si.v_ref;
            eprintln!(
                "{}   +{:.1} s: y' peak {:.1} mm/s, slip {:.3} m/s, i_a {:.1} A",
                hms(t),
                since as f64 * 1e-9,
                *peak * 1e3,
                slip,
                si.i_a
            );
            *peak = 0.0;
        }
        if since >= 10 * BLOCK_NS {
            self.onset = None;
        }
    }

    fn period(&mut self) {
        let t = self.t_ns;
        self.service(t);
        let (curvature, cant) = self.track.at(&mut self.rng_track, t);
        let demand = self.demand.at(&mut self.rng_track, t);
        let x = self.x;
        self.seq = self.seq.wrapping_add(1);
        let si = SensorSi {
            y_dot: x[ix::YD],
            y_ddot: 0.0,
            i_a: x[ix::IA],
            w_m: x[ix::WM],
            demand_nm: demand,
            v_ref: x[ix::V],
        };
        let s: Sensor = Sensor::from_si(self.seq, t, &si, LateralSensing::Velocity).msg;
        self.trace_onset(t, &si);
        let mut at = t;
        let fresh = self.send(&mut at, &Message::Sensor(s));
        let mut config_applied = None;
        if let Some((cfg, hz)) = self.config_pending {
            if self.send(&mut at, &Message::Config(cfg)) {
                config_applied = Some((cfg, hz));
            }
        }
        let mut status_requested = false;
        if t >= self.status_next_ns {
            self.status_next_ns = t + (self.rng_service.random_range(2.0..6.0) * 1e9) as u64;
            if self.status_pending {
                self.report.statuses_lost += 1;
            }
            self.status_pending = true;
            status_requested = self.send(&mut at, &Message::Command(Command::RequestStatus));
        }
        let mut cleared = false;
        if self.acc.latched && t >= self.clear_next_ns && !matches!(self.act, ActState::Failed(_)) {
            // The host clears a latched fault once the actuator works (at most every
            // 10 ms: its view of the latch comes with the Actuation frames).
            self.clear_next_ns = t + 10_000_000;
            cleared = self.send(&mut at, &Message::Command(Command::ClearFaults));
        }
        let tick_at = t + PHASE_NS;
        let mut out = self.rt.tick(0).to_vec();
        self.after_tick(t, fresh, config_applied, status_requested, cleared, &out);
        let mut fresh_act: Option<Actuation> = None;
        let mut status: Option<Status> = None;
        let mut at = tick_at;
        for frame in out.split_inclusive_mut(|&b| b == 0) {
            self.frames_out += 1;
            if let DeviceFault::Corrupt { every } = self.opts.defect {
                if self.frames_out.is_multiple_of(u64::from(every)) && frame.len() > 3 {
                    frame[2] ^= 0x10;
                }
            }
            let clean = self.down.clean();
            let dec = &mut self.host_dec;
            let fate = self.down.carry(at, frame, |piece| {
                let (r, _) = dec.next_message(piece);
                match r {
                    Some(Ok(Message::Actuation(a))) => fresh_act = Some(a),
                    Some(Ok(Message::Status(s))) => status = Some(s),
                    _ => {}
                }
                r.map(|r| r.map(|_| ()))
            });
            if clean && fate != Fate::Valid {
                self.fail(format!(
                    "device -> host: a frame {fate:?} on a line without faults (the device sent it broken)"
                ));
            }
            at += frame.len() as u64 * 2_000;
        }
        if let Some(s) = status {
            self.status_pending = false;
            self.check_status(&s);
        }
        if let Some(a) = fresh_act {
            self.host_sees(t, &a);
        }
        self.integrate(curvature, cant, demand);
        if let Some(a) = fresh_act {
            self.held = (
                f64::from(a.t_psi_dnm) * TORQUE_LSB_NM,
                f64::from(a.u_a_cv) * VOLTAGE_LSB_V,
            );
        }
        self.t_ns = t + self.period_ns;
        let hz = self.rt.base_rate_hz();
        if hz != self.acc.rate_hz {
            self.fail(format!(
                "the device ticks at {hz} Hz, the harness's account says {} Hz",
                self.acc.rate_hz
            ));
        }
        self.period_ns = 1_000_000_000 / u64::from(hz.max(1));
    }

    /// One frame up, sent at `at` (advanced by its wire time), through the line into the
    /// runtime, its fate attributed from the runtime's own counters
    /// (`wheelset_loop::inproc`'s rule); whether the device received it valid.
    fn send(&mut self, at: &mut u64, m: &Message) -> bool {
        let Ok(frame) = encode_vec(m) else {
            return false;
        };
        let clean = self.up.clean();
        let rt = &mut self.rt;
        let fate = self.up.carry(*at, &frame, |piece| {
            let before = rx_counts(rt.counters());
            rt.receive(piece);
            let after = rx_counts(rt.counters());
            if after[0] != before[0] || after[6] != before[6] {
                return Some(Ok(()));
            }
            (1..6)
                .find(|&k| after[k] != before[k])
                .map(|k| Err(FrameError::KINDS[k - 1]))
        });
        *at += frame.len() as u64 * 2_000;
        if clean && fate != Fate::Valid {
            self.fail(format!(
                "host -> device: a frame {fate:?} on a line without faults"
            ));
        }
        fate == Fate::Valid
    }

    /// The tick's checks against the account, on the device's own output.
    fn after_tick(
        &mut self,
        t: u64,
        fresh: bool,
        config: Option<(Config, u32)>,
        status_requested: bool,
        cleared: bool,
        out: &[u8],
    ) {
        let acc = &mut self.acc;
        self.report.ticks += 1;
        if let Some((cfg, hz)) = config {
            acc.hold_ticks = cfg.hold_ticks;
            self.report.configs += 1;
            if hz != acc.rate_hz {
                self.report.rate_changes += 1;
            }
            acc.rate_hz = hz;
            self.config_pending = None;
            self.next = next_episode(&mut self.rng_service, t, self.opts.service);
        }
        if cleared {
            acc.latched = false;
        }
        if fresh {
            if acc.sampled && self.seq != acc.last_seq.wrapping_add(1) {
                acc.seq_gaps += 1;
            }
            acc.sampled = true;
            acc.last_seq = self.seq;
        }
        // The hold policy (`wheelset_runtime`'s fault policy, items 2 to 4; no alarm holds
        // the safe state: the soak's Configs report alarms only).
        let h = acc.hold.step(fresh, acc.sampled, acc.hold_ticks, false);
        let (holding, safe) = (h.holding, h.safe);
        match h.change {
            Some(SafeChange::Enter) => {
                self.report.safe_entries += 1;
                acc.safe_since_ns = t;
            }
            Some(SafeChange::Exit) => {
                acc.safe_exits += 1;
                acc.safe_exit_ns = t;
            }
            None => {}
        }
        self.report.held_ticks += u64::from(holding);
        acc.safe_ticks += u64::from(safe);
        if status_requested {
            acc.statuses += 1;
        }
        let (mut a, mut st) = (None, false);
        let wrong = self.dev_dec.messages(out).find_map(|r| {
            match r {
                Ok(Message::Actuation(x)) => a = Some(x),
                Ok(Message::Status(_)) => st = true,
                other => return Some(other),
            }
            None
        });
        if wrong.is_some() {
            self.fail(format!(
                "the device sent {wrong:?} where an Actuation or Status belongs"
            ));
            return;
        }
        let Some(a) = a else {
            self.fail("the device's tick sent no Actuation frame".into());
            return;
        };
        if st != status_requested {
            self.fail(format!(
                "a Status frame {} (requested: {status_requested})",
                if st {
                    "came unrequested"
                } else {
                    "did not come"
                }
            ));
        }
        let f = a.flags;
        let acc = &mut self.acc;
        let tick_count = self.start.ticks.wrapping_add(self.report.ticks as u32);
        if tick_count == 0 {
            self.report.tick_wrap_s = Some(t as f64 * 1e-9);
        }
        let mut broke = Vec::new();
        if a.tick != tick_count as u16 {
            broke.push(format!("tick {} where the count is {tick_count}", a.tick));
        }
        let expect = [
            (Flags::HOLDING, holding, "HOLDING"),
            (Flags::SAFE, safe, "SAFE"),
            (Flags::NO_SAMPLE, !acc.sampled, "NO_SAMPLE"),
            (Flags::ENABLED, true, "ENABLED"),
            (Flags::CMD_REFUSED, false, "CMD_REFUSED"),
            (Flags::DRIVE_OSC, false, "DRIVE_OSC"),
        ];
        for (flag, want, name) in expect {
            if f.has(flag) != want {
                broke.push(format!("flag {name} is {} (policy: {want})", f.has(flag)));
            }
        }
        if acc.sampled && a.seq_echo != acc.last_seq {
            broke.push(format!(
                "seq_echo {} where the latest valid Sensor frame was {}",
                a.seq_echo, acc.last_seq
            ));
        }
        if a.t_psi_dnm.abs() > self.torque_max
            || a.u_a_cv < self.voltage.0
            || a.u_a_cv > self.voltage.1
        {
            broke.push(format!(
                "outputs out of their limits: T_psi {} x 0.1 N m, u_a {} x 10 mV",
                a.t_psi_dnm, a.u_a_cv
            ));
        }
        if safe
            && t > acc.safe_since_ns + self.safe_ramp_ns + 2 * self.period_ns
            && a.t_psi_dnm != 0
        {
            broke.push(format!(
                "yaw torque {} x 0.1 N m after the safe ramp ran out",
                a.t_psi_dnm
            ));
        }
        let alarm_bits = f.0 & (Flags::HUNTING | Flags::ACTUATOR_FAULT | Flags::DRIVE_OSC);
        let rose = alarm_bits & !acc.alarm_flags;
        acc.alarm_flags = alarm_bits;
        for (i, flag) in [Flags::HUNTING, Flags::ACTUATOR_FAULT, Flags::DRIVE_OSC]
            .into_iter()
            .enumerate()
        {
            if rose & flag != 0 {
                self.report.alarms[i] += 1;
                acc.latched = true;
                acc.first_alarm_tick.get_or_insert(tick_count.max(1));
            }
        }
        // (The safe state's zero yaw torque: see `ALARM_GRACE_NS`.)
        let after_safe = safe || (acc.safe_exit_ns > 0 && t < acc.safe_exit_ns + ALARM_GRACE_NS);
        let expected = after_safe
            || match self.act {
                ActState::Idle => false,
                ActState::Failed(_) => true,
                ActState::Repaired(at) => t < at + ALARM_GRACE_NS,
            };
        if rose != 0 && !expected {
            broke.push(format!(
                "an alarm nobody expected (flags {:#06x}; no actuator fault or safe state to explain it)",
                f.0
            ));
        }
        if f.has(Flags::FAULT_LATCHED) != acc.latched {
            broke.push(format!(
                "FAULT_LATCHED is {} (account: an alarm since the last ClearFaults: {})",
                f.has(Flags::FAULT_LATCHED),
                acc.latched
            ));
        }
        match self.act {
            ActState::Failed(since) if t > since + ALARM_DEADLINE_NS => broke.push(format!(
                "no alarm {:.1} s after the actuator failed at {}",
                (t - since) as f64 * 1e-9,
                hms(since)
            )),
            ActState::Repaired(at) if t >= at + ALARM_GRACE_NS => {
                self.act = ActState::Idle;
                self.next = next_episode(&mut self.rng_service, t, self.opts.service);
            }
            _ => {}
        }
        if !broke.is_empty() {
            self.fail(broke.join("; "));
        }
    }

    /// What the host does on an Actuation frame: after an actuator fault, the alarm it
    /// carries is the cue to repair the actuator.
    fn host_sees(&mut self, t: u64, a: &Actuation) {
        let alarm = a.flags.0 & (Flags::HUNTING | Flags::ACTUATOR_FAULT | Flags::FAULT_LATCHED);
        if let ActState::Failed(_) = self.act {
            if alarm != 0 {
                if self.opts.trace {
                    eprintln!(
                        "{} the host sees the alarm (flags {:#06x}): actuator repaired",
                        hms(t),
                        a.flags.0
                    );
                }
                self.act = ActState::Repaired(t);
            }
        }
    }

    /// The device's Status against the account (all modulo 2^32 from its start).
    fn check_status(&mut self, s: &Status) {
        self.report.statuses_checked += 1;
        let (st, acc, up, down) = (&self.start, &self.acc, &self.up.counts, &self.down.counts);
        let r = &self.report;
        let d = |f: fn(&Status) -> u32| f(s).wrapping_sub(f(st));
        let mut broke = Vec::new();
        for (name, device, harness) in [
            (
                "valid frames up",
                d(|x| x.rx_ok).wrapping_add(d(|x| x.rx_unexpected)),
                up.ok_events,
            ),
            ("CRC rejects", d(|x| x.rx_crc), up.rejects[0]),
            ("COBS rejects", d(|x| x.rx_cobs), up.rejects[1]),
            ("version rejects", d(|x| x.rx_version), up.rejects[2]),
            ("length rejects", d(|x| x.rx_length), up.rejects[3]),
            ("postcard rejects", d(|x| x.rx_postcard), up.rejects[4]),
            ("ticks", d(|x| x.ticks), r.ticks),
            (
                "frames down (ticks + Status frames)",
                d(|x| x.ticks).wrapping_add(acc.statuses as u32),
                down.frames.sent,
            ),
            ("held ticks", d(|x| x.held_ticks), r.held_ticks),
            ("safe ticks", d(|x| x.safe_ticks), acc.safe_ticks),
            ("safe entries", d(|x| x.safe_entries), r.safe_entries),
            ("safe exits", d(|x| x.safe_exits), acc.safe_exits),
            ("seq gaps", d(|x| x.seq_gaps), acc.seq_gaps),
            ("hunting alarms", d(|x| x.hunt_alarms), r.alarms[0]),
            ("actuator alarms", d(|x| x.act_alarms), r.alarms[1]),
            ("drive alarms", d(|x| x.drive_alarms), r.alarms[2]),
            ("refusals", d(|x| x.cmd_refused), 0),
            (
                "first alarm tick",
                s.first_alarm_tick,
                acc.first_alarm_tick.map_or(0, u64::from),
            ),
        ] {
            let harness = harness as u32;
            if device != harness {
                broke.push(format!("{name}: device {device}, harness {harness}"));
            }
        }
        if !up.frames.adds_up() || !down.frames.adds_up() {
            broke.push(format!("frames do not add up: up {up:?}, down {down:?}"));
        }
        if !broke.is_empty() {
            self.fail(format!("Status: {}", broke.join("; ")));
        }
    }

    /// The plant over one period under the held actuation (a failed actuator delivering
    /// none of its torque).
    fn integrate(&mut self, curvature: f64, cant: f64, demand: f64) {
        let h = STEP_NS as f64 * 1e-9;
        let m_long = self.params.m + self.params.m_v / 2.0;
        let plant = self.plant;
        let gain = if matches!(self.act, ActState::Failed(_)) {
            0.0
        } else {
            1.0
        };
        let mut x = self.x;
        for _ in 0..self.period_ns / STEP_NS {
            let u = Inputs {
                t_psi: gain * self.held.0,
                u_a: self.held.1,
                curvature,
                cant,
                f_run: demand / self.params.r0 + m_long * (x[ix::V] - self.v0) / SPEED_HOLD_S,
                t_drive: 0.0,
            };
            x = rk4_step(&x, h, |_, x| plant.rhs(Fixed::<true, true, false>, x, &u).0);
        }
        self.x = x;
        if !(x.iter().all(|v| v.is_finite()) && x[ix::Y].abs() < Y_MAX_M) {
            self.fail(format!(
                "the plant left the rails: y = {:.4} m, psi = {:.4} rad",
                x[ix::Y],
                x[ix::PSI]
            ));
        }
    }
}

/// Runs the soak; a panic in the device or the harness is a failure at the time it
/// happened. Errors: the set-up (scenario, configurations).
pub fn soak(opts: SoakOptions) -> Result<SoakReport, String> {
    let wall = Instant::now();
    let cpu0 = thread_cpu();
    let mut s = Soak::new(opts)?;
    let ran = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| s.run()));
    if let Err(p) = ran {
        let msg = p
            .downcast_ref::<&str>()
            .map(|m| (*m).to_string())
            .or_else(|| p.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        s.fail(format!("panic: {msg}"));
    }
    let mut r = std::mem::take(&mut s.report);
    r.simulated_s = s.t_ns as f64 * 1e-9;
    r.up = s.up.counts;
    r.down = s.down.counts;
    r.rss_end_kib = peak_rss_kib();
    if r.rss_first_kib == 0 {
        r.rss_first_kib = r.rss_end_kib;
        r.rss_first_s = r.simulated_s;
    }
    if s.failure.is_none() && r.rss_end_kib > r.rss_first_kib + RSS_GROWTH_MAX_KIB {
        s.fail(format!(
            "memory grew: peak RSS {} KiB at {:.0} s, {} KiB at the end",
            r.rss_first_kib, r.rss_first_s, r.rss_end_kib
        ));
    }
    r.failure = s.failure.take();
    r.wall_s = wall.elapsed().as_secs_f64();
    r.cpu_s = thread_cpu()
        .zip(cpu0)
        .map_or(0.0, |(b, a)| b.saturating_sub(a).as_secs_f64());
    Ok(r)
}
