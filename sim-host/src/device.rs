//! The device in process, behind the simulated serial link: the firmware's own
//! [`Runtime`] (control core + protocol + fault policy), driven in lock-step by simulated
//! time, receiving and sending bytes only.
//!
//! One exchange per control period `T` (the device's base rate), starting at the sample
//! instant `t_k = k T`:
//!
//! ```text
//! t_k            host quantises the measurements into a Sensor frame (seq k) -> up link
//! t_k + d        device tick: Runtime::receive(bytes arrived by now); Runtime::tick()
//!                -> Actuation frame -> down link      (d = worst-case Sensor frame time
//!                                                      on the wire + latency)
//! t_k + T        host applies the latest valid Actuation that arrived (ZOH until t_k+2T);
//!                if none arrived, it holds the previous one
//! ```
//!
//! So the plant sees the computation/transport delay of one period that the control
//! core's rate analysis assumes. The link budget check refuses a configuration whose
//! round trip does not fit ([`crate::link::check_budget`]).

use std::fmt;

use wheelset_control::Sample;
use wheelset_proto::units::{
    quantize, to_si, CURRENT_LSB_A, DEMAND_LSB_NM, LAT_VEL_LSB_M_PER_S, SPEED_LSB_RAD_PER_S,
    TORQUE_LSB_NM, VOLTAGE_LSB_V,
};
use wheelset_proto::{
    encode_vec, Actuation, Command, Flags, Lateral, Message, Sensor, Status, MAX_FRAME,
};
use wheelset_runtime::{Runtime, RuntimeConfig, RuntimeError};

use crate::link::{check_budget, wire_ns, Accounting, Link, LinkBudgetError, LinkConfig, RxPort};

/// Worst-case Sensor frame (velocity only) on the wire, bytes (the proto `sizes` test).
pub const SENSOR_WORST_BYTES: usize = 33;
/// Worst-case Actuation frame on the wire, bytes.
pub const ACTUATION_WORST_BYTES: usize = 28;

/// Why the device loop cannot be built.
#[derive(Debug, Clone, PartialEq)]
pub enum DeviceError {
    /// The runtime refused its configuration.
    Runtime(RuntimeError),
    /// The link cannot carry one exchange per period.
    Budget(LinkBudgetError),
    /// The base rate does not give a whole number of nanoseconds.
    Rate(u32),
}

impl fmt::Display for DeviceError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Runtime(e) => write!(f, "{e}"),
            Self::Budget(e) => write!(f, "{e}"),
            Self::Rate(hz) => write!(
                f,
                "device base rate {hz} Hz: the period must be a whole number of nanoseconds"
            ),
        }
    }
}

impl std::error::Error for DeviceError {}

/// One period's link record (the CSV's link columns).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct LinkSample {
    /// Sample instant, ns.
    pub t_ns: u64,
    /// Sequence number of the Sensor frame sent at `t_ns`.
    pub seq: u16,
    /// `seq_echo` of the actuation in force from `t_ns + T`.
    pub seq_echo: u16,
    /// Age of that actuation's sample, periods: `seq - seq_echo` (0: computed from this
    /// period's sample, the normal case; more when frames were lost and an older
    /// actuation is held).
    pub age: u16,
    /// Its flags.
    pub flags: u8,
    /// A new valid Actuation frame arrived in this period.
    pub fresh: bool,
}

/// The link columns appended to the standard CSV.
pub const LINK_COLUMNS: [&str; 5] = ["seq", "seq_echo", "frame_age", "flags", "fresh"];

/// End-of-run report: every frame accounted for, and the device's own counters.
#[derive(Debug, Clone)]
pub struct LinkReport {
    /// Host -> device.
    pub up: Accounting,
    /// Device -> host.
    pub down: Accounting,
    /// The device's counters as read back over the link in a Status frame (None if that
    /// frame was lost).
    pub device: Option<Status>,
    /// Periods in which the safe flag was set in the applied actuation.
    pub safe_periods: u64,
    /// Transitions into / out of the safe state seen by the host (from the flags).
    pub safe_entries_seen: u64,
    /// See `safe_entries_seen`.
    pub safe_exits_seen: u64,
    /// Inputs clamped while quantising for the wire (host side).
    pub host_clamped: u64,
    /// Mean wire bytes per period, up and down.
    pub mean_bytes: (f64, f64),
}

impl fmt::Display for LinkReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "host -> device: {}", self.up)?;
        writeln!(f, "device -> host: {}", self.down)?;
        writeln!(
            f,
            "safe state: {} periods, entered {} x, left {} x (seen in the actuation flags); \
             mean bytes per period: {:.1} up, {:.1} down; host-side clamps: {}",
            self.safe_periods,
            self.safe_entries_seen,
            self.safe_exits_seen,
            self.mean_bytes.0,
            self.mean_bytes.1,
            self.host_clamped
        )?;
        match &self.device {
            Some(s) => write!(
                f,
                "device status: ticks {}, rx ok {}, rejected crc {} cobs {} version {} length {} \
                 postcard {}, seq gaps {}, held ticks {}, safe ticks {}, safe entries {}, exits {}, \
                 yaw sat {}, traction sat {}",
                s.ticks,
                s.rx_ok,
                s.rx_crc,
                s.rx_cobs,
                s.rx_version,
                s.rx_length,
                s.rx_postcard,
                s.seq_gaps,
                s.held_ticks,
                s.safe_ticks,
                s.safe_entries,
                s.safe_exits,
                s.yaw_sat,
                s.traction_sat
            ),
            None => write!(f, "device status: the status frame was lost"),
        }
    }
}

/// The measurements the host sends (SI): `y'` m/s, `i_a` A, motor speed rad/s,
/// traction demand (wheel torque) N m.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct HostSample {
    /// Lateral velocity relative to the track, m/s.
    pub y_dot: f64,
    /// Armature current, A.
    pub i_a: f64,
    /// Motor speed, rad/s.
    pub w_m: f64,
    /// Traction demand at the wheel, N m.
    pub demand_nm: f64,
}

/// The device behind the link, in lock-step with the plant.
pub struct DeviceLoop<T: Sample> {
    link: Link,
    rt: Runtime<T>,
    host_rx: RxPort,
    dev_rx: RxPort,
    period_ns: u64,
    tick_offset_ns: u64,
    seq: u16,
    held: Option<Actuation>,
    held_si: (f64, f64),
    log: Vec<LinkSample>,
    host_clamped: u64,
    last_t_ns: u64,
}

impl<T: Sample> DeviceLoop<T> {
    /// The runtime with `rt_cfg`, behind a link with `link_cfg`; refuses a link that
    /// cannot carry one exchange per period.
    pub fn try_new(rt_cfg: RuntimeConfig, link_cfg: &LinkConfig) -> Result<Self, DeviceError> {
        let hz = rt_cfg.control.base_rate_hz;
        if hz == 0 || 1_000_000_000 % u64::from(hz) != 0 {
            return Err(DeviceError::Rate(hz));
        }
        let period_ns = 1_000_000_000 / u64::from(hz);
        check_budget(
            SENSOR_WORST_BYTES,
            ACTUATION_WORST_BYTES,
            link_cfg.baud,
            link_cfg.latency_ns,
            period_ns,
        )
        .map_err(DeviceError::Budget)?;
        let rt = Runtime::try_new(rt_cfg).map_err(DeviceError::Runtime)?;
        Ok(Self {
            link: Link::new(link_cfg),
            rt,
            host_rx: RxPort::new(),
            dev_rx: RxPort::new(),
            period_ns,
            tick_offset_ns: wire_ns(SENSOR_WORST_BYTES, link_cfg.baud) + link_cfg.latency_ns,
            seq: 0,
            held: None,
            held_si: (0.0, 0.0),
            log: Vec::new(),
            host_clamped: 0,
            last_t_ns: 0,
        })
    }

    /// The control period, ns.
    #[must_use]
    pub fn period_ns(&self) -> u64 {
        self.period_ns
    }

    /// The runtime (read only).
    #[must_use]
    pub fn runtime(&self) -> &Runtime<T> {
        &self.rt
    }

    /// The per-period link records.
    #[must_use]
    pub fn log(&self) -> &[LinkSample] {
        &self.log
    }

    fn q(&mut self, x: f64, lsb: f64) -> i32 {
        let (v, clamped) = quantize(x, lsb);
        self.host_clamped += u64::from(clamped);
        v
    }

    /// One exchange at the sample instant `t_ns` (see the module docs). Returns the
    /// actuation in force from `t_ns + T`: `(T_psi N m, u_a V)`; before the first valid
    /// actuation frame, `initial`.
    pub fn exchange(&mut self, t_ns: u64, m: &HostSample, initial: (f64, f64)) -> (f64, f64) {
        if self.held.is_none() && self.log.is_empty() {
            self.held_si = initial;
        }
        self.seq = self.seq.wrapping_add(1);
        let sensor = Sensor {
            seq: self.seq,
            t_us: ((t_ns / 1_000) & 0xffff) as u16,
            lateral: Lateral::Velocity(self.q(m.y_dot, LAT_VEL_LSB_M_PER_S)),
            i_a_ma: self.q(m.i_a, CURRENT_LSB_A),
            omega_m_mrad_s: self.q(m.w_m, SPEED_LSB_RAD_PER_S),
            demand_nm: self.q(m.demand_nm, DEMAND_LSB_NM),
        };
        let frame = encode_vec(&Message::Sensor(sensor)).unwrap_or_default();
        self.link.up.send(t_ns, &frame);
        // The device's tick.
        let t_dev = t_ns + self.tick_offset_ns;
        self.device_receive(t_dev);
        let out = self.rt.tick(0).to_vec();
        self.link.down.send(t_dev, &out);
        // What reaches the host before the next sample instant.
        let t_next = t_ns + self.period_ns;
        let fresh = self.host_receive(t_next - 1);
        self.last_t_ns = t_next;
        let (seq_echo, flags) = self.held.map_or((0, 0), |a| (a.seq_echo, a.flags.0));
        self.log.push(LinkSample {
            t_ns,
            seq: self.seq,
            seq_echo,
            age: self.seq.wrapping_sub(seq_echo),
            flags,
            fresh,
        });
        self.held_si
    }

    fn device_receive(&mut self, t: u64) {
        let (rt, port) = (&mut self.rt, &mut self.dev_rx);
        self.link.up.deliver(t, |b, id| {
            rt.receive(&[b]);
            let _ = port.push(b, id);
        });
    }

    fn host_receive(&mut self, t: u64) -> bool {
        let mut fresh = false;
        let (port, held, held_si) = (&mut self.host_rx, &mut self.held, &mut self.held_si);
        self.link.down.deliver(t, |b, id| {
            if let Some(Ok(Message::Actuation(a))) = port.push(b, id) {
                *held = Some(a);
                *held_si = (
                    to_si(a.t_psi_dnm, TORQUE_LSB_NM),
                    to_si(a.u_a_cv, VOLTAGE_LSB_V),
                );
                fresh = true;
            }
        });
        fresh
    }

    /// Ends the run: asks the device for its counters over the link, lets every byte in
    /// flight arrive, and accounts for every frame in both directions.
    pub fn finish(&mut self) -> LinkReport {
        let t = self.last_t_ns;
        let req = encode_vec(&Message::Command(Command::RequestStatus)).unwrap_or_default();
        self.link.up.send(t, &req);
        let t_dev = self.link.up.line_free_ns() + self.tick_offset_ns;
        self.device_receive(t_dev);
        let out = self.rt.tick(0).to_vec();
        self.link.down.send(t_dev, &out);
        // Drain: long enough for two maximal frames plus latency.
        let t_end = self.link.down.line_free_ns() + 4 * wire_ns(MAX_FRAME, 9_600);
        let mut status = None;
        let port = &mut self.host_rx;
        self.link.down.deliver(t_end, |b, id| {
            if let Some(Ok(Message::Status(s))) = port.push(b, id) {
                status = Some(s);
            }
        });
        self.device_receive(t_end);
        let mut safe_periods = 0;
        let (mut entries, mut exits) = (0, 0);
        let mut prev = false;
        for s in &self.log {
            let safe = Flags(s.flags).has(Flags::SAFE);
            safe_periods += u64::from(safe);
            entries += u64::from(safe && !prev);
            exits += u64::from(!safe && prev);
            prev = safe;
        }
        let n = self.log.len().max(1) as f64;
        let up_c = self.link.up.counters();
        let down_c = self.link.down.counters();
        LinkReport {
            up: self.dev_rx.account(&self.link.up),
            down: self.host_rx.account(&self.link.down),
            device: status,
            safe_periods,
            safe_entries_seen: entries,
            safe_exits_seen: exits,
            host_clamped: self.host_clamped,
            mean_bytes: (up_c.bytes_sent as f64 / n, down_c.bytes_sent as f64 / n),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use wheelset_control::Fx;

    fn sample(k: u64) -> HostSample {
        HostSample {
            y_dot: 1e-3 * ((k as f64) * 0.01).sin(),
            i_a: 0.0,
            w_m: 925.6,
            demand_nm: 0.0,
        }
    }

    fn run(faults: &str, periods: u64) -> (DeviceLoop<Fx>, LinkReport) {
        let link = LinkConfig {
            faults: faults.parse().expect("valid spec"),
            seed: 11,
            ..LinkConfig::default()
        };
        let mut d = DeviceLoop::<Fx>::try_new(RuntimeConfig::default(), &link).expect("fits");
        let t = d.period_ns();
        for k in 0..periods {
            let _ = d.exchange(k * t, &sample(k), (0.0, 3961.6));
        }
        let r = d.finish();
        (d, r)
    }

    #[test]
    fn clean_link_echoes_every_sample_within_the_period() {
        let (d, r) = run("", 2000);
        assert!(d
            .log()
            .iter()
            .all(|s| s.fresh && s.age == 0 && s.seq_echo == s.seq));
        assert_eq!((r.up.received, r.up.rejected, r.up.dropped), (2001, 0, 0));
        assert_eq!(
            (r.down.received, r.down.rejected, r.down.dropped),
            (2001, 0, 0)
        );
        let st = r.device.expect("status arrives on a clean link");
        assert_eq!(st.rx_ok, 2001);
        assert_eq!(st.safe_entries, 0);
        // Typical frames: within the proto's measured sizes.
        assert!(r.mean_bytes.0 <= 23.0 && r.mean_bytes.1 <= 20.5, "{r}");
    }

    #[test]
    fn faults_are_accounted_and_the_outage_trips_the_safe_state() {
        // 5 kHz: 2 s = 10 000 periods; the outage at 1 s for 50 ms.
        let (d, r) = run("ber=1e-3,drop=0.1,outage=1.0:0.05", 10_000);
        println!("{r}");
        assert!(r.up.adds_up() && r.down.adds_up(), "{r}");
        assert_eq!(r.up.in_flight + r.down.in_flight, 0, "{r}");
        assert!(
            r.up.rejected > 0 && r.up.dropped >= r.up.link_dropped_whole,
            "{r}"
        );
        assert!(r.safe_entries_seen >= 1 && r.safe_exits_seen >= 1, "{r}");
        // The device's own view agrees with the shadow decoder's.
        if let Some(st) = r.device {
            assert_eq!(u64::from(st.rx_ok), r.up.received, "{r}");
            assert!(st.safe_entries >= 1 && st.safe_exits >= 1, "{r}");
        }
        // Frame age grows during the outage and returns to 0 after it.
        let max_age = d.log().iter().map(|s| s.age).max().unwrap_or(0);
        assert!(max_age >= 250, "max age {max_age}");
        assert_eq!(d.log().last().map(|s| s.age), Some(0));
    }

    #[test]
    fn a_sensor_outage_puts_the_safe_outputs_on_the_plant() {
        // Only host -> device is cut: the device's safe state reaches the plant.
        let (d, r) = run("outage=1.0:0.05:up", 10_000);
        let hold = u64::from(wheelset_runtime::DEFAULT_HOLD_TICKS);
        // 250 periods without a sensor frame: `hold` on the held sample, the rest safe.
        assert_eq!(r.safe_periods, 250 - hold, "{r}");
        assert_eq!((r.safe_entries_seen, r.safe_exits_seen), (1, 1), "{r}");
        let st = r.device.expect("status");
        assert_eq!((st.safe_entries, st.safe_exits), (1, 1));
        // (+1: the final tick that answers the status request has no new sample.)
        assert_eq!(st.held_ticks as u64, hold + 1);
        assert_eq!(r.up.dropped, 250, "{r}");
        assert_eq!(r.down.received, r.down.sent, "{r}");
        assert!(d.log().iter().filter(|s| s.age > 0).count() as u64 == 250);
    }

    #[test]
    fn a_link_too_slow_is_refused() {
        let link = LinkConfig {
            baud: 115_200,
            ..LinkConfig::default()
        };
        let e = DeviceLoop::<Fx>::try_new(RuntimeConfig::default(), &link)
            .err()
            .expect("refused");
        let msg = e.to_string();
        assert!(matches!(e, DeviceError::Budget(_)), "{msg}");
        assert!(
            msg.contains("115200 baud") && msg.contains("5000 Hz"),
            "{msg}"
        );
    }
}
