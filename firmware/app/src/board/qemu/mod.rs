//! QEMU `mps2-an386` board layer (Cortex-M4F, 25 MHz): UART0 or the bulk channel for
//! frames, a frame-clocked time driver, SysTick as instruction stopwatch, defmt over
//! semihosting. Both executors run in interrupt mode, so thread mode idles with WFI
//! (QEMU spins on embassy's WFE).

mod bulk;
pub mod clock;
mod log;
pub mod pac;
pub mod uart;
pub mod wdog;

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{NVIC, SYST};
use embassy_executor::InterruptExecutor;

use crate::app::{self, Stopwatch};
use crate::exec::{systick_elapsed, systick_to_instructions};
use pac::Interrupt;

pub(super) static EXEC_CONTROL: InterruptExecutor = InterruptExecutor::new();
static EXEC_COMMS: InterruptExecutor = InterruptExecutor::new();

/// SysTick as a stopwatch of instructions, `counts * 40 ns / 2^shift`, running only while a
/// tick executes (stopped, it arms no timer for `sleep=off` to jump to).
pub struct SysTickStopwatch {
    /// Owned: nothing else touches SysTick (the stopwatch's accesses are in assembly).
    _syst: SYST,
}

impl SysTickStopwatch {
    /// Takes SysTick: core clock, no interrupt, stopped until [`Stopwatch::start`].
    pub fn new(mut syst: SYST) -> Self {
        syst.set_clock_source(SystClkSource::Core);
        syst.disable_interrupt();
        syst.disable_counter();
        syst.set_reload(0x00FF_FFFF);
        Self { _syst: syst }
    }
}

impl Stopwatch for SysTickStopwatch {
    /// The held count, the enable: in assembly, so the order is kept. The register moves are
    /// padding keeping the sequence's instruction count, so `exec` keeps its golden values.
    fn start(&mut self) -> u32 {
        let start: u32;
        // SAFETY: word accesses to SysTick's registers (0xE000_E010/18), owned by this stopwatch.
        unsafe {
            core::arch::asm!(
                "mov {tmp}, {reload}",
                "ldr {start}, [{base}, #8]",
                "mov {tmp}, #5",
                "mov {tmp}, {tmp}",
                "str {tmp}, [{base}, #0]",
                "mov {tmp}, {tmp}",
                base = in(reg) 0xE000_E010u32,
                reload = in(reg) 0x00FF_FFFFu32,
                start = out(reg) start,
                tmp = out(reg) _,
                options(nostack, preserves_flags),
            );
        }
        start
    }

    fn stop(&mut self, start: u32) -> u32 {
        let end: u32;
        // SAFETY: as in `start`.
        unsafe {
            core::arch::asm!(
                "ldr {end}, [{base}, #8]",
                "mov {tmp}, #4",
                "str {tmp}, [{base}, #0]",
                base = in(reg) 0xE000_E010u32,
                end = out(reg) end,
                tmp = out(reg) _,
                options(nostack, preserves_flags),
            );
        }
        // Free-running (no -icount): 25 MHz cycles of virtual time, reported as they are.
        if cfg!(feature = "free-run") {
            return systick_elapsed(start, end);
        }
        systick_to_instructions(
            systick_elapsed(start, end),
            crate::settings::QEMU_ICOUNT_SHIFT,
        )
    }
}

#[embassy_executor::task]
async fn control_task(stopwatch: SysTickStopwatch) {
    app::control_loop::<Board>(app::new_device::<Board>, stopwatch).await
}

/// The UART's transmitter (the bulk channel's receiver sends its frames itself).
#[embassy_executor::task]
async fn tx_task() {
    let mut buf = [0u8; 64];
    loop {
        let n = app::TX.read(&mut buf).await;
        uart::write_all(buf.get(..n).unwrap_or(&[])).await;
    }
}

/// QEMU's mps2-an386.
pub struct Board;

impl super::Board for Board {
    const LINK_MAX_RATE_HZ: u32 = LINK_MAX_RATE_HZ;
    const WATCHDOG_ENDS_STALL: bool = wdog::ENABLED;
    type Stopwatch = SysTickStopwatch;

    fn run() -> ! {
        run()
    }

    fn set_period(ticks: u64) {
        clock::set_period(ticks)
    }

    /// No reset-cause register: an unrecorded reset is UNKNOWN; a fresh process POWER_ON.
    fn reset_cause() -> (Option<u8>, bool) {
        (None, false)
    }

    fn send_safe_frame() {
        let mut buf = [0u8; wheelset_proto::MAX_FRAME];
        let frame = crate::device::safe_frame(&mut buf);
        if bulk::active() {
            bulk::flush_answers();
            bulk::write_all(frame);
        } else {
            // A lone delimiter ends a frame the interrupted TX task left half sent.
            uart::write_blocking(&[0]);
            uart::write_blocking(frame);
        }
    }

    /// Sends the safe frame and exits QEMU with a failure status.
    fn halt() -> ! {
        crate::panic::send_safe_frame_once();
        loop {
            cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
        }
    }

    fn inject(c: wheelset_proto::Command) {
        crate::panic::inject(c)
    }
}

/// No limit on the base rate: the QEMU build is frame-clocked (its frames are the clock).
#[cfg(not(feature = "free-run"))]
pub const LINK_MAX_RATE_HZ: u32 = u32::MAX;

/// The free-running build's highest base rate: QEMU's UART over TCP moves one byte per
/// thread round trip, so 1 kHz does not hold on a busy host and 500 Hz does.
#[cfg(feature = "free-run")]
pub const LINK_MAX_RATE_HZ: u32 = 500;

/// The watchdog's first expiry (the NMI; free-running only): records WATCHDOG, sends the
/// safe frame, waits for the second expiry's reset ([`wdog::GRACE_COUNTS`]).
#[cortex_m_rt::exception]
unsafe fn NonMaskableInt() {
    wdog::grace();
    crate::boot::record_cause(wheelset_proto::reset_cause::WATCHDOG);
    crate::panic::send_safe_frame_once();
    loop {
        core::hint::spin_loop();
    }
}

fn run() -> ! {
    let Some(mut core) = cortex_m::Peripherals::take() else {
        defmt::error!("core peripherals taken twice");
        <Board as super::Board>::halt();
    };
    let stopwatch = SysTickStopwatch::new(core.SYST);
    let (boot_count, reset_cause) = crate::boot::start_on::<Board>();
    defmt::info!("boot {=u32}, reset cause {=u8}", boot_count, reset_cause);
    let bulk = bulk::open();
    uart::init();
    defmt::info!(
        "wheelset-qemu: {} Hz base rate, {} build, {}",
        crate::settings::BASE_RATE_HZ,
        crate::settings::NUMERIC,
        if cfg!(feature = "free-run") {
            "free-running on TIMER0"
        } else {
            "frame-clocked lock-step"
        }
    );

    // SAFETY: priorities are set before any of these interrupts is enabled.
    unsafe {
        core.NVIC.set_priority(Interrupt::Timer0, 0x10);
        core.NVIC.set_priority(Interrupt::Uart0Rx, 0x20);
        core.NVIC.set_priority(Interrupt::Swi0, 0x40);
        core.NVIC.set_priority(Interrupt::Uart0Tx, 0x80);
        core.NVIC.set_priority(Interrupt::Swi1, 0xC0);
    }
    let control = EXEC_CONTROL.start(Interrupt::Swi0);
    control.spawn(app::token::<Board, _>(control_task(stopwatch)));
    let comms = EXEC_COMMS.start(Interrupt::Swi1);
    if bulk.is_none() {
        comms.spawn(app::token::<Board, _>(tx_task()));
    }

    // SAFETY: both UART handlers are defined below and touch only the UART and locked queues.
    unsafe {
        NVIC::unmask(Interrupt::Uart0Rx);
        NVIC::unmask(Interrupt::Uart0Tx);
        #[cfg(feature = "free-run")]
        NVIC::unmask(Interrupt::Timer0);
    }
    if let Some(bulk) = bulk {
        defmt::info!("frames over the semihosting bulk channel");
        // The receiver polls the control executor after each frame edge itself: SWI0 stays
        // pending, masked, and no exception is taken per frame (the same tick, in thread mode).
        NVIC::mask(Interrupt::Swi0);
        // A blocking read does not advance virtual time; the watchdog stays off in lock-step.
        if wdog::ENABLED {
            wdog::start();
        }
        bulk.run();
    }
    // A byte that arrived before the RX interrupt was enabled raised none: look once.
    NVIC::pend(Interrupt::Uart0Rx);
    idle()
}

/// Thread mode's idle loop, lock-step (`-icount`): a plain WFI, no watchdog ([`wdog`]).
#[cfg(not(feature = "free-run"))]
fn idle() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

/// Thread mode's idle loop, free-running: the watchdog counts wall time as on a board.
#[cfg(feature = "free-run")]
fn idle() -> ! {
    let mut started = false;
    loop {
        cortex_m::interrupt::disable();
        if crate::watchdog::take_both() {
            if started {
                wdog::feed();
            } else {
                wdog::start();
                started = true;
            }
        }
        cortex_m::asm::wfi();
        // SAFETY: not inside a critical section (the idle loop masked interrupts itself).
        unsafe { cortex_m::interrupt::enable() };
    }
}

#[allow(non_snake_case)]
#[unsafe(no_mangle)]
extern "C" fn SWI0() {
    // SAFETY: this is SWI0's handler, the interrupt EXEC_CONTROL was started on.
    unsafe { EXEC_CONTROL.on_interrupt() }
}

#[allow(non_snake_case)]
#[unsafe(no_mangle)]
extern "C" fn SWI1() {
    // SAFETY: this is SWI1's handler, the interrupt EXEC_COMMS was started on.
    unsafe { EXEC_COMMS.on_interrupt() }
}

#[allow(non_snake_case)]
#[unsafe(no_mangle)]
extern "C" fn UART0RX() {
    uart::on_rx_interrupt();
}

#[cfg(feature = "free-run")]
#[allow(non_snake_case)]
#[unsafe(no_mangle)]
extern "C" fn TIMER0() {
    clock::timer::on_interrupt();
}

#[allow(non_snake_case)]
#[unsafe(no_mangle)]
extern "C" fn UART0TX() {
    uart::on_tx_interrupt();
}
