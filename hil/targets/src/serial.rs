//! The serial-port target: a board on a serial port (`serialport`, default features off:
//! no libudev). Two pacings: [`Pace::RealTime`] (the default, a board ticking on its own
//! timer: [`crate::realtime::RealTime`]) and [`Pace::LockStep`] (a frame-clocked device:
//! [`Serial`] waits for each tick's answer, and the timing is modelled from the baud and
//! the reported `exec`).

use std::io::{self, Read, Write};
use std::time::{Duration, Instant};

use serialport::{SerialPort, TTYPort};

use crate::lockstep::{Expect, OneInFlight};
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
    port: TTYPort,
    baud: u32,
    cpu_hz: f64,
    timeout: Duration,
    expect: Expect,
}

impl Serial {
    /// Opens `path` at `baud` (8N1); `cpu_hz` turns `exec` cycles into ns, `timeout` bounds a wait.
    pub fn open(
        path: &str,
        baud: u32,
        cpu_hz: f64,
        timeout: Duration,
    ) -> Result<Self, TransportError> {
        Ok(Self {
            path: path.to_string(),
            port: open_port(path, baud, Duration::from_millis(1))?,
            baud,
            cpu_hz,
            timeout,
            expect: Expect::default(),
        })
    }

    fn io(&self, e: &io::Error) -> TransportError {
        TransportError::Io(format!("serial:{}: {e}", self.path))
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
        self.send_frames(bytes)
    }

    fn recv(
        &mut self,
        deadline_ns: u64,
        sink: &mut dyn FnMut(u64, &[u8]),
    ) -> Result<(), TransportError> {
        self.recv_owed(deadline_ns, sink)
    }
}

impl OneInFlight for Serial {
    fn expect(&mut self) -> &mut Expect {
        &mut self.expect
    }

    fn write(&mut self, part: &[u8]) -> Result<(), TransportError> {
        self.port.write_all(part).map_err(|e| self.io(&e))
    }

    /// Reads until bytes come (the port's reads time out after 1 ms).
    fn recv_some(&mut self, sink: &mut dyn FnMut(&[u8])) -> Result<(), TransportError> {
        let mut buf = [0u8; 256];
        let give_up = Instant::now() + self.timeout;
        loop {
            match self.port.read(&mut buf) {
                Ok(n) if n > 0 => {
                    self.expect.received(&buf[..n]);
                    sink(&buf[..n]);
                    return Ok(());
                }
                Err(e) if !nothing_yet(&e) => return Err(self.io(&e)),
                _ => {}
            }
            if Instant::now() > give_up {
                return Err(TransportError::Timeout(format!(
                    "serial:{}: no answer within {:?} ({} frames owed)",
                    self.path,
                    self.timeout,
                    self.expect.owed()
                )));
            }
        }
    }
}

/// `path` at `baud` (8N1), reads bounded by `wait`, both buffers cleared.
pub(crate) fn open_port(path: &str, baud: u32, wait: Duration) -> Result<TTYPort, TransportError> {
    let open = serialport::new(path, baud).timeout(wait).open_native();
    let port = open.map_err(|e| {
        TransportError::Unavailable(format!(
            "serial:{path}: cannot open at {baud} baud: {e} (is the board connected, and is the \
             path right?)"
        ))
    })?;
    let _ = port.clear(serialport::ClearBuffer::All);
    Ok(port)
}

/// A read that timed out or was interrupted: nothing arrived yet.
pub(crate) fn nothing_yet(e: &io::Error) -> bool {
    matches!(
        e.kind(),
        io::ErrorKind::TimedOut | io::ErrorKind::WouldBlock | io::ErrorKind::Interrupted
    )
}
