//! The board-independent task structure: the pipes between the UART and the control
//! task, and the control loop itself. Each board supplies the executors, the UART tasks
//! and a [`Stopwatch`].
//!
//! ```text
//!  UART RX (ISR or DMA task) --RX pipe--> control task --TX pipe--> UART TX task
//!                                         (Ticker, base rate, highest executor)
//! ```

use embassy_executor::{SpawnError, SpawnToken};
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pipe::Pipe;
use embassy_time::{Duration, Instant, Ticker};

use crate::config::{LATE_AFTER_TICKS, PERIOD_TICKS, RX_PIPE, TX_PIPE};
use crate::device::{Device, EchoStub};
use crate::tick::{TickMonitor, TickWake};

/// Bytes from the UART receiver to the control task.
pub static RX: Pipe<CriticalSectionRawMutex, RX_PIPE> = Pipe::new();
/// Encoded frames from the control task to the UART transmitter.
pub static TX: Pipe<CriticalSectionRawMutex, TX_PIPE> = Pipe::new();

/// The execution-time counter of a board.
pub trait Stopwatch {
    /// Starts a measurement; returns the raw start reading.
    fn start(&mut self) -> u32;
    /// Ends the measurement started at `start`; returns cycles (board) or instructions
    /// (QEMU).
    fn stop(&mut self, start: u32) -> u32;
}

/// The device the control task drives. Today: the link-test stub (see the README's
/// Firmware section); the control runtime replaces it.
pub fn new_device() -> EchoStub {
    EchoStub::default()
}

/// The frame the panic handler sends to put the actuators in their safe state (zero yaw
/// torque, zero traction demand). Empty while the link-test stub is wired: the stub
/// commands nothing, so there is nothing to make safe.
pub fn safe_frame() -> &'static [u8] {
    &[]
}

/// Unwraps a task's spawn token; a full task pool is a build error in disguise, so it
/// halts the board (it cannot depend on input: tasks are spawned once at start-up).
pub fn token<S>(t: Result<SpawnToken<S>, SpawnError>) -> SpawnToken<S> {
    match t {
        Ok(t) => t,
        Err(_) => {
            defmt::error!("task pool exhausted at start-up");
            crate::board::panic_halt()
        }
    }
}

/// The control task's body. Deadline: one base period per tick.
///
/// Each tick: apply the missed-tick policy ([`crate::tick`]), feed the bytes received
/// since the last tick to the device, run the device's tick with the previous tick's
/// execution time, and queue the encoded frame for the transmitter. The execution time
/// is measured from the wake-up to the encoded frame (drain + decode + control +
/// encode).
pub async fn control_loop(mut device: impl Device, mut stopwatch: impl Stopwatch) -> ! {
    let period = Duration::from_ticks(PERIOD_TICKS);
    let start = Instant::now();
    let first = start + period;
    let mut ticker = Ticker::every(period);
    // `reset_at(t)` makes `t` the last tick: the next one is due at `t + period`.
    ticker.reset_at(start);
    let mut monitor = match TickMonitor::try_new(PERIOD_TICKS, first.as_ticks(), LATE_AFTER_TICKS) {
        Ok(m) => m,
        Err(_) => {
            defmt::error!("bad tick configuration");
            crate::board::panic_halt()
        }
    };
    let mut last_exec = 0u32;
    let mut tx_dropped = 0u32;
    let mut chunk = [0u8; 32];
    loop {
        ticker.next().await;
        let t0 = stopwatch.start();
        match monitor.on_wake(Instant::now().as_ticks()) {
            TickWake::OnTime => {}
            TickWake::Late { lateness } => defmt::warn!("late tick: {=u64} us", lateness),
            TickWake::Skipped {
                missed,
                next_deadline,
            } => {
                ticker.reset_at(Instant::from_ticks(
                    next_deadline.saturating_sub(PERIOD_TICKS),
                ));
                defmt::warn!("stalled: skipped {=u32} ticks", missed);
            }
        }
        // Bounded: the pipe holds at most RX_PIPE bytes.
        for _ in 0..RX_PIPE / chunk.len() + 1 {
            match RX.try_read(&mut chunk) {
                Ok(n) => device.receive(chunk.get(..n).unwrap_or(&[])),
                Err(_) => break,
            }
        }
        let frame = device.tick(last_exec);
        // The measurement ends with the encoded frame: handing it to the transmitter
        // costs more or less depending on whether the TX task is already waiting,
        // which under lock-step depends on host timing, not on the tick.
        last_exec = stopwatch.stop(t0);
        // A frame goes out whole or not at all.
        if !frame.is_empty() {
            if TX.free_capacity() >= frame.len() {
                // The pipe is a ring: one write stops at its end, so write until done
                // (at most two writes; the room was checked above).
                let mut rest = frame;
                while let Ok(n @ 1..) = TX.try_write(rest) {
                    rest = rest.get(n..).unwrap_or(&[]);
                }
            } else {
                tx_dropped = tx_dropped.wrapping_add(1);
                defmt::warn!("TX pipe full: frame dropped ({=u32})", tx_dropped);
            }
        }
    }
}
