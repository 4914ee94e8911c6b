//! The closed loop through a [`Transport`]: the plant of `sim_host::sim::run_sampled`
//! calls [`DeviceController::step`] once per control period `T`; each call is one
//! exchange with the device:
//!
//! ```text
//! t_k        measurements -> Sensor frame (seq k, wire LSBs of wheelset-proto) -> send
//! t_k .. t_k + T   receive until the deadline t_k + T; every valid Actuation frame is
//!                  recorded (arrival time, seq_echo, exec, flags, device tick)
//! t_k + T    the latest valid actuation received is applied (ZOH; `run_sampled` with an
//!            actuator delay of one period), or the previous one is held
//! ```
//!
//! So the plant sees the one-period computation/transport delay the control core's rate
//! analysis assumes, on every target alike. At the end, [`DeviceController::finish`]
//! asks the device for its counters (a Status frame) and drains the link.

use indicatif::ProgressBar;
use sim_host::control::{Actuation as SiActuation, Measurements, SampledController};
use wheelset_proto::units::{
    quantize, to_si, CURRENT_LSB_A, DEMAND_LSB_NM, LAT_VEL_LSB_M_PER_S, SPEED_LSB_RAD_PER_S,
    TORQUE_LSB_NM, VOLTAGE_LSB_V,
};
use wheelset_proto::{
    encode_vec, Actuation, Command, Decoder, FrameError, Lateral, Message, Sensor, Status,
};

use crate::transport::{Transport, TransportError};

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

/// Host-side frame counts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct HostCounts {
    /// Frames the host sent (Sensor + Command).
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

/// The device as a sampled controller of the plant, through a transport.
pub struct DeviceController<'a> {
    tr: &'a mut dyn Transport,
    period_ns: u64,
    k_m: f64,
    decoder: Decoder,
    seq: u16,
    k: u64,
    held: Option<SiActuation>,
    rx_buf: Vec<(u64, u8)>,
    frame_bytes: usize,
    /// Every Actuation frame received, in order.
    pub actuations: Vec<RxActuation>,
    /// Every period.
    pub periods: Vec<Period>,
    /// The sensor samples sent, in wire codes, one per period (a recorded sensor stream).
    pub sent_codes: Vec<wheelset_control::InputCodes>,
    /// Host-side counts.
    pub host: HostCounts,
    /// The device's counters, if its Status frame arrived.
    pub status: Option<Status>,
    /// The first transport error; the loop holds the last actuation after it.
    pub error: Option<TransportError>,
    progress: Option<ProgressBar>,
    status_seen: bool,
}

impl<'a> DeviceController<'a> {
    /// A controller with period `period_ns` talking through `tr`; `k_m` (V s/rad) gives
    /// the back-EMF voltage held before the first actuation frame arrives.
    pub fn new(
        tr: &'a mut dyn Transport,
        period_ns: u64,
        k_m: f64,
        progress: Option<ProgressBar>,
    ) -> Self {
        Self {
            tr,
            period_ns,
            k_m,
            decoder: Decoder::new(),
            seq: 0,
            k: 0,
            held: None,
            rx_buf: Vec::new(),
            frame_bytes: 0,
            actuations: Vec::new(),
            periods: Vec::new(),
            sent_codes: Vec::new(),
            host: HostCounts::default(),
            status: None,
            error: None,
            progress,
            status_seen: false,
        }
    }

    fn q(&mut self, x: f64, lsb: f64) -> i32 {
        let (v, c) = quantize(x, lsb);
        self.host.clamped += u64::from(c);
        v
    }

    fn send(&mut self, t_ns: u64, m: &Message) {
        let Ok(frame) = encode_vec(m) else { return };
        self.host.sent += 1;
        self.host.bytes_sent += frame.len() as u64;
        if self.error.is_none() {
            if let Err(e) = self.tr.send(t_ns, &frame) {
                self.error = Some(e);
            }
        }
    }

    fn receive(&mut self, deadline_ns: u64) {
        if self.error.is_some() {
            return;
        }
        let buf = &mut self.rx_buf;
        buf.clear();
        if let Err(e) = self.tr.recv(deadline_ns, &mut |at, bytes| {
            buf.extend(bytes.iter().map(|&b| (at, b)));
        }) {
            self.error = Some(e);
        }
        let bytes = std::mem::take(&mut self.rx_buf);
        for &(at, b) in &bytes {
            self.host.bytes_received += 1;
            self.frame_bytes += 1;
            let Some(r) = self.decoder.push(b) else {
                continue;
            };
            let n = std::mem::take(&mut self.frame_bytes);
            self.on_frame(at, n, r);
        }
        self.rx_buf = bytes;
    }

    fn on_frame(&mut self, at_ns: u64, wire_bytes: usize, r: Result<Message, FrameError>) {
        if !self.status_seen {
            match r {
                Ok(_) => self.host.received += 1,
                Err(_) => self.host.rejected += 1,
            }
        }
        match r {
            Ok(Message::Actuation(a)) => {
                // Unwrap the 16-bit echo against the host's own sample count.
                let echo = (a.seq_echo != 0 || self.k > 0xffff).then(|| {
                    let diff = self.seq.wrapping_sub(a.seq_echo);
                    self.k.saturating_sub(u64::from(diff))
                });
                let echo = echo.map(|e| e.saturating_sub(1));
                self.actuations.push(RxActuation {
                    at_ns,
                    wire_bytes,
                    echo,
                    frame: a,
                });
                self.held = Some(SiActuation {
                    t_psi: to_si(a.t_psi_dnm, TORQUE_LSB_NM),
                    u_a: to_si(a.u_a_cv, VOLTAGE_LSB_V),
                });
                if let (Some(e), Some(p)) = (echo, self.periods.last_mut()) {
                    if e + 1 == self.k && p.echo_at_ns.is_none() {
                        p.echo_at_ns = Some(at_ns);
                    }
                }
            }
            Ok(Message::Status(s)) => {
                self.status = Some(s);
                self.status_seen = true;
            }
            _ => {}
        }
    }

    /// Ends the run at `t_ns` (the end of the last period): requests the device's
    /// counters, and receives for three more periods so the Status frame and everything
    /// in flight arrive.
    pub fn finish(&mut self, t_ns: u64) {
        self.send(t_ns, &Message::Command(Command::RequestStatus));
        for j in 1..=3 {
            self.receive(t_ns + j * self.period_ns);
        }
        if let Some(pb) = &self.progress {
            pb.finish_and_clear();
        }
    }
}

impl SampledController for DeviceController<'_> {
    fn period_ns(&self) -> u64 {
        self.period_ns
    }

    fn step(&mut self, t_ns: u64, m: &Measurements) -> SiActuation {
        self.seq = self.seq.wrapping_add(1);
        self.k += 1;
        let sensor = Sensor {
            seq: self.seq,
            t_us: ((t_ns / 1_000) & 0xffff) as u16,
            lateral: Lateral::Velocity(self.q(m.yd_mps, LAT_VEL_LSB_M_PER_S)),
            i_a_ma: self.q(m.i_a, CURRENT_LSB_A),
            omega_m_mrad_s: self.q(m.w_m, SPEED_LSB_RAD_PER_S),
            demand_nm: self.q(m.demand_nm, DEMAND_LSB_NM),
        };
        if let Lateral::Velocity(v) = sensor.lateral {
            self.sent_codes.push(wheelset_control::InputCodes {
                y_dot: v,
                current: sensor.i_a_ma,
                speed: sensor.omega_m_mrad_s,
                demand: sensor.demand_nm,
            });
        }
        let before = self.host.bytes_sent;
        self.send(t_ns, &Message::Sensor(sensor));
        self.periods.push(Period {
            t_ns,
            sensor_bytes: (self.host.bytes_sent - before) as usize,
            echo_at_ns: None,
        });
        self.receive(t_ns + self.period_ns);
        if let Some(pb) = &self.progress {
            if self.k.is_multiple_of(1024) {
                pb.set_position(t_ns / 1_000_000);
            }
        }
        // Before the first valid actuation: the plant's initial actuation (zero torque,
        // back-EMF voltage), as `run_sampled` started with.
        self.held.unwrap_or(SiActuation {
            t_psi: 0.0,
            u_a: self.k_m * m.w_m,
        })
    }
}
