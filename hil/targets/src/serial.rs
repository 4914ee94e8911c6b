//! The serial-port target: a board on a serial port (`serialport`, default features off:
//! no libudev). Two pacings: [`Pace::RealTime`] (the default, a board ticking on its own
//! timer: [`crate::realtime::RealTime`]) and [`Pace::LockStep`] (a frame-clocked device,
//! or [`serve_lockstep`] behind a pseudo-terminal in the tests: [`Serial`] waits for each
//! tick's answer, and the timing is modelled from the baud and the reported `exec`).

use std::io::{self, Read, Write};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};

use serialport::SerialPort;
use wheelset_control::Fx;
use wheelset_runtime::Runtime;

use crate::lockstep::Expect;
use wheelset_loop::transport::{Clock, Transport, TransportError};

/// How the host paces the exchanges (see the module docs).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Pace {
    /// Wall-clock periods against a free-running device.
    RealTime,
    /// Wait for each tick's answer.
    LockStep,
}

/// A frame-clocked device on a serial port, in lock-step.
pub struct Serial {
    path: String,
    port: Box<dyn SerialPort>,
    baud: u32,
    cpu_hz: f64,
    timeout: Duration,
    expect: Expect,
}

impl Serial {
    /// Opens `path` at `baud` (8N1). `cpu_hz` converts the device's `exec` cycles to ns;
    /// `timeout` bounds a lock-step wait.
    pub fn open(
        path: &str,
        baud: u32,
        cpu_hz: f64,
        timeout: Duration,
    ) -> Result<Self, TransportError> {
        let port = serialport::new(path, baud)
            .timeout(Duration::from_millis(1))
            .open()
            .map_err(|e| {
                TransportError::Unavailable(format!(
                    "serial:{path}: cannot open at {baud} baud: {e} (is the board connected, \
                     and is the path right?)"
                ))
            })?;
        let _ = port.clear(serialport::ClearBuffer::All);
        Ok(Self {
            path: path.to_string(),
            port,
            baud,
            cpu_hz,
            timeout,
            expect: Expect::new(),
        })
    }

    fn io(&self, e: &io::Error) -> TransportError {
        TransportError::Io(format!("serial:{}: {e}", self.path))
    }

    /// Reads what is there (up to the port's 1 ms timeout); `Ok(empty)` if nothing.
    fn read_some(&mut self, buf: &mut [u8]) -> Result<usize, TransportError> {
        match self.port.read(buf) {
            Ok(n) => Ok(n),
            Err(e) if nothing_yet(&e) => Ok(0),
            Err(e) => Err(self.io(&e)),
        }
    }
}

impl Transport for Serial {
    fn name(&self) -> String {
        format!("serial:{}", self.path)
    }

    fn clock(&self) -> Clock {
        Clock::LockStep
    }

    fn baud(&self) -> u32 {
        self.baud
    }

    fn exec_unit(&self) -> (&'static str, f64) {
        ("cycles", 1e9 / self.cpu_hz)
    }

    fn send(&mut self, _t_ns: u64, bytes: &[u8]) -> Result<(), TransportError> {
        // One frame in flight (`crate::lockstep`): each frame of the write after the
        // answers still owed.
        for part in crate::lockstep::frames(bytes) {
            let mut early = Vec::new();
            self.wait_owed(&mut |b| early.extend_from_slice(b))?;
            self.expect.stash(&early);
            self.expect.sent(part);
            self.port.write_all(part).map_err(|e| self.io(&e))?;
        }
        Ok(())
    }

    fn recv(
        &mut self,
        deadline_ns: u64,
        sink: &mut dyn FnMut(u64, &[u8]),
    ) -> Result<(), TransportError> {
        let early = self.expect.take_early();
        if !early.is_empty() {
            sink(deadline_ns, &early);
        }
        self.wait_owed(&mut |b| sink(deadline_ns, b))
    }
}

impl Serial {
    /// Reads until nothing is owed, every run of bytes to `sink`; a timeout error if the
    /// device stays silent for `timeout`.
    fn wait_owed(&mut self, sink: &mut dyn FnMut(&[u8])) -> Result<(), TransportError> {
        let mut buf = [0u8; 256];
        let give_up = Instant::now() + self.timeout;
        while self.expect.owed() > 0 {
            let n = self.read_some(&mut buf)?;
            if n > 0 {
                self.expect.received(&buf[..n]);
                sink(&buf[..n]);
            } else if Instant::now() > give_up {
                return Err(TransportError::Timeout(format!(
                    "serial:{}: no answer within {:?} ({} frames owed)",
                    self.path,
                    self.timeout,
                    self.expect.owed()
                )));
            }
        }
        Ok(())
    }
}

/// A frame-clocked device on the other end of a port: every 0x00 delimiter received is
/// one tick of `rt` (the firmware's runtime), whose output is written back at once
/// (reporting 0 execution time). Runs until `stop` is set or the port fails; returns the
/// ticks run.
pub fn serve_lockstep<P: Read + Write + ?Sized>(
    port: &mut P,
    rt: &mut Runtime<Fx>,
    stop: &AtomicBool,
) -> io::Result<u64> {
    let mut buf = [0u8; 256];
    let mut ticks = 0;
    while !stop.load(Ordering::Relaxed) {
        let n = match port.read(&mut buf) {
            Ok(n) => n,
            Err(e) if nothing_yet(&e) => continue,
            Err(e) => return Err(e),
        };
        for chunk in buf[..n].split_inclusive(|&b| b == 0) {
            rt.receive(chunk);
            if chunk.last() == Some(&0) {
                let out = rt.tick(0).to_vec();
                port.write_all(&out)?;
                ticks += 1;
            }
        }
    }
    Ok(ticks)
}

/// A read that timed out or was interrupted: nothing arrived yet.
pub(crate) fn nothing_yet(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
    )
}
