//! The QEMU build's embassy-time driver: the host's frames are the clock. With `-icount
//! sleep=off` a hardware timer would expire before the host's next frame, so `now =
//! frame_edges * period` (1 us ticks), an edge being each frame's 0x00: a run's trace
//! depends only on the bytes exchanged. Free-running (`free-run`): TIMER0 makes the edges.

use core::cell::{Cell, RefCell};
use core::sync::atomic::{AtomicU32, Ordering};
use core::task::Waker;

use critical_section::Mutex;
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

/// The control period in embassy-time ticks (1 us), set by the control task.
static PERIOD: AtomicU32 = AtomicU32::new(0);

/// Sets the period a frame edge advances the clock by (free-running: TIMER0's reload).
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
        // SAFETY: `addr` is a TIMER0 register: valid, aligned MMIO, owned by this module alone.
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
                queue.next_expiration(self.now.borrow(cs).get());
            }
        });
    }
}

embassy_time_driver::time_driver_impl!(static CLOCK: FrameClock = FrameClock {
    now: Mutex::new(Cell::new(0)),
    queue: Mutex::new(RefCell::new(Queue::new())),
});

/// One host frame ended: device time advances one period, and whatever was due wakes.
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
