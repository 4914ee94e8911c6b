//! The QEMU target, lock-step (each frame delimiter is one device tick). `exec` is in
//! instructions, scaled at `--cpu-hz` one per cycle (nominally [`MPS2_CPU_HZ`]). Over the
//! bulk channel two exchanges are in flight ([`Transport::pipelined`]) and the frames
//! sent are written when the host next waits ([`Qemu::queue`]): one write, one wait and
//! one read per two periods when the device is the slower side.

use std::time::Duration;

use crate::lockstep::{Expect, OneInFlight};
use crate::qemu::{Channel, Machine, Qemu, QemuConfig, QemuError};
use wheelset_loop::transport::{Clock, Transport, TransportError};

/// The emulated board's core clock, Hz (mps2-an386: 25 MHz).
pub const MPS2_CPU_HZ: f64 = 25e6;

/// The firmware under QEMU.
pub struct QemuTarget {
    q: Qemu,
    baud: u32,
    cpu_hz: f64,
    expect: Expect,
    pipelined: bool,
}

/// Whether a target on `channel` keeps two exchanges in flight ([`Transport::pipelined`]).
fn pipelined(channel: Channel) -> bool {
    channel == Channel::Bulk && std::env::var("WHEELSET_QEMU_IN_FLIGHT").as_deref() != Ok("1")
}

impl QemuTarget {
    /// Starts QEMU on `machine` over `channel` (the bulk channel: faster), a clear error if
    /// QEMU or the ELF (`cargo fw`) is missing; `baud`: the timing model's line rate.
    pub fn start_with(
        machine: Machine,
        channel: Channel,
        baud: u32,
        cpu_hz: f64,
        timeout: Duration,
    ) -> Result<Self, TransportError> {
        let cfg = QemuConfig {
            timeout,
            channel,
            ..QemuConfig::on(machine)
        };
        Self::on(Qemu::start(&cfg), baud, cpu_hz, pipelined(channel))
    }

    /// The firmware under a QEMU started by hand ([`Qemu::connect`]), left running at the end.
    pub fn connect(
        port: u16,
        baud: u32,
        cpu_hz: f64,
        timeout: Duration,
    ) -> Result<Self, TransportError> {
        Self::on(Qemu::connect(port, timeout), baud, cpu_hz, false)
    }

    fn on(
        q: Result<Qemu, QemuError>,
        baud: u32,
        cpu_hz: f64,
        pipelined: bool,
    ) -> Result<Self, TransportError> {
        Ok(Self {
            q: q.map_err(|e| TransportError::Unavailable(e.to_string()))?,
            baud,
            cpu_hz,
            expect: Expect::default(),
            pipelined,
        })
    }
}

impl Transport for QemuTarget {
    fn name(&self) -> String {
        "qemu".into()
    }

    fn clock(&self) -> Clock {
        Clock::LockStep
    }

    fn baud(&self) -> u32 {
        self.baud
    }

    fn exec_unit(&self) -> (&'static str, f64) {
        ("instructions", 1e9 / self.cpu_hz)
    }

    fn pipelined(&self) -> bool {
        self.pipelined
    }

    fn send(&mut self, t_ns: u64, bytes: &[u8]) -> Result<(), TransportError> {
        if self.pipelined {
            // The firmware ticks on each frame before it reads the next: the whole write
            // at once, each frame's answers owed from `t_ns` (`crate::lockstep`).
            for part in crate::lockstep::frames(bytes) {
                self.expect.sent_at(t_ns, part);
            }
            // Written when the host next waits for an answer not yet here: the frames of
            // two periods often go in one write.
            self.q.queue(bytes);
            return Ok(());
        }
        self.send_frames(bytes)
    }

    fn recv(
        &mut self,
        deadline_ns: u64,
        sink: &mut dyn FnMut(u64, &[u8]),
    ) -> Result<(), TransportError> {
        if !self.pipelined {
            return self.recv_owed(deadline_ns, sink);
        }
        // The answers owed before the deadline; later ones wait in the link's buffer.
        while self.expect.owed_before(deadline_ns) > 0 {
            self.recv_some(&mut |b| sink(deadline_ns, b))?;
        }
        Ok(())
    }
}

impl OneInFlight for QemuTarget {
    fn expect(&mut self) -> &mut Expect {
        &mut self.expect
    }

    fn write(&mut self, part: &[u8]) -> Result<(), TransportError> {
        self.q
            .send(part)
            .map_err(|e| TransportError::Io(e.to_string()))
    }

    /// The next frame (its delimiter included).
    fn recv_some(&mut self, sink: &mut dyn FnMut(&[u8])) -> Result<(), TransportError> {
        let expect = &mut self.expect;
        self.q
            .with_frame(|frame| {
                expect.received(frame);
                sink(frame);
            })
            .map_err(|e| TransportError::Io(e.to_string()))
    }
}
