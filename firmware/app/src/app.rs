//! The board-independent task structure: the pipes between the UART and the control
//! task, and the control loop itself, generic over the [`Board`] (its executors and UART
//! tasks, its [`Stopwatch`], its tick source's period, its fault path).
//!
//! ```text
//!  UART RX (ISR or DMA task) --RX pipe--> control task --TX pipe--> UART TX task
//!                                         (Ticker, base rate, highest executor)
//! ```

use core::future::poll_fn;
use core::sync::atomic::{AtomicU32, Ordering};
use core::task::Poll;

use embassy_executor::{SpawnError, SpawnToken};
use embassy_sync::waitqueue::AtomicWaker;
use embassy_time::Instant;

use crate::board::Board;
use crate::device::{new_runtime, Device, FwRuntime};
use crate::ring::{ByteRing, Empty};
use crate::settings::{RX_PIPE, TX_PIPE};
use crate::tick::{period_ticks, TickMonitor, TickWake};

/// Bytes from the UART receiver to the control task.
pub static RX: Pipe<RX_PIPE> = Pipe::new();
/// Encoded frames from the control task to the UART transmitter.
pub static TX: Pipe<TX_PIPE> = Pipe::new();

/// A byte pipe between one producer and one consumer: the panic-free [`ByteRing`] and
/// the consumer's waker (instead of `embassy_sync::pipe::Pipe`, whose panic paths link
/// `core::fmt`; see [`crate::ring`]).
pub struct Pipe<const N: usize> {
    ring: ByteRing<N>,
    reader: AtomicWaker,
}

impl<const N: usize> Default for Pipe<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> Pipe<N> {
    /// An empty pipe.
    pub const fn new() -> Self {
        Self {
            ring: ByteRing::new(),
            reader: AtomicWaker::new(),
        }
    }

    /// Writes as much of `data` as fits ([`ByteRing::try_write`]) and wakes the reader.
    pub fn try_write(&self, data: &[u8]) -> Result<usize, Empty> {
        let r = self.ring.try_write(data);
        if r.is_ok() {
            self.reader.wake();
        }
        r
    }

    /// The held bytes in place, one contiguous run ([`ByteRing::read_in_place`]).
    pub fn read_in_place(&self, f: impl FnOnce(&[u8])) -> Result<usize, Empty> {
        self.ring.read_in_place(f)
    }

    /// Room for this many more bytes.
    pub fn free_capacity(&self) -> usize {
        self.ring.free_capacity()
    }

    /// Waits until at least one byte is held, then reads up to `out.len()` (0 only for
    /// an empty `out`).
    pub async fn read(&self, out: &mut [u8]) -> usize {
        if out.is_empty() {
            return 0;
        }
        poll_fn(|cx| {
            // Register first: a write after the check below wakes this task.
            self.reader.register(cx.waker());
            match self.ring.try_read(out) {
                Ok(n) => Poll::Ready(n),
                Err(Empty) => Poll::Pending,
            }
        })
        .await
    }
}

/// Bytes the board's receive path lost since the control task last looked (the RX pipe
/// was full; on the Nucleo also one per receive error its UART driver reports, which
/// cannot say how many bytes it lost: `board::nucleo`'s RX task), for the Status
/// `rx_overrun`.
pub static RX_OVERRUN: AtomicU32 = AtomicU32::new(0);

/// The execution-time counter of a board.
pub trait Stopwatch {
    /// Starts a measurement; returns the raw start reading.
    fn start(&mut self) -> u32;
    /// Ends the measurement started at `start`; returns cycles (board) or instructions
    /// (QEMU).
    fn stop(&mut self, start: u32) -> u32;
}

/// The device the control task drives: the runtime with its default configuration. A
/// configuration the control core refuses is a build error in disguise (it is not
/// input): the board halts.
pub fn new_device<B: Board>() -> FwRuntime {
    match new_runtime() {
        Ok(mut rt) => {
            // A Config may not set a rate the board's link cannot carry.
            rt.set_link_limit(B::LINK_MAX_RATE_HZ);
            // An injected stall only where a watchdog ends it.
            rt.set_watchdog(B::WATCHDOG_ENDS_STALL);
            rt
        }
        Err(e) => {
            defmt::error!("runtime refused its default configuration: {}", e);
            B::halt()
        }
    }
}

/// Unwraps a task's spawn token; a full task pool is a build error in disguise, so it
/// halts the board (it cannot depend on input: tasks are spawned once at start-up).
pub fn token<B: Board, S>(t: Result<SpawnToken<S>, SpawnError>) -> SpawnToken<S> {
    match t {
        Ok(t) => t,
        Err(_) => {
            defmt::error!("task pool exhausted at start-up");
            B::halt()
        }
    }
}

/// A ticker whose first tick is one period from now.
fn new_ticker(period: u64) -> (Ticker, u64) {
    let start = Instant::now().as_ticks();
    let mut t = Ticker {
        expires_at: 0,
        period,
    };
    // `reset_at(t)` makes `t` the last tick: the next one is due at `t + period`.
    t.reset_at(start);
    (t, start.saturating_add(period))
}

/// The control task's periodic wake-up: `embassy_time::Ticker`'s behaviour (a tick
/// already due is taken at once, then the deadline moves on by one period, so a late
/// tick does not shift the schedule) on time-driver ticks with saturating additions.
///
/// Why not `embassy_time::Ticker`: its `Instant + Duration` is `checked_add(..)
/// .expect("overflow ...")`, and the message's formatting links `core::fmt`'s `str`
/// Display (`Formatter::pad`, hundreds of bytes of the Nucleo's flash, `arm-none-eabi-nm
/// --size-sort`), for an overflow that needs `2^64` 1 us ticks (hundreds of thousands of
/// years).
struct Ticker {
    /// The next deadline, time-driver ticks.
    expires_at: u64,
    /// The period, time-driver ticks.
    period: u64,
}

impl Ticker {
    /// The next tick is due one period after `last` (a deadline in the past: at once).
    fn reset_at(&mut self, last: u64) {
        self.expires_at = last.saturating_add(self.period);
    }

    /// Waits for the next deadline; cancel safe (no tick is lost if dropped).
    fn next(&mut self) -> impl core::future::Future<Output = ()> + '_ {
        poll_fn(|cx| {
            if self.expires_at <= Instant::now().as_ticks() {
                self.expires_at = self.expires_at.saturating_add(self.period);
                Poll::Ready(())
            } else {
                embassy_time_driver::schedule_wake(self.expires_at, cx.waker());
                Poll::Pending
            }
        })
    }
}

/// The board's counters not yet handed to the device: ticks late and deadlines skipped
/// (the tick monitor's classification of each wake-up) and frames the TX pipe had no
/// room for.
#[derive(Default)]
struct BoardNote {
    late: u32,
    missed: u32,
    tx_dropped: u32,
}

/// One tick's work, from the wake-up at stopwatch reading `t0`: hand the board's
/// counters to the device (`note_board`, with the bytes lost on receive from
/// [`RX_OVERRUN`]), feed the bytes received since the last tick to the device, run its tick with the previous tick's execution
/// time, and queue the encoded frame for the transmitter (whole or not at all: a frame
/// that does not fit is dropped and counted in `tx_dropped`). Returns this tick's
/// execution time (drain + decode + control + encode).
#[inline(always)]
fn exchange(
    device: &mut impl Device,
    stopwatch: &mut impl Stopwatch,
    t0: u32,
    last_exec: u32,
    note: &mut BoardNote,
) -> u32 {
    let taken = core::mem::take(note);
    device.note_board(
        taken.late,
        taken.missed,
        RX_OVERRUN.swap(0, Ordering::Relaxed),
        taken.tx_dropped,
    );
    // The held bytes in place, in at most two runs (up to the ring's end, then from its
    // start); bounded, as bytes may keep arriving from the receiver meanwhile.
    for _ in 0..3 {
        if RX.read_in_place(|held| device.receive(held)).is_err() {
            break;
        }
    }
    let frame = device.tick(last_exec);
    // The measurement ends with the encoded frame: handing it to the transmitter
    // costs more or less depending on whether the TX task is already waiting,
    // which under lock-step depends on host timing, not on the tick.
    let exec = stopwatch.stop(t0);
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
            note.tx_dropped = note.tx_dropped.wrapping_add(1);
            defmt::warn!("TX pipe full: frame dropped");
        }
    }
    exec
}

/// Base ticks between two log records of rejected frames and refused requests (0.1 s at
/// the default 5 kHz): a burst of bad frames logs its first, and the next record, at
/// most this many ticks later, the first after it with the number in between; the
/// Status counters count every one.
pub const RX_LOG_QUIET_TICKS: u32 = 500;

/// The receive log, once per tick after the frame went out (outside the measured
/// execution time): while `quiet` counts down nothing is taken (the runtime keeps the
/// first event and counts the rest); then the held event, if any, is logged with
/// `defmt::warn!` and the countdown restarts.
#[inline(always)]
fn log_rx(device: &mut impl Device, quiet: &mut u32) {
    if *quiet != 0 {
        *quiet -= 1;
    } else if let Some((e, more)) = device.take_rx_event() {
        log_rx_event(e, more);
        *quiet = RX_LOG_QUIET_TICKS;
    }
}

#[cold]
#[inline(never)]
fn log_rx_event(e: wheelset_runtime::RxEvent, more: u32) {
    defmt::warn!("rx {} (+{=u32} more since the last record)", e, more);
}

/// Every [`crate::stack::SCAN_TICKS`] ticks (counted in `ticks`), the stack's
/// high-water mark into the device's Status ([`crate::stack`]).
#[inline(always)]
fn note_stack(device: &mut impl Device, ticks: &mut u32) {
    *ticks = ticks.wrapping_add(1);
    if *ticks >= crate::stack::SCAN_TICKS {
        *ticks = 0;
        device.set_stack_peak(crate::stack::peak());
    }
}

/// The control task's body. Deadline: one base period per tick.
///
/// Each tick: apply the missed-tick policy ([`crate::tick`]), feed the bytes received
/// since the last tick to the device, run the device's tick with the previous tick's
/// execution time, and queue the encoded frame for the transmitter. The execution time
/// is measured from the wake-up to the encoded frame (drain + decode + control +
/// encode). A host Config frame that changes the base rate re-arms the schedule.
pub async fn control_loop<B: Board, D: Device>(
    make_device: impl FnOnce() -> D,
    mut stopwatch: B::Stopwatch,
) -> ! {
    // Made here, not passed in: an async fn's arguments are kept in its future beside
    // the body's copy of them (rust-lang/rust#62958), so a device argument took the
    // runtime's size twice in the task's static RAM (`cargo fw`: see the README).
    let mut device = make_device();
    // The boot record the board read at start-up (crate::boot).
    let (count, cause) = crate::boot::this_boot();
    device.set_boot(count, cause);
    let mut rate = device.base_rate_hz();
    // The schedule: a whole number of us per period, and a tick monitor for it.
    let schedule = period_ticks(rate).and_then(|p| {
        B::set_period(p);
        let (ticker, first) = new_ticker(p);
        let monitor = TickMonitor::try_new(p, first, p / 4).ok()?;
        Some((p, ticker, monitor))
    });
    let Some((mut period, mut ticker, mut monitor)) = schedule else {
        defmt::error!(
            "base rate {=u32} Hz: no tick schedule (period not a whole number of us)",
            rate
        );
        B::halt()
    };
    defmt::info!("control task: {=u32} Hz, period {=u64} us", rate, period);
    crate::stack::paint();
    let mut last_exec = 0u32;
    let mut note = BoardNote::default();
    let mut stack_ticks = 0u32;
    let mut rx_quiet = 0u32;
    loop {
        ticker.next().await;
        let t0 = stopwatch.start();
        match monitor.on_wake(Instant::now().as_ticks()) {
            TickWake::OnTime => {}
            TickWake::Late { lateness } => {
                note.late = note.late.wrapping_add(1);
                defmt::warn!("late tick: {=u64} us", lateness)
            }
            TickWake::Skipped {
                missed,
                next_deadline,
            } => {
                ticker.reset_at(next_deadline.saturating_sub(period));
                note.late = note.late.wrapping_add(1);
                note.missed = note.missed.wrapping_add(missed);
                defmt::warn!("stalled: skipped {=u32} ticks", missed);
            }
        }
        last_exec = exchange(&mut device, &mut stopwatch, t0, last_exec, &mut note);
        note_stack(&mut device, &mut stack_ticks);
        log_rx(&mut device, &mut rx_quiet);
        crate::watchdog::tick_ran();
        if let Some(c) = device.take_injected() {
            B::inject(c);
        }
        // A Config frame from the host may have changed the base rate.
        let now_rate = device.base_rate_hz();
        if now_rate != rate {
            match period_ticks(now_rate) {
                Some(p) => {
                    rate = now_rate;
                    period = p;
                    B::set_period(period);
                    let (t, first) = new_ticker(period);
                    ticker = t;
                    monitor.rearm(period, first);
                    defmt::info!("base rate now {=u32} Hz", rate);
                }
                None => {
                    // Logged once (`rate` follows): the runtime refuses such a rate
                    // (`RefuseReason::Period`), so this is a guard, not a path.
                    defmt::warn!(
                        "base rate {=u32} Hz refused: not a whole number of us",
                        now_rate
                    );
                    rate = now_rate;
                }
            }
        }
    }
}

/// The frame-clocked control task (feature `frame-clock`, the Nucleo's lock-step build):
/// one tick per frame delimiter (0x00) received, as the QEMU build's frame clock, so a
/// board behind a USB serial bridge runs in lock-step at the full rate (the host waits
/// for each answer). No ticker and no missed-tick policy: the host's frames are the
/// clock. The execution time is measured as in [`control_loop`] (DWT cycles).
#[cfg(feature = "frame-clock")]
pub async fn frame_loop<B: Board, D: Device>(
    make_device: impl FnOnce() -> D,
    mut stopwatch: B::Stopwatch,
) -> ! {
    // Made here, as in [`control_loop`] (an argument is kept twice in the future).
    let mut device = make_device();
    let (count, cause) = crate::boot::this_boot();
    device.set_boot(count, cause);
    defmt::info!(
        "control task: frame-clocked, {=u32} Hz nominal",
        device.base_rate_hz()
    );
    crate::stack::paint();
    let mut last_exec = 0u32;
    let mut note = BoardNote::default();
    let mut stack_ticks = 0u32;
    let mut rx_quiet = 0u32;
    loop {
        edges::next().await;
        let t0 = stopwatch.start();
        last_exec = exchange(&mut device, &mut stopwatch, t0, last_exec, &mut note);
        note_stack(&mut device, &mut stack_ticks);
        log_rx(&mut device, &mut rx_quiet);
        crate::watchdog::tick_ran();
        if let Some(c) = device.take_injected() {
            B::inject(c);
        }
    }
}

/// Frame edges from the receiver to the frame-clocked control task.
#[cfg(feature = "frame-clock")]
pub mod edges {
    use core::sync::atomic::{AtomicU32, Ordering};

    use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
    use embassy_sync::signal::Signal;

    static PENDING: AtomicU32 = AtomicU32::new(0);
    static EDGE: Signal<CriticalSectionRawMutex, ()> = Signal::new();

    /// The receiver saw `n` frame delimiters (after putting their bytes in the RX pipe).
    pub fn add(n: u32) {
        if n > 0 {
            PENDING.fetch_add(n, Ordering::Release);
            EDGE.signal(());
        }
    }

    /// Waits for the next frame edge (only the control task consumes them).
    pub async fn next() {
        loop {
            if PENDING.load(Ordering::Acquire) > 0 {
                PENDING.fetch_sub(1, Ordering::AcqRel);
                return;
            }
            EDGE.wait().await;
        }
    }
}
