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

use core::cell::{Cell, RefCell};
use core::sync::atomic::{AtomicU32, Ordering};
use core::task::Waker;

use critical_section::Mutex;
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

/// The control period in embassy-time ticks (1 us), set by the control task.
static PERIOD: AtomicU32 = AtomicU32::new(0);

/// Sets the period one frame edge advances the clock by.
pub fn set_period(ticks: u64) {
    PERIOD.store(u32::try_from(ticks).unwrap_or(u32::MAX), Ordering::Relaxed);
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
