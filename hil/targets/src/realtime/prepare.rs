//! [`RealTime::prepare`]: the start of a run against a free-running device.

use std::time::{Duration, Instant};

use wheelset_loop::sim_link::wire_ns;
use wheelset_proto::{encode_vec, Command, Config, Flags, Message, Status};

use wheelset_loop::transport::TransportError;

use super::{lower_decile, median_exec_ns, wrap, Port, RealTime, PHASE_FRAMES, ROUND_TRIP_PROBES};

fn status_request() -> Result<Vec<u8>, TransportError> {
    encode_vec(&Message::Command(Command::RequestStatus))
        .map(|f| f.to_vec())
        .map_err(|e| TransportError::Io(format!("cannot encode a status request: {e:?}")))
}

impl RealTime {
    /// [`SyncReport::lead_ns`](super::SyncReport::lead_ns).
    fn lead_ns(&self) -> u64 {
        self.o.period_ns * self.o.lead_num.clamp(1, 7) / 8
    }

    /// Reads until a Status frame arrives after this call (at most `timeout`).
    fn await_status(&mut self, what: &str) -> Result<Status, TransportError> {
        self.run.last_status = None;
        self.wait_for(|s| s.run.last_status.is_some())?;
        self.run.last_status.take().ok_or_else(|| {
            TransportError::Timeout(format!(
                "{}: no Status frame within {:?} after {what}",
                self.path, self.o.timeout
            ))
        })
    }

    /// Configures the device with `cfg`, takes the baseline and locks to its tick phase.
    pub fn prepare(&mut self, cfg: &Config) -> Result<(), TransportError> {
        let t = self.o.period_ns;
        // 1. Is anybody there, ticking on its own?
        let listen = Instant::now() + Duration::from_nanos((4 * t).max(20_000_000));
        self.wait_until(listen)?;
        if !self.wait_for(|s| s.run.sync.pre_run != 0)? {
            return Err(TransportError::Timeout(format!(
                "{}: the device sent nothing in {:?}: a free-running device \
                 answers every tick (a frame-clocked one needs --pace lockstep)",
                self.path, self.o.timeout
            )));
        }
        // 2. The run's configuration, checked.
        let mut out = encode_vec(&Message::Config(*cfg))
            .map(|f| f.to_vec())
            .map_err(|e| TransportError::Io(format!("cannot encode the start-up frames: {e:?}")))?;
        out.extend(status_request()?);
        self.write(&out)?;
        let s = self.await_status("the Config frame")?;
        if s.flags.has(Flags::CMD_REFUSED) {
            let why = wheelset_proto::RefuseReason::from_code(s.refuse_reason);
            return Err(TransportError::Unavailable(format!(
                "{}: the device refused the run's configuration (Status cmd_refused \
                 {}, reason {}): another sample type or control core than this harness's \
                 fixed-point default, or a rate its link cannot carry",
                self.path,
                s.cmd_refused,
                why.map_or_else(|| format!("code {}", s.refuse_reason), |w| w.to_string())
            )));
        }
        // A re-armed ticker settles; the round trip is probed; 3. the baseline.
        let settle = Instant::now() + Duration::from_nanos(3 * t);
        self.wait_until(settle)?;
        if matches!(self.port, Port::Tty(_)) {
            let delay = cfg.rates.map_or(1, |r| r.delay_ticks);
            self.check_round_trip(delay)?;
        }
        self.write(&status_request()?)?;
        let b = self.await_status("the baseline status request")?;
        self.run.baseline = Some(b);
        // 4. The device's phase and period.
        self.run.seen.clear();
        self.wait_for(|s| s.run.seen.len() >= PHASE_FRAMES)?;
        let seen = std::mem::take(&mut self.run.seen);
        if seen.len() < PHASE_FRAMES {
            return Err(TransportError::Timeout(format!(
                "{}: {} of {PHASE_FRAMES} Actuation frames within {:?} after the \
                 baseline: the device does not answer every tick",
                self.path,
                seen.len(),
                self.o.timeout
            )));
        }
        let tf = t as f64;
        let outs: Vec<f64> = seen
            .iter()
            .map(|&(at, n, _, _)| at as f64 - wire_ns(n, self.o.baud) as f64)
            .collect();
        // The period: the lower envelope's slope (robust to skipped ticks and bursts).
        let measured = envelope_period(&seen.iter().map(|s| s.2).collect::<Vec<_>>(), &outs, tf);
        self.run.sync.device_period_ns = measured;
        if (measured - tf).abs() > 0.1 * tf {
            return Err(TransportError::Unavailable(format!(
                "{}: the device ticks every {:.1} us, not every {:.1} us of the run's \
                 rate: it did not take the rate (--rate-hz) or cannot hold it",
                self.path,
                measured * 1e-3,
                tf * 1e-3
            )));
        }
        // The phase of its output instants: the lower decile of the residuals modulo T.
        let first = outs.first().copied().unwrap_or(0.0);
        let mut res: Vec<f64> = outs.iter().map(|&o| wrap(o - first, tf)).collect();
        let phase = first + lower_decile(&mut res);
        // Its tick: the output instant less the median reported execution time.
        let exec_ns = median_exec_ns(seen.iter().map(|s| s.3), self.o.cpu_hz);
        // The first send half a period before a device tick at least two periods away.
        let now = self.at_ns(Instant::now()) as f64;
        let mut tick_at = phase - exec_ns;
        let k = ((now + 2.0 * tf - tick_at) / tf).ceil().max(0.0);
        tick_at += k * tf;
        let lead = self.lead_ns();
        self.run.sync.lead_ns = lead;
        let first = (tick_at - lead as f64).max(now) as u64;
        // The device's output phase on the run's clock (origin = `first`).
        self.run.phase_ref_ns = wrap(phase - first as f64, tf);
        self.origin += Duration::from_nanos(first);
        // Everything read so far is pre-run (stamped against the old origin).
        self.run.pending.clear();
        Ok(())
    }

    /// Probes the round trip with [`ROUND_TRIP_PROBES`] status requests and refuses a run
    /// whose `delay` it does not fit: both ways' latency plus the Sensor frame's wire time
    /// must be within `lead + (d - 1) T` for a delay of `d` ticks (reported in `sync`).
    fn check_round_trip(&mut self, delay: u8) -> Result<(), TransportError> {
        let t = self.o.period_ns;
        let req = status_request()?;
        let step = t / ROUND_TRIP_PROBES;
        let mut best: Option<(f64, usize)> = None;
        for i in 0..ROUND_TRIP_PROBES {
            // Request i at i/32 of a period after the last Status: a later tick phase each.
            let now = Instant::now();
            let mut at = self.run.last_status_at.map_or(now, |(at, _)| self.wall(at))
                + Duration::from_nanos(i * step);
            while at < now {
                at += self.period();
            }
            self.wait_until(at)?;
            let sent = self.at_ns(Instant::now());
            self.write(&req)?;
            self.await_status("a round-trip probe")?;
            if let Some((at, n)) = self.run.last_status_at {
                let rt = at.saturating_sub(sent) as f64;
                if best.is_none_or(|(b, _)| rt < b) {
                    best = Some((rt, n));
                }
            }
        }
        let (rt, status_bytes) = best.unwrap_or((0.0, 0));
        let wire = |n: usize| wire_ns(n, self.o.baud) as f64;
        let latest = self.run.seen.iter().rev().take(PHASE_FRAMES);
        let exec = median_exec_ns(latest.map(|s| s.3), self.o.cpu_hz);
        let before = rt
            - exec
            - wire(status_bytes)
            - wire(wheelset_proto::ACTUATION_MAX_FRAME)
            - wire(req.len())
            + wire(wheelset_proto::SENSOR_ONE_LATERAL_MAX_FRAME);
        let before = (before - step as f64).max(0.0);
        self.run.sync.round_trip_ns = rt;
        self.run.sync.before_tick_ns = before;
        let lead = self.lead_ns() as f64;
        let tf = t as f64;
        let allowed = lead + f64::from(delay.max(1) - 1) * tf;
        if before <= allowed {
            return Ok(());
        }
        // The least delay that fits, and whether the device has gains for it.
        let need = ((before - lead) / tf).ceil().max(0.0) as u64 + 1;
        let rate = cfg_rate(t);
        let designed: Vec<u8> = wheelset_control::design::DESIGNED
            .iter()
            .filter(|p| p.base_rate_hz == rate && u64::from(p.delay_ticks) >= need)
            .map(|p| p.delay_ticks)
            .collect();
        let remedy = match designed.first() {
            Some(d) => format!("pipeline the exchange: --delay-ticks {d}"),
            None => format!(
                "no delay designed for {rate} Hz is that long: a lower rate (`sim-host rates \
                 --max-baud B --latency-us L --delay D` chooses a designed rate and delay \
                 for the link)"
            ),
        };
        Err(TransportError::Unavailable(format!(
            "{}: the link's round trip is {:.0} us (the least of {ROUND_TRIP_PROBES} status \
             requests), so a Sensor frame needs {:.0} us (both ways' latency and its wire \
             time) to reach the device's tick, longer than the {:.0} us a run with \
             --delay-ticks {delay} at {rate} Hz gives it ({:.0} us of lead{}): every answer \
             would miss its deadline; {remedy}",
            self.path,
            rt * 1e-3,
            before * 1e-3,
            allowed * 1e-3,
            lead * 1e-3,
            if delay > 1 {
                format!(" and {} period(s)", delay - 1)
            } else {
                String::new()
            },
        )))
    }
}

/// The rate of a period of `t` ns, Hz.
fn cfg_rate(t: u64) -> u32 {
    u32::try_from(1_000_000_000 / t.max(1)).unwrap_or(u32::MAX)
}

/// The device's period, ns, from output instants `outs` and 16-bit `ticks`:
/// `T = t + (r_b - r_a) / (j_b - j_a)`, residuals `r_i = o_i - j_i t`, `a` and `b` the least
/// residual of each half (delays only raise residuals). 0 if under 4 frames or one tick.
#[must_use]
pub fn envelope_period(ticks: &[u16], outs: &[f64], t: f64) -> f64 {
    let n = ticks.len().min(outs.len());
    let (Some(&j0), true) = (ticks.first(), n >= 4) else {
        return 0.0;
    };
    let least = |r: std::ops::Range<usize>| {
        r.map(|i| {
            let j = f64::from(ticks.get(i).copied().unwrap_or(j0).wrapping_sub(j0));
            (outs.get(i).copied().unwrap_or(0.0) - j * t, j)
        })
        .min_by(|x, y| x.0.total_cmp(&y.0))
        .unwrap_or((0.0, 0.0))
    };
    let (ra, ja) = least(0..n / 2);
    let (rb, jb) = least(n / 2..n);
    if jb <= ja {
        return 0.0;
    }
    t + (rb - ra) / (jb - ja)
}
