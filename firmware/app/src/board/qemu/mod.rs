//! QEMU `mps2-an386` board layer (Cortex-M4F at 25 MHz): CMSDK UART0 for frames (or the
//! semihosting bulk channel, [`bulk`], when the harness asks for it), a
//! frame-clocked embassy-time driver, SysTick as the instruction stopwatch, defmt over
//! semihosting, semihosting exit.
//!
//! Executors: both run in interrupt mode, so thread mode only sleeps. embassy's thread
//! executor idles with WFE, which QEMU treats as a no-op (the CPU spins and virtual time
//! runs away); with every task in an interrupt executor the idle loop is a plain WFI,
//! which QEMU does sleep on, and every wake-up is an interrupt that WFI returns for.
//!
//! | interrupt | priority (NVIC, lower = more urgent) | job |
//! |---|---|---|
//! | TIMER0 (IRQ 8, `free-run` only) | 0x10 | one clock edge per period |
//! | UART0 RX (IRQ 0) | 0x20 | bytes to the RX pipe, frame edges to the clock |
//! | SWI0 (IRQ 16) | 0x40 | control executor: the control task |
//! | UART0 TX (IRQ 1) | 0x80 | holding register free |
//! | SWI1 (IRQ 17) | 0xC0 | communication executor: the UART's TX task |

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

static EXEC_CONTROL: InterruptExecutor = InterruptExecutor::new();
static EXEC_COMMS: InterruptExecutor = InterruptExecutor::new();

/// SysTick as a stopwatch, running only while a tick executes: stopped, it arms no
/// timer, so QEMU's `sleep=off` has nothing to jump virtual time to while the guest
/// waits for the host. Reports instructions (`counts * 40 ns / 2^shift`).
///
/// It counts on from where it stopped (a stopped SysTick holds its count) instead of
/// from a cleared counter: a cleared counter reloads one clock edge after the enable, a
/// timer QEMU expires at once, and each expiry wakes QEMU's main loop (an event and a
/// hand-over of its global lock: about half the CPU of a bulk-channel exchange). The
/// count is read just before the enable, so `start - end` counts from the enable, as the
/// cleared counter's `0 - end` did (the same `exec` bit for bit, `hil/harness/tests/
/// qemu_bulk.rs`); the counter wraps at 2^24 counts either way.
pub struct SysTickStopwatch {
    syst: SYST,
}

impl SysTickStopwatch {
    /// Takes SysTick: core clock, no interrupt, stopped until [`Stopwatch::start`].
    pub fn new(mut syst: SYST) -> Self {
        syst.set_clock_source(SystClkSource::Core);
        syst.disable_interrupt();
        syst.disable_counter();
        Self { syst }
    }
}

impl Stopwatch for SysTickStopwatch {
    /// The count, then the enable, then one read of the counter as before (the
    /// instructions after the enable, counted in the tick, are those of the cleared
    /// counter's start): in assembly, so that the compiler keeps this order.
    fn start(&mut self) -> u32 {
        let start: u32;
        // SAFETY: SysTick's registers (CSR, RVR, CVR at 0xE000_E010/14/18), owned by this
        // stopwatch (`self.syst`); word accesses to the core's own System Control
        // Space, no memory of the program touched.
        unsafe {
            core::arch::asm!(
                "str {reload}, [{base}, #4]",
                "ldr {start}, [{base}, #8]",
                "ldr {tmp}, [{base}, #0]",
                "orr {tmp}, {tmp}, #1",
                "str {tmp}, [{base}, #0]",
                "ldr {tmp}, [{base}, #8]",
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
        let end = SYST::get_current();
        self.syst.disable_counter();
        // Free-running (no -icount): SysTick counts the 25 MHz clock of virtual time,
        // which follows the host's; the counts are reported as they are (cycles of
        // 25 MHz, 40 ns each), not as instructions.
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
    app::control_loop::<Board, _>(app::new_device::<Board>, stopwatch).await
}

/// The UART's transmitter (the bulk channel's receiver sends the frames itself,
/// [`bulk::Bulk::run`]).
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

    /// QEMU has no reset-cause register: a reset nobody recorded a cause for is UNKNOWN;
    /// a fresh QEMU process starts from zeroed RAM (no valid record: boot 1, POWER_ON).
    fn reset_cause() -> (Option<u8>, bool) {
        (None, false)
    }

    fn send_safe_frame() {
        send_safe_frame()
    }

    /// Sends the safe frame and exits QEMU with a failure status.
    fn halt() -> ! {
        if !crate::panic::enter_halt() {
            send_safe_frame();
        }
        loop {
            cortex_m_semihosting::debug::exit(cortex_m_semihosting::debug::EXIT_FAILURE);
        }
    }

    fn inject(c: wheelset_proto::Command) {
        crate::panic::inject(c)
    }
}

/// The highest base rate a host Config may set: no limit, the QEMU build is
/// frame-clocked (lock-step: its frames are the clock, whatever the link's speed).
#[cfg(not(feature = "free-run"))]
pub const LINK_MAX_RATE_HZ: u32 = u32::MAX;

/// The highest base rate a host Config may set on the free-running build: what QEMU's
/// CMSDK UART over a TCP chardev carries in real time. QEMU hands the UART one byte per
/// round trip between its I/O and vCPU threads: 26-55 kB/s host -> device measured on
/// this project's 2-core machine (a flood of delimiters; quiet machines at the low end),
/// so a 23-byte Sensor frame takes 0.4-0.9 ms to cross and 1 kHz (23.5 kB/s, the frame
/// in half a period) does not hold; 500 Hz does (README, "QEMU free-running").
#[cfg(feature = "free-run")]
pub const LINK_MAX_RATE_HZ: u32 = 500;

/// Sends the safe frame by polling (interrupts off).
fn send_safe_frame() {
    let mut buf = [0u8; wheelset_proto::MAX_FRAME];
    let frame = crate::device::safe_frame(&mut buf);
    if bulk::active() {
        bulk::write_all(frame);
    } else {
        // A lone delimiter first: the handler that sends this (panic, HardFault, the
        // watchdog's NMI) may have interrupted the TX task with a frame half on the wire;
        // the delimiter ends that one (the host drops it as a bad frame), so that the safe
        // frame arrives whole. (The bulk channel writes whole frames: nothing is half out.)
        uart::write_blocking(&[0]);
        uart::write_blocking(frame);
    }
}

/// The watchdog's first expiry (its interrupt is the NMI; free-running build only): a
/// stalled control task or receive path. Records the cause WATCHDOG in the boot record,
/// sends the safe frame and waits for the second expiry, which resets the board
/// ([`wdog::GRACE_COUNTS`]). The control task stalls at a higher priority than the TX
/// task, which may have had a frame half on the wire: [`send_safe_frame`] ends it with a
/// lone delimiter first.
#[cortex_m_rt::exception]
unsafe fn NonMaskableInt() {
    wdog::grace();
    crate::boot::record_cause(wheelset_proto::reset_cause::WATCHDOG);
    if !crate::panic::enter_halt() {
        send_safe_frame();
    }
    loop {
        core::hint::spin_loop();
    }
}

/// Brings the board up and runs forever.
fn run() -> ! {
    let Some(mut core) = cortex_m::Peripherals::take() else {
        defmt::error!("core peripherals taken twice");
        <Board as super::Board>::halt();
    };
    let stopwatch = SysTickStopwatch::new(core.SYST);
    // The boot record (crate::boot).
    let (boot_count, reset_cause) = crate::boot::start_on::<Board>();
    defmt::info!("boot {=u32}, reset cause {=u8}", boot_count, reset_cause);
    // The bulk channel if the harness asked for it (blocks until it opened its ends).
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

    // SAFETY: priorities are set before any of these interrupts is enabled, so no
    // priority-based critical section can be broken by the change.
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

    // SAFETY: the handlers of both UART interrupts are defined below and only touch the
    // UART and lock-protected queues.
    unsafe {
        NVIC::unmask(Interrupt::Uart0Rx);
        NVIC::unmask(Interrupt::Uart0Tx);
        #[cfg(feature = "free-run")]
        NVIC::unmask(Interrupt::Timer0);
    }
    if let Some(bulk) = bulk {
        defmt::info!("frames over the semihosting bulk channel");
        // Its loop is thread mode's (a blocking read does not advance virtual time):
        // the watchdog would run throughout and bulk::run feeds it (lock-step only,
        // so not started: wdog::ENABLED).
        if wdog::ENABLED {
            wdog::start();
        }
        bulk.run();
    }
    // A byte that arrived before the RX interrupt was enabled raised none: look once.
    NVIC::pend(Interrupt::Uart0Rx);
    idle()
}

/// Thread mode's idle loop, lock-step (`-icount`): a plain WFI, no watchdog (QEMU 7.2's
/// cannot be paused while the guest waits for the host: [`wdog`]).
#[cfg(not(feature = "free-run"))]
fn idle() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}

/// Thread mode's idle loop, free-running (QEMU's clock follows the host's, WFI sleeps
/// without clock jumps): the watchdog counts wall time as on a board; it starts at the
/// first feed (the host's first bytes and a tick after them) and is fed by the same rule.
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
        // SAFETY: not inside a critical section (thread mode's idle loop, which masked
        // interrupts itself just above).
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
