//! The board-independent task structure, generic over the [`Board`]: UART RX --RX pipe-->
//! control task (ticker, highest executor) --TX pipe--> UART TX.

use core::future::poll_fn;
use core::sync::atomic::{AtomicU32, Ordering};
use core::task::Poll;

use embassy_executor::{SpawnError, SpawnToken};
use embassy_sync::waitqueue::AtomicWaker;
use embassy_time::Instant;

use crate::board::Board;
use crate::device::{new_runtime, FwRuntime};
use crate::ring::{ByteRing, Empty};
use crate::settings::{RX_PIPE, TX_PIPE};
use crate::tick::{period_ticks, TickMonitor, TickWake};

/// Bytes from the UART receiver to the control task.
pub static RX: Pipe<RX_PIPE> = Pipe::new();
/// Encoded frames from the control task to the UART transmitter.
pub static TX: Pipe<TX_PIPE> = Pipe::new();

/// A single-producer, single-consumer byte pipe: the panic-free [`ByteRing`] and a waker.
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

    /// Waits until a byte is held, then reads up to `out.len()` (0 only for an empty `out`).
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

/// Bytes the receive path lost since the control task last looked (`rx_overrun`).
pub static RX_OVERRUN: AtomicU32 = AtomicU32::new(0);

/// The execution-time counter of a board.
pub trait Stopwatch {
    /// Starts a measurement; returns the raw start reading.
    fn start(&mut self) -> u32;
    /// Ends the measurement started at `start`: cycles (board) or instructions (QEMU).
    fn stop(&mut self, start: u32) -> u32;
}

/// The runtime with its default configuration (a refusal is a build error: the board halts).
pub fn new_device<B: Board>() -> FwRuntime {
    match new_runtime() {
        Ok(mut rt) => {
            rt.set_link_limit(B::LINK_MAX_RATE_HZ);
            rt.set_watchdog(B::WATCHDOG_ENDS_STALL);
            rt
        }
        Err(e) => {
            defmt::error!("runtime refused its default configuration: {}", e);
            B::halt()
        }
    }
}

/// Unwraps a spawn token (a full pool is a build error: the board halts).
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
    t.reset_at(start);
    (t, start.saturating_add(period))
}

/// The control task's periodic wake-up, `embassy_time::Ticker`'s behaviour with saturating
/// additions (`Ticker`'s overflow `expect` links `core::fmt`).
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

/// The board's counters not yet handed to the device.
#[derive(Default)]
struct BoardNote {
    late: u32,
    missed: u32,
    tx_dropped: u32,
}

/// One tick's work from the wake-up at `t0`: counters and received bytes to the device,
/// its tick, the frame queued whole or dropped. Returns the execution time.
#[inline(always)]
fn exchange(
    device: &mut FwRuntime,
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
    // The held bytes in place, in at most two runs; bounded, as bytes keep arriving.
    for _ in 0..3 {
        if RX.read_in_place(|held| device.receive(held)).is_err() {
            break;
        }
    }
    let frame = device.tick(last_exec);
    // The measurement ends with the encoded frame (handing it over depends on host timing).
    let exec = stopwatch.stop(t0);
    if !frame.is_empty() {
        if TX.free_capacity() >= frame.len() {
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

/// Base ticks between two receive log records (a burst logs its first, then the count).
pub const RX_LOG_QUIET_TICKS: u32 = 500;

/// The receive log, after the frame went out: the held event once `quiet` ran down.
#[inline(always)]
fn log_rx(device: &mut FwRuntime, quiet: &mut u32) {
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

/// Every [`crate::stack::SCAN_TICKS`] ticks, the stack's high-water mark into the Status.
#[inline(always)]
fn note_stack(device: &mut FwRuntime, ticks: &mut u32) {
    *ticks = ticks.wrapping_add(1);
    if *ticks >= crate::stack::SCAN_TICKS {
        *ticks = 0;
        device.set_stack_peak(crate::stack::peak());
    }
}

/// After every tick of either control task: the stack mark, the receive log, the
/// watchdog's proof of life, a fault the Config injected.
#[inline(always)]
fn after_tick<B: Board>(device: &mut FwRuntime, stack_ticks: &mut u32, rx_quiet: &mut u32) {
    note_stack(device, stack_ticks);
    log_rx(device, rx_quiet);
    crate::watchdog::tick_ran();
    if let Some(c) = device.take_injected() {
        B::inject(c);
    }
}

/// The control task's body, one base period per tick; a Config changing the rate re-arms it.
pub async fn control_loop<B: Board>(
    make_device: impl FnOnce() -> FwRuntime,
    mut stopwatch: B::Stopwatch,
) -> ! {
    // Made here, not passed in: an async fn's arguments are kept twice in its future.
    let mut device = make_device();
    let (count, cause) = crate::boot::this_boot();
    device.set_boot(count, cause);
    let mut rate = device.base_rate_hz();
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
        after_tick::<B>(&mut device, &mut stack_ticks, &mut rx_quiet);
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
                    // A guard: the runtime refuses such a rate (`RefuseReason::Period`).
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

/// The frame-clocked control task (`frame-clock`): one tick per frame delimiter received.
#[cfg(feature = "frame-clock")]
pub async fn frame_loop<B: Board>(
    make_device: impl FnOnce() -> FwRuntime,
    mut stopwatch: B::Stopwatch,
) -> ! {
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
        after_tick::<B>(&mut device, &mut stack_ticks, &mut rx_quiet);
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
