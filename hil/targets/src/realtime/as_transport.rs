//! [`RealTime`] as the one [`Transport`]: frames out as the device's clock allows, frames
//! in as they arrive, each stamped with the host's clock.

#[allow(clippy::wildcard_imports)]
use super::*;

impl Transport for RealTime {
    fn name(&self) -> String {
        self.path.clone()
    }

    fn clock(&self) -> Clock {
        Clock::RealTime
    }

    fn baud(&self) -> u32 {
        self.o.baud
    }

    fn exec_unit(&self) -> (&'static str, f64) {
        ("cycles", 1e9 / self.o.cpu_hz)
    }

    fn send(&mut self, t_ns: u64, bytes: &[u8]) -> Result<(), TransportError> {
        // Only a Sensor frame opens a period (not the status request at the end).
        let mut d: Decoder = Decoder::new();
        let mut sensor = None;
        for r in d.messages(bytes) {
            match r {
                Ok(Message::Sensor(s)) => sensor = Some(s.seq),
                Ok(Message::Command(Command::RequestStatus)) if self.run.synced => {
                    self.run.status_owed = true;
                }
                _ => {}
            }
        }
        if self.run.first_seq.is_none() {
            self.run.first_seq = sensor;
        }
        if let Some(seq) = sensor {
            self.run.last_seq = seq;
        }
        let target = self.wall(t_ns);
        self.wait_until(target)?;
        let late = Instant::now().saturating_duration_since(target).as_nanos() as f64;
        let quarter = (self.o.period_ns / 4) as f64;
        self.write(bytes)?;
        if sensor.is_some() {
            self.run.send_late.push(late);
            self.run.period_missed = late > quarter;
            if self.run.period_missed {
                self.run.late_sends += 1;
            }
        }
        Ok(())
    }

    fn recv(
        &mut self,
        deadline_ns: u64,
        sink: &mut dyn FnMut(u64, &[u8]),
    ) -> Result<(), TransportError> {
        let deadline = self.wall(deadline_ns);
        self.wait_until(deadline)?;
        // A stalled device's closing Status may come after a period: waited for (bounded).
        if self.run.status_owed {
            self.wait_for(|s| s.run.pending.iter().any(|(_, f)| is_status(f)))?;
            self.run.status_owed = false;
            while let Some((at, bytes)) = self.run.pending.pop_front() {
                sink(at.min(deadline_ns), &bytes);
            }
            return Ok(());
        }
        let over = Instant::now()
            .saturating_duration_since(deadline)
            .as_nanos() as f64;
        if self.run.recv_over.len() < self.run.send_late.len() {
            self.run.recv_over.push(over);
            if over > (self.o.period_ns / 4) as f64 {
                self.run.late_receives += 1;
                self.run.period_missed = true;
            }
            if std::mem::take(&mut self.run.period_missed) {
                self.run.missed += 1;
            }
        }
        while let Some((at, _)) = self.run.pending.front() {
            if *at > deadline_ns {
                break;
            }
            if let Some((at, bytes)) = self.run.pending.pop_front() {
                sink(at, &bytes);
            }
        }
        Ok(())
    }

    fn extra(&self) -> Option<serde_json::Value> {
        Some(serde_json::json!({
            "pace": "realtime",
            "realtime": self.obtained,
            "host": self.host_report(),
            "sync": self.run.sync,
            // The free-running QEMU's own core and priority (`--target qemu-free`).
            "device_process": match &self.port {
                Port::Tcp(_, Some(q)) => serde_json::to_value(q.launch()).ok(),
                _ => None,
            },
        }))
    }
}
