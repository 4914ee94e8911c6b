//! The Nucleo's embassy-time driver on TIM2, register access of its own (embassy-stm32
//! is built without `time-driver-tim2`): 1 us ticks, a 32-bit counter, the alarm on
//! CC1, the half-wrap on CC2 and the wrap on the update event. The arithmetic (device
//! time from the half-wrap count and the counter, when the alarm's compare may be
//! enabled) is in `board::nucleo_time`, tested on the host.
//!
//! It is embassy-stm32's `time_driver/gp16.rs` logic with a 32-bit counter, and with the
//! timer queue in an `UnsafeCell` used only inside critical sections instead of a
//! `RefCell` (whose `borrow_mut` brought a formatting panic path: 360 B of flash).
//!
//! Interrupt: TIM2 at [`PRIORITY`], above both executors, so the control task's ticker
//! is woken on time whatever the communication executor does.

use core::cell::{Cell, UnsafeCell};
use core::sync::atomic::{compiler_fence, AtomicU32, Ordering};
use core::task::Waker;

use critical_section::{CriticalSection, Mutex};
use embassy_stm32::interrupt::{self, InterruptExt, Priority};
use embassy_stm32::pac;
use embassy_stm32::pac::timer::{regs, vals};
use embassy_time_driver::{Driver, TICK_HZ};
use embassy_time_queue_utils::Queue;

use super::nucleo_time as arith;

/// TIM2's clock, Hz: APB1 at 42 MHz (SYSCLK 168 MHz / 4, `board::nucleo::run`), doubled
/// because the APB1 prescaler is not 1 (RM0390 6.2, "Clocks": the timer clock is twice
/// PCLK1 when the APB1 prescaler is above 1, RCC_DCKCFGR TIMPRE = 0).
pub const TIMER_HZ: u32 = 84_000_000;

/// TIM2's interrupt priority (4 bits, lower is more urgent): above the control
/// executor's P6 and the communication executor's P10.
pub const PRIORITY: Priority = Priority::P4;

/// The prescaler to 1 us counts; a clock that does not divide to [`TICK_HZ`] does not build.
const PSC: u16 = match arith::prescaler(TIMER_HZ, TICK_HZ as u32) {
    Some(p) => p,
    None => panic!("TIM2's clock does not divide to embassy-time's tick rate"),
};

/// CC1 (index 0 in the PAC): the alarm.
const CC_ALARM: usize = 0;
/// CC2 (index 1): the half-wrap at 0x8000_0000.
const CC_HALF: usize = 1;

struct Tim2Driver {
    /// Half-wraps of the counter since start (written by the TIM2 interrupt only).
    period: AtomicU32,
    /// The alarm's device time, us (`u64::MAX`: none).
    alarm: Mutex<Cell<u64>>,
    /// The timer queue, used only inside a critical section (below).
    queue: Mutex<UnsafeCell<Queue>>,
}

impl Tim2Driver {
    /// Runs `f` on the timer queue.
    fn with_queue<R>(&self, cs: CriticalSection, f: impl FnOnce(&mut Queue) -> R) -> R {
        // SAFETY: the queue is reached only here, inside a critical section (interrupts
        // off on this single core), and `f` (the queue's own methods: waking a task pends
        // its executor's interrupt, it does not call back into the driver) does not
        // re-enter: this is the only reference to it while it lives.
        f(unsafe { &mut *self.queue.borrow(cs).get() })
    }

    /// Sets the alarm to `at` (us); `false` (disarmed) if `at` is not in the future.
    fn set_alarm(&self, cs: CriticalSection, at: u64) -> bool {
        let tim = pac::TIM2;
        self.alarm.borrow(cs).set(at);
        let t = self.now();
        if at <= t {
            tim.dier().modify(|w| w.set_ccie(CC_ALARM, false));
            self.alarm.borrow(cs).set(u64::MAX);
            return false;
        }
        // The compare value first (RM0390 18.4.13 TIMx_CCR1: CC1IF is set when the
        // counter equals it; CCMR1 OC1PE is clear at reset, so the value takes effect at
        // once), so that the compare, when enabled here or at a later period start, is
        // already the right one.
        tim.ccr(CC_ALARM).write_value(at as u32);
        // CC1IE (RM0390 18.4.4 TIMx_DIER) only if the alarm is within the window in
        // which the compare's next match is the alarm itself.
        tim.dier()
            .modify(|w| w.set_ccie(CC_ALARM, arith::arm_now(at, t)));
        // The counter may have passed `at` while it was being set: then the match may
        // or may not have happened; disarm and let the caller take the expired timers.
        if at <= self.now() {
            tim.dier().modify(|w| w.set_ccie(CC_ALARM, false));
            self.alarm.borrow(cs).set(u64::MAX);
            return false;
        }
        true
    }

    /// Wakes the expired timers and sets the alarm to the next one.
    fn trigger_alarm(&self, cs: CriticalSection) {
        loop {
            let next = self.with_queue(cs, |q| q.next_expiration(self.now()));
            if self.set_alarm(cs, next) {
                break;
            }
        }
    }

    /// One more half-wrap: counts it and enables the alarm's compare if the alarm has
    /// come within the window.
    fn next_period(&self, cs: CriticalSection) {
        let period = self.period.load(Ordering::Relaxed).wrapping_add(1);
        self.period.store(period, Ordering::Relaxed);
        if arith::arm_at_period(self.alarm.borrow(cs).get(), period) {
            pac::TIM2.dier().modify(|w| w.set_ccie(CC_ALARM, true));
        }
    }

    fn on_interrupt(&self) {
        let tim = pac::TIM2;
        critical_section::with(|cs| {
            let sr = tim.sr().read();
            let dier = tim.dier().read();
            // TIMx_SR's flags are rc_w0 (RM0390 18.4.5): writing the complement clears
            // exactly the flags read, never one set since (a read-modify-write could).
            tim.sr().write_value(regs::SrGp16(!sr.0));
            if sr.uif() {
                self.next_period(cs);
            }
            if sr.ccif(CC_HALF) {
                self.next_period(cs);
            }
            if sr.ccif(CC_ALARM) && dier.ccie(CC_ALARM) {
                self.trigger_alarm(cs);
            }
        });
    }
}

impl Driver for Tim2Driver {
    fn now(&self) -> u64 {
        let period = self.period.load(Ordering::Relaxed);
        // The period before the counter: see `nucleo_time::now` for the race.
        compiler_fence(Ordering::Acquire);
        arith::now(period, pac::TIM2.cnt().read())
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            if self.with_queue(cs, |q| q.schedule_wake(at, waker)) {
                self.trigger_alarm(cs);
            }
        });
    }
}

embassy_time_driver::time_driver_impl!(static DRIVER: Tim2Driver = Tim2Driver {
    period: AtomicU32::new(0),
    alarm: Mutex::new(Cell::new(u64::MAX)),
    queue: Mutex::new(UnsafeCell::new(Queue::new())),
});

/// Clocks, configures and starts TIM2 and enables its interrupt. Called once, after the
/// clock tree is set (`embassy_stm32::init`) and before the executors start.
pub fn start() {
    let rcc = pac::RCC;
    // Clock TIM2 and reset it to its reset values (RM0390 6.3.13 RCC_APB1ENR TIM2EN,
    // 6.3.8 RCC_APB1RSTR TIM2RST); the read back makes the enable take effect before
    // the timer's registers are written (RM0390 6.3.13: two APB cycles).
    rcc.apb1enr().modify(|w| w.set_tim2en(true));
    let _ = rcc.apb1enr().read();
    rcc.apb1rstr().modify(|w| w.set_tim2rst(true));
    rcc.apb1rstr().modify(|w| w.set_tim2rst(false));

    let tim = pac::TIM2;
    // Counter stopped (TIMx_CR1 CEN, RM0390 18.4.1) while it is configured, from 0.
    tim.cr1().modify(|w| w.set_cen(false));
    tim.cnt().write_value(0);
    // 1 us per count (TIMx_PSC, 18.4.11) over the full 32-bit range (TIMx_ARR, 18.4.12):
    // the counter wraps at 2^32 with an update event.
    tim.psc().write_value(PSC);
    tim.arr().write_value(u32::MAX);
    // The prescaler is buffered: an update generation (TIMx_EGR UG, 18.4.6) loads it.
    // URS = counter only (CR1) while doing so, so the UG sets no UIF (no false wrap).
    tim.cr1().modify(|w| w.set_urs(vals::Urs::COUNTER_ONLY));
    tim.egr().write(|w| w.set_ug(true));
    tim.cr1().modify(|w| w.set_urs(vals::Urs::ANY_EVENT));
    // CC2 compares at the midpoint: the half-wrap (CCMR1 at reset: output compare,
    // frozen, no pin: only the flag).
    tim.ccr(CC_HALF).write_value(arith::HALF);
    // Interrupts on the wrap (UIE) and the half-wrap (CC2IE); CC1IE is the alarm's,
    // set by `set_alarm` (TIMx_DIER, 18.4.4).
    tim.dier().write(|w| {
        w.set_uie(true);
        w.set_ccie(CC_HALF, true);
    });
    interrupt::TIM2.unpend();
    interrupt::TIM2.set_priority(PRIORITY);
    // SAFETY: TIM2's handler (`board::nucleo`) takes the driver's state in a critical
    // section only; enabling it breaks no critical section in progress (none is).
    unsafe { interrupt::TIM2.enable() };
    tim.cr1().modify(|w| w.set_cen(true));
}

/// TIM2's interrupt handler's body.
pub fn on_interrupt() {
    DRIVER.on_interrupt();
}
