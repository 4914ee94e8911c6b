//! The in-process device: the firmware's [`Runtime`] behind the simulated link of
//! [`crate::sim_link`] as a [`Transport`], deterministic for a seed. Tick `j` runs at
//! `t_j = j T + phase`, `phase` = worst-case Sensor frame wire time + link latency, so the
//! frame sent at `k T` has arrived by tick `k`; each end's [`RxPort`] accounts every frame.

use std::time::Instant;

use wheelset_control::{Fx, SampleBits};
use wheelset_proto::{
    encode_vec, Decoder, Message, ACTUATION_MAX_FRAME, SENSOR_ONE_LATERAL_MAX_FRAME,
};
use wheelset_report::stats::Stats;
use wheelset_runtime::{Runtime, RuntimeConfig};

use crate::device_loop::DeviceError;
use crate::sim_link::{check_budget, wire_ns, Link, LinkConfig, RxPort};
use crate::transport::{Clock, FrameSink, LinkAccounting, Transport, TransportError};

/// A deliberately broken device, to prove the checks can fail.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum DeviceFault {
    /// A correct device.
    #[default]
    None,
    /// The yaw torque's sign is reversed (a wrong sign convention in the firmware).
    WrongSign,
    /// Every tick takes `exec_ns` of simulated time before its frame leaves.
    TooSlow {
        /// Simulated execution time per tick, ns.
        exec_ns: u64,
    },
    /// Each tick takes a seeded uniform execution time in `[0, max_ns]`.
    Jitter {
        /// Largest execution time, ns.
        max_ns: u64,
    },
    /// Every `every`-th outgoing frame has one bit flipped (a broken UART or buffer).
    Corrupt {
        /// Period of the corruption, frames (>= 1).
        every: u32,
    },
    /// `Command::InjectStall` at `at_ns` to a `fault-inject` firmware, whose watchdog
    /// resets it; not for the in-process device, which has no watchdog.
    Stall {
        /// When the command goes out, ns of the run.
        at_ns: u64,
    },
}

impl std::fmt::Display for DeviceFault {
    /// The `--device-fault` form that parses back to it (times in us, the stall's in s).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let us = |ns: u64| ns as f64 * 1e-3;
        match *self {
            Self::None => f.write_str("none"),
            Self::WrongSign => f.write_str("wrong-sign"),
            Self::TooSlow { exec_ns } => write!(f, "slow:{}", us(exec_ns)),
            Self::Jitter { max_ns } => write!(f, "jitter:{}", us(max_ns)),
            Self::Corrupt { every } => write!(f, "corrupt:{every}"),
            Self::Stall { at_ns } => write!(f, "stall:{}", at_ns as f64 * 1e-9),
        }
    }
}

impl std::str::FromStr for DeviceFault {
    type Err = String;

    /// `none`, `wrong-sign`, `slow[:EXEC_US]` (default 300 us), `jitter[:MAX_US]`
    /// (default 40 us), `corrupt[:EVERY]` (default every 10th frame), `stall:T` (T in s).
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let (kind, arg) = match s.split_once(':') {
            Some((k, a)) => (k, Some(a)),
            None => (s, None),
        };
        let num = |a: Option<&str>, default: u64| -> Result<u64, String> {
            match a {
                None => Ok(default),
                Some(a) => a
                    .parse::<u64>()
                    .ok()
                    .filter(|&v| v > 0)
                    .ok_or_else(|| format!("`{a}` is not a positive whole number")),
            }
        };
        match kind {
            "none" => Ok(Self::None),
            "wrong-sign" => Ok(Self::WrongSign),
            "slow" => Ok(Self::TooSlow {
                exec_ns: num(arg, 300)?.saturating_mul(1_000),
            }),
            "jitter" => Ok(Self::Jitter {
                max_ns: num(arg, 40)?.saturating_mul(1_000),
            }),
            "corrupt" => Ok(Self::Corrupt {
                every: u32::try_from(num(arg, 10)?).map_err(|e| e.to_string())?,
            }),
            "stall" => {
                let t = arg.ok_or("stall:T needs the time T of the run, s")?;
                match t.parse::<f64>() {
                    Ok(v) if v.is_finite() && v >= 0.0 => Ok(Self::Stall {
                        at_ns: (v * 1e9).round() as u64,
                    }),
                    _ => Err(format!("stall:{t}: T must be a time of the run, s (>= 0)")),
                }
            }
            _ => Err(format!(
                "unknown device fault `{s}` (known: none, wrong-sign, slow[:EXEC_US], jitter[:MAX_US], corrupt[:EVERY], stall:T)"
            )),
        }
    }
}

/// The in-process device behind the simulated link (`T`: the runtime's sample type).
pub struct InProc<T: SampleBits = Fx> {
    link: Link,
    latency_ns: u64,
    baud: u32,
    rt: Runtime<T>,
    dev_rx: RxPort,
    /// The device's decoder holds bytes of an unfinished frame (see [`outcome`]).
    dev_frame_open: bool,
    host_rx: RxPort,
    fault: DeviceFault,
    period_ns: u64,
    phase_ns: u64,
    next_tick: u64,
    last_exec: u32,
    frames_out: u64,
    /// The execution times of [`DeviceFault::Jitter`] (a fixed seed).
    jitter: rand_pcg::Pcg64,
    /// A tick's output as a broken device changes it.
    scratch: Vec<u8>,
    /// Arrival time of the last byte of each down-link frame (index: frame id).
    arrival_ns: Vec<u64>,
    timed: bool,
    host_tick_ns: Vec<f64>,
}

impl<T: SampleBits> InProc<T> {
    /// The runtime with `rt_cfg` behind a link with `link_cfg`, or why it is refused.
    pub fn try_new(
        rt_cfg: RuntimeConfig,
        link_cfg: &LinkConfig,
        fault: DeviceFault,
    ) -> Result<Self, DeviceError> {
        let hz = rt_cfg.control.base_rate_hz;
        if hz == 0 || 1_000_000_000 % u64::from(hz) != 0 {
            return Err(DeviceError::Rate(hz));
        }
        let period_ns = 1_000_000_000 / u64::from(hz);
        check_budget(
            SENSOR_ONE_LATERAL_MAX_FRAME,
            ACTUATION_MAX_FRAME,
            link_cfg.baud,
            link_cfg.latency_ns,
            period_ns,
            u32::from(rt_cfg.control.delay_ticks),
        )?;
        let rt = Runtime::<T>::try_new(rt_cfg).map_err(DeviceError::Runtime)?;
        Ok(Self {
            link: Link::new(link_cfg),
            latency_ns: link_cfg.latency_ns,
            baud: link_cfg.baud,
            rt,
            dev_rx: RxPort::default(),
            dev_frame_open: false,
            host_rx: RxPort::default(),
            fault,
            period_ns,
            phase_ns: wire_ns(SENSOR_ONE_LATERAL_MAX_FRAME, link_cfg.baud) + link_cfg.latency_ns,
            next_tick: 0,
            last_exec: 0,
            frames_out: 0,
            jitter: rand::SeedableRng::seed_from_u64(0x6a69_7474_6572),
            scratch: Vec::new(),
            arrival_ns: Vec::new(),
            timed: true,
            host_tick_ns: Vec::new(),
        })
    }

    /// Whether the host's wall time per [`Runtime::tick`] is measured for
    /// [`Transport::extra`] (default on; nothing the device does depends on it).
    pub fn time_ticks(&mut self, on: bool) {
        self.timed = on;
    }

    /// Brings the device to `cfg` out of band (through the runtime's receive path, then a
    /// `ResetCounters`), so the first period's timing is the run's own; or the refusal.
    pub fn configure(
        &mut self,
        cfg: &wheelset_proto::Config,
    ) -> Result<(), wheelset_proto::RefuseReason> {
        use wheelset_proto::{Command, RefuseReason};
        let frame = encode_vec(&Message::Config(*cfg)).map_err(|_| RefuseReason::Bits)?;
        self.rt.receive(&frame);
        let why = self.rt.refuse_reason();
        if why != RefuseReason::None && self.rt.counters().cmd_refused > 0 {
            return Err(why);
        }
        let reset = encode_vec(&Message::Command(Command::ResetCounters))
            .map_err(|_| RefuseReason::Bits)?;
        self.rt.receive(&reset);
        Ok(())
    }

    /// The control period `T`, ns.
    #[must_use]
    pub fn period_ns(&self) -> u64 {
        self.period_ns
    }

    /// Every frame of both directions accounted for (see the module docs).
    #[must_use]
    pub fn accounting(&self) -> LinkAccounting {
        LinkAccounting {
            up: self.dev_rx.account(&self.link.up),
            down: self.host_rx.account(&self.link.down),
        }
    }

    fn tick(&mut self, t_ns: u64) {
        let (rt, port, open) = (&mut self.rt, &mut self.dev_rx, &mut self.dev_frame_open);
        self.link.up.deliver(t_ns, |run, id| {
            port.push_with(run, id, |piece| {
                let before = rx_counts(rt.counters());
                rt.receive(piece);
                outcome(piece, open, before, rx_counts(rt.counters()))
            });
        });
        let start = self.timed.then(Instant::now);
        let out = self.rt.tick(self.last_exec);
        if let Some(start) = start {
            let measured = u32::try_from(start.elapsed().as_nanos()).unwrap_or(u32::MAX);
            self.host_tick_ns.push(f64::from(measured));
        }
        let (out, exec_ns): (&[u8], u64) = match self.fault {
            DeviceFault::None | DeviceFault::Stall { .. } => (out, 0),
            DeviceFault::WrongSign => {
                negate_torque(out, &mut self.scratch);
                (&self.scratch, 0)
            }
            DeviceFault::TooSlow { exec_ns } => (out, exec_ns),
            DeviceFault::Jitter { max_ns } => {
                use rand::Rng as _;
                (out, self.jitter.random_range(0..=max_ns))
            }
            DeviceFault::Corrupt { every } => {
                self.scratch.clear();
                self.scratch.extend_from_slice(out);
                if self.frames_out.is_multiple_of(u64::from(every.max(1))) && out.len() > 3 {
                    if let Some(b) = self.scratch.get_mut(2) {
                        *b ^= 0x10;
                    }
                }
                (&self.scratch, 0)
            }
        };
        self.last_exec = u32::try_from(exec_ns).unwrap_or(u32::MAX);
        self.frames_out += 1;
        // Each frame is its own on the link, stamped with the arrival of its last byte.
        let (down, arrival, latency) = (&mut self.link.down, &mut self.arrival_ns, self.latency_ns);
        let mut send = |frame: &[u8]| {
            let id = down.send(t_ns + exec_ns, frame) as usize;
            if arrival.len() <= id {
                arrival.resize(id + 1, 0);
            }
            if let Some(a) = arrival.get_mut(id) {
                *a = down.line_free_ns() + latency;
            }
        };
        match out.split_last() {
            Some((&0, head)) if !head.contains(&0) => send(out),
            _ => out.split_inclusive(|&b| b == 0).for_each(send),
        }
    }
}

/// The device's receive counters: valid, the rejections in [`wheelset_proto::FrameError::KINDS`]'
/// order (CRC, COBS, version, length, postcard), unexpected.
#[inline(always)]
#[must_use]
pub fn rx_counts(s: &wheelset_proto::Status) -> [u32; 7] {
    [
        s.rx_ok,
        s.rx_crc,
        s.rx_cobs,
        s.rx_version,
        s.rx_length,
        s.rx_postcard,
        s.rx_unexpected,
    ]
}

/// The outcome of the frame one [`Runtime::receive`] on `piece` closed, from the runtime's
/// counters; `open`: its decoder holds an unfinished frame.
fn outcome(
    piece: &[u8],
    open: &mut bool,
    before: [u32; 7],
    after: [u32; 7],
) -> Option<Result<(), wheelset_proto::FrameError>> {
    use wheelset_proto::FrameError;
    let closes = piece.last() == Some(&0);
    let nonempty = *open || piece.len() > usize::from(closes);
    *open = !closes && nonempty;
    if !(closes && nonempty) {
        return None;
    }
    let kind = (before.into_iter().skip(1))
        .zip(after.into_iter().skip(1))
        .zip(FrameError::KINDS)
        .find_map(|((b, a), e)| (a == b.wrapping_add(1)).then_some(e));
    Some(kind.map_or(Ok(()), Err))
}

fn negate_torque(out: &[u8], res: &mut Vec<u8>) {
    let mut dec: Decoder = Decoder::new();
    res.clear();
    for mut m in dec.messages(out).flatten() {
        if let Message::Actuation(a) = &mut m {
            a.t_psi_dnm = a.t_psi_dnm.saturating_neg();
        }
        if let Ok(f) = encode_vec(&m) {
            res.extend_from_slice(&f);
        }
    }
}

impl<T: SampleBits> InProc<T> {
    fn ticks_until(&mut self, deadline_ns: u64) {
        loop {
            let t = self.next_tick * self.period_ns + self.phase_ns;
            if t > deadline_ns {
                break;
            }
            self.tick(t);
            self.next_tick += 1;
        }
    }
}

impl<T: SampleBits> Transport for InProc<T> {
    fn name(&self) -> String {
        "inproc".into()
    }

    fn clock(&self) -> Clock {
        Clock::Simulated
    }

    fn baud(&self) -> u32 {
        self.baud
    }

    fn exec_unit(&self) -> (&'static str, f64) {
        ("ns", 1.0)
    }

    fn send(&mut self, t_ns: u64, bytes: &[u8]) -> Result<(), TransportError> {
        self.link.up.send(t_ns, bytes);
        Ok(())
    }

    fn recv(
        &mut self,
        deadline_ns: u64,
        sink: &mut dyn FnMut(u64, &[u8]),
    ) -> Result<(), TransportError> {
        self.ticks_until(deadline_ns);
        let (port, arrival) = (&mut self.host_rx, &self.arrival_ns);
        self.link.down.deliver(deadline_ns, |run, id| {
            port.push(run, id, |_| {});
            let at = arrival.get(id as usize).copied().unwrap_or(deadline_ns);
            sink(at, run);
        });
        Ok(())
    }

    /// The host's decoder decides each frame; the down link's port attributes it.
    fn recv_frames(
        &mut self,
        deadline_ns: u64,
        dec: &mut Decoder,
        sink: &mut FrameSink<'_>,
    ) -> Result<(), TransportError> {
        self.ticks_until(deadline_ns);
        let (port, arrival) = (&mut self.host_rx, &self.arrival_ns);
        self.link.down.deliver(deadline_ns, |run, id| {
            let at = arrival.get(id as usize).copied().unwrap_or(deadline_ns);
            port.push_with(run, id, |piece| {
                let (r, _) = dec.next_message(piece);
                let outcome = r.as_ref().map(|r| r.as_ref().map(|_| ()).map_err(|e| *e));
                sink(at, piece.len(), r);
                outcome
            });
        });
        Ok(())
    }

    fn extra(&self) -> Option<serde_json::Value> {
        // The host's wall time per tick, ns: `{n, min, mean, p99, max}`.
        Some(serde_json::json!({ "host_tick_ns": Stats::of(&self.host_tick_ns) }))
    }

    fn link_accounting(&self) -> Option<LinkAccounting> {
        Some(self.accounting())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn device_fault_prints_the_form_it_parses_from() {
        for s in [
            "none",
            "wrong-sign",
            "slow:300",
            "jitter:40",
            "corrupt:10",
            "stall:6.5",
        ] {
            assert_eq!(
                s.parse::<DeviceFault>().map(|f| f.to_string()),
                Ok(s.to_string())
            );
        }
    }

    #[test]
    fn device_fault_parses_and_refuses() {
        assert_eq!("none".parse(), Ok(DeviceFault::None));
        assert_eq!("wrong-sign".parse(), Ok(DeviceFault::WrongSign));
        assert_eq!(
            "slow".parse(),
            Ok(DeviceFault::TooSlow { exec_ns: 300_000 })
        );
        assert_eq!(
            "slow:50".parse(),
            Ok(DeviceFault::TooSlow { exec_ns: 50_000 })
        );
        assert_eq!("corrupt:3".parse(), Ok(DeviceFault::Corrupt { every: 3 }));
        assert_eq!(
            "stall:1.5".parse(),
            Ok(DeviceFault::Stall {
                at_ns: 1_500_000_000
            })
        );
        assert!("stall".parse::<DeviceFault>().is_err());
        assert!("stall:-1".parse::<DeviceFault>().is_err());
        assert!("stall:nan".parse::<DeviceFault>().is_err());
        for bad in ["slow:0", "slow:x", "corrupt:-1", "sideways"] {
            assert!(bad.parse::<DeviceFault>().is_err(), "{bad}");
        }
    }

    #[test]
    fn the_host_tick_summary_is_the_nearest_rank_p99() {
        let summary = |v: &[f64]| serde_json::json!(Stats::of(v));
        let v: Vec<f64> = (1..=200).map(f64::from).collect();
        let s = summary(&v);
        assert_eq!(s["n"], 200);
        assert_eq!(s["p99"], 198.0);
        assert_eq!(s["max"], 200.0);
        assert_eq!(summary(&[])["n"], 0);
    }
}
