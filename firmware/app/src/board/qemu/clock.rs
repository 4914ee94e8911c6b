//! The QEMU build's embassy-time driver: the host's frames are the clock.
//!
//! Lock-step needs a device clock that stands still while the guest waits for the
//! host. With `-icount sleep=off`, QEMU jumps virtual time to the next armed timer as
//! soon as the guest idles, so any hardware timer (SysTick, CMSDK timers) would expire
//! "instantly" in wall time, before the host's next frame could arrive, and the tick
//! would see old or new data depending on host speed. Here device time is instead
//!
//! `now = frame_edges * period` (embassy-time ticks of 1 us),
//!
//! where a frame edge is the delimiter byte 0x00 that ends each host frame: the host
//! sends exactly one frame per control period, so the control task's `Ticker` fires
//! once per host frame, after the frame's bytes are in the RX pipe. Nothing counts time
//! while the guest sleeps in WFI, so a run's per-tick trace depends only on the bytes
//! exchanged. A host that wants a tick without a sensor frame (a dropped frame in a fault
//! run) sends a bare 0x00, which every COBS decoder ignores as an empty frame.
//!
//! **Free-running build** (feature `free-run`, QEMU without `-icount`, virtual time
//! following the host's clock): the same clock, its edges from the CMSDK TIMER0
//! (0x4000_0000, IRQ 8, counting down at the 25 MHz system clock) instead of the frame
//! delimiters. TIMER0 reloads every period, `RELOAD = period_us * 25 - 1`, and each of
//! its interrupts is one edge: the board ticks on its own clock as a real board does,
//! whatever the host sends. Device time is quantised to whole periods, so the tick
//! monitor sees a delayed edge as a skipped tick (lateness a multiple of the period),
//! never as a late one.

use core::cell::{Cell, RefCell};
use core::sync::atomic::{AtomicU32, Ordering};
use core::task::Waker;

use critical_section::Mutex;
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

/// The control period in embassy-time ticks (1 us), set by the control task.
static PERIOD: AtomicU32 = AtomicU32::new(0);

/// Sets the period one frame edge advances the clock by (and, free-running, the
/// TIMER0 reload that makes the edges).
pub fn set_period(ticks: u64) {
    let ticks = u32::try_from(ticks).unwrap_or(u32::MAX);
    PERIOD.store(ticks, Ordering::Relaxed);
    #[cfg(feature = "free-run")]
    timer::start(ticks);
}

/// TIMER0 as the free-running build's tick source (see the module docs).
#[cfg(feature = "free-run")]
pub mod timer {
    use core::ptr::write_volatile;

    const BASE: usize = 0x4000_0000;
    const CTRL: usize = BASE;
    const VALUE: usize = BASE + 0x04;
    const RELOAD: usize = BASE + 0x08;
    const INTCLEAR: usize = BASE + 0x0C;
    const CTRL_ENABLE: u32 = 1 << 0;
    const CTRL_IRQ_EN: u32 = 1 << 3;
    /// TIMER0's clock: the mps2's 25 MHz system clock, in counts per us.
    const COUNTS_PER_US: u32 = 25;

    fn write(addr: usize, value: u32) {
        // SAFETY: `addr` is one of TIMER0's registers above: a valid, aligned MMIO word of
        // the mps2-an386; TIMER0 is owned by this module alone.
        unsafe { write_volatile(addr as *mut u32, value) }
    }

    /// (Re)starts TIMER0 with one interrupt every `period_us` us.
    pub fn start(period_us: u32) {
        let reload = period_us.saturating_mul(COUNTS_PER_US).saturating_sub(1);
        write(CTRL, 0);
        write(RELOAD, reload);
        write(VALUE, reload);
        write(INTCLEAR, 1);
        write(CTRL, CTRL_ENABLE | CTRL_IRQ_EN);
    }

    /// TIMER0's interrupt: one period passed.
    pub fn on_interrupt() {
        write(INTCLEAR, 1);
        super::frame_edge();
    }
}

struct FrameClock {
    now: Mutex<Cell<u64>>,
    queue: Mutex<RefCell<Queue>>,
}

impl Driver for FrameClock {
    fn now(&self) -> u64 {
        critical_section::with(|cs| self.now.borrow(cs).get())
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            let mut queue = self.queue.borrow_ref_mut(cs);
            if queue.schedule_wake(at, waker) {
                // Wakes it at once if `at` has already passed.
                queue.next_expiration(self.now.borrow(cs).get());
            }
        });
    }
}

embassy_time_driver::time_driver_impl!(static CLOCK: FrameClock = FrameClock {
    now: Mutex::new(Cell::new(0)),
    queue: Mutex::new(RefCell::new(Queue::new())),
});

/// One host frame ended: advance device time by one control period and wake whatever
/// was due (the control task's ticker).
pub fn frame_edge() {
    critical_section::with(|cs| {
        let now = CLOCK.now.borrow(cs);
        let t = now
            .get()
            .saturating_add(u64::from(PERIOD.load(Ordering::Relaxed)));
        now.set(t);
        CLOCK.queue.borrow_ref_mut(cs).next_expiration(t);
    });
}
