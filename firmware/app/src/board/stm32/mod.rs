//! What the STM32 boards share on embassy-stm32 0.6: the DWT stopwatch, the tasks around
//! the UART driver (a DMA receive ring, DMA transmission), two interrupt executors, the
//! independent watchdog's feeding, the fault path's end, and the clock checks
//! ([`clock`]). A board module adds its clock tree, its UART and pins, its reset flags
//! and the polled safe frame of its fault path.
//!
//! Executors and priorities (4 priority bits, lower = more urgent):
//!
//! | context | priority | job |
//! |---|---|---|
//! | TIM2 (embassy-stm32's time driver) | P4 | wakes the ticker |
//! | UART4 (unused peripheral, software-pended) | P6 | control executor: the control task |
//! | the link's UART and DMA channels (embassy-stm32's handlers) | P8 | UART driver |
//! | UART5 (unused peripheral, software-pended) | P10 | communication executor: RX task, TX task |
//! | thread mode | lowest | WFI, feeds the IWDG |
//!
//! A UART burst is handled by the DMA, the driver's interrupts and the communication
//! executor, all of which the control executor preempts: it cannot delay a tick. (Both
//! executors run in interrupt mode, so the thread executor is not linked.)

pub mod clock;

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::{DWT, SCB};
use defmt_rtt as _;
use embassy_executor::InterruptExecutor;
use embassy_stm32::interrupt::{self, InterruptExt, Priority};
use embassy_stm32::mode::Async;
use embassy_stm32::peripherals::{IWDG, RCC};
use embassy_stm32::usart::{self, RingBufferedUartRx, Uart, UartTx};
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::Peri;

use super::{Board as _, Selected};
use crate::app::{self, Stopwatch};
use crate::bounded;
use crate::exec::cyccnt_elapsed;

/// The time driver's TIM2 interrupt: above both executors, so the control task's ticker
/// is woken on time whatever the communication executor does.
const TIME_PRIORITY: Priority = Priority::P4;
/// The control executor's.
const CONTROL_PRIORITY: Priority = Priority::P6;
/// The link UART's and its DMA channels' interrupts (embassy-stm32 sets every DMA
/// channel's from its `Config`'s DMA interrupt priority): below the control executor (a UART
/// burst cannot delay a tick), above the communication executor (the driver's state is
/// up to date whenever the RX and TX tasks run).
pub const UART_PRIORITY: Priority = Priority::P8;
/// The communication executor's.
const COMMS_PRIORITY: Priority = Priority::P10;

/// The receive DMA ring, bytes: more than five worst-case Sensor frames; the RX task
/// empties it at each IDLE line or half ring.
pub const RX_RING: usize = 256;
/// The most bytes of one transmit transfer (the TX pipe is a byte stream: a longer
/// frame goes in several transfers, back to back).
const TX_LEN: usize = 64;

/// The independent watchdog's timeout, us, at the LSI's nominal 32 kHz (the HAL derives
/// its prescaler and reload from it). The board feeds it once per control period when
/// the host's frames come (200 us at the 5 kHz base rate), so neither a late tick nor a
/// frame-clocked build's USB latency comes near it, while a stalled control task or a
/// silent link puts the outputs back to the reset state within half a second. Once
/// started it runs until the next reset (a debugger halting the core does not stop it:
/// DBGMCU is left as it is); its reset sets the RCC CSR flag IWDGRSTF, which the boot
/// record reports as `reset_cause` WATCHDOG.
pub const IWDG_TIMEOUT_US: u32 = 250_000;

/// The core clock, Hz: the HSI's 16 MHz from reset (both boards' reset clock), SYSCLK
/// from the configured clock tree once the board set it ([`clocks`]). The fault
/// path's bounds and its delay before the reset are counted in its cycles.
static CORE_HZ: AtomicU32 = AtomicU32::new(16_000_000);
/// Polls of the link UART's TXE flag within which a byte must go out on the fault path
/// ([`bounded::polls_per_char`] at the core clock and the link's baud); 0 until the UART
/// is configured, and then the fault path sends nothing (nobody can hear it).
static FAULT_POLLS: AtomicU32 = AtomicU32::new(0);

static EXEC_CONTROL: InterruptExecutor = InterruptExecutor::new();
static EXEC_COMMS: InterruptExecutor = InterruptExecutor::new();

/// The DWT cycle counter as a stopwatch: core cycles at SYSCLK (read from the clock tree
/// and logged at start-up; a host converts them to time with it). The counter is 32 bits:
/// a measurement is the wrapping difference of two reads
/// (`crate::exec::cyccnt_elapsed`), right for any tick shorter than a wrap.
pub struct DwtStopwatch;

impl Stopwatch for DwtStopwatch {
    fn start(&mut self) -> u32 {
        DWT::cycle_count()
    }

    fn stop(&mut self, start: u32) -> u32 {
        cyccnt_elapsed(start, DWT::cycle_count())
    }
}

/// One-way latency of a board's link the budget allows for (UART FIFO + DMA hand-off), ns.
pub const LINK_LATENCY_NS: u64 = 2_000;

/// The highest base rate a link at `baud` carries: one worst-case Sensor frame up and one
/// Actuation frame down per period within the project's link budget
/// (`wheelset_proto::link`). A host Config above it is refused.
pub const fn link_max_rate_hz(baud: u32) -> u32 {
    wheelset_proto::link::max_rate_hz(
        baud,
        wheelset_proto::SENSOR_MAX_FRAME as u32,
        wheelset_proto::ACTUATION_MAX_FRAME as u32,
        LINK_LATENCY_NS,
        wheelset_proto::link::LINK_SHARE_MAX_PERMILLE,
    )
}

/// Whether a link at `baud` carries one exchange per period at the build's base rate
/// (a board asserts it at compile time).
pub const fn carries_base_rate(baud: u32) -> bool {
    wheelset_proto::link::link_fits(
        crate::settings::BASE_RATE_HZ,
        baud,
        wheelset_proto::SENSOR_MAX_FRAME as u32,
        wheelset_proto::ACTUATION_MAX_FRAME as u32,
        LINK_LATENCY_NS,
        wheelset_proto::link::LINK_SHARE_MAX_PERMILLE,
    )
    .is_ok()
}

/// The reset cause from a board's RCC CSR flags, in priority order (the reset pin flag is
/// set by every internal reset too, so it comes last), and whether it was a power-on or
/// brown-out reset.
pub fn reset_cause(
    power_on: bool,
    watchdog: bool,
    software: bool,
    pin: bool,
) -> (Option<u8>, bool) {
    use wheelset_proto::reset_cause as rc;
    let cause = if power_on {
        rc::POWER_ON
    } else if watchdog {
        rc::WATCHDOG
    } else if software {
        rc::SOFTWARE
    } else if pin {
        rc::PIN
    } else {
        rc::UNKNOWN
    };
    (Some(cause), power_on)
}

/// The safe frame by polled writes on the link UART (the fault path): nothing before the
/// UART is configured (`FAULT_POLLS` 0); else `stop_dma` (with the per-byte bound) stops
/// its transmit DMA, then a lone delimiter (it ends a frame the DMA left half sent, so
/// that the safe frame arrives whole), the frame, each byte after `txe` within the bound;
/// then `tc` (the last byte off the shift register, so a reset next does not cut it)
/// within twice that bound. A byte that does not go out within its bound ends the frame.
pub fn send_polled(
    stop_dma: impl FnOnce(u32),
    txe: impl Fn() -> bool,
    write: impl Fn(u8),
    tc: impl Fn() -> bool,
) {
    let polls = FAULT_POLLS.load(Ordering::Relaxed);
    if polls == 0 {
        return;
    }
    stop_dma(polls);
    let mut buf = [0u8; wheelset_proto::MAX_FRAME];
    let frame = crate::device::safe_frame(&mut buf);
    if bounded::write_polled(&[0], polls, &txe, &write) == 1 {
        let _ = bounded::write_polled(frame, polls, &txe, &write);
    }
    let _ = bounded::poll_until(polls.saturating_mul(2), tc);
}

/// The end of every fault path but the HardFault handler's: interrupts off, the board's
/// safe frame (bounded), the cause FAULT in the boot record, a tenth of a second of core
/// cycles for a debug probe to read the defmt log from RAM, then a system reset (SCB
/// AIRCR SYSRESETREQ). It never waits on a peripheral without a bound and ends in the
/// reset whether or not the watchdog has started: the board reboots into its safe
/// outputs and reports `reset_cause` FAULT.
pub fn halt() -> ! {
    cortex_m::interrupt::disable();
    if !crate::panic::enter_halt() {
        Selected::send_safe_frame();
    }
    crate::boot::record_cause(wheelset_proto::reset_cause::FAULT);
    cortex_m::asm::delay(CORE_HZ.load(Ordering::Relaxed) / 10);
    SCB::sys_reset()
}

/// Stops the board at start-up on a configuration it cannot run (the clock tree does not
/// give what the build assumes; a driver refused its configuration): a build error in
/// disguise, logged, then the fault path.
#[cold]
pub fn refuse(what: &str) -> ! {
    defmt::error!("start-up refused: {=str}", what);
    halt()
}

/// The clock checks of a board build: its UART makes `baud` from `uart_hz` within
/// `tolerance_permille` (`made_baud`: the UART's divider model, [`clock`]), and TIM2's
/// clock `tim_hz` counts the time driver's ticks exactly.
pub fn check_clocks(
    made_baud: Option<u32>,
    baud: u32,
    tolerance_permille: u32,
    tim_hz: u32,
) -> Result<(), &'static str> {
    if !clock::within(made_baud, baud, tolerance_permille) {
        return Err("the link UART cannot make the build's baud from its clock");
    }
    if !clock::timer_divides(tim_hz, embassy_time_driver::TICK_HZ as u32) {
        return Err("TIM2's clock is not a whole multiple of the time driver's tick");
    }
    Ok(())
}

/// The clock figures the firmware needs, Hz, read from the clock tree `embassy_stm32::init`
/// configured: SYSCLK (stored for the fault path), PCLK1 and APB1's timer clock (TIM2's).
/// Also sets the time driver's interrupt priority and starts the DWT cycle counter.
pub fn clocks(rcc: &Peri<'static, RCC>) -> (u32, u32, u32) {
    interrupt::TIM2.set_priority(TIME_PRIORITY);
    let clocks = embassy_stm32::rcc::clocks(rcc);
    let hz = |h: embassy_stm32::time::MaybeHertz| h.to_hertz().map_or(0, |h| h.0);
    let sys_hz = hz(clocks.sys);
    CORE_HZ.store(sys_hz, Ordering::Relaxed);
    if let Some(mut core) = cortex_m::Peripherals::take() {
        core.DCB.enable_trace();
        core.DWT.enable_cycle_counter();
    }
    (sys_hz, hz(clocks.pclk1), hz(clocks.pclk1_tim))
}

/// 8N1 at `baud`.
pub fn uart_config(baud: u32) -> usart::Config {
    let mut c = usart::Config::default();
    c.baudrate = baud;
    c
}

/// The link UART as the HAL configured it (at `baud`; `name` for the refusal), its
/// interrupt at [`UART_PRIORITY`]: split, reception into the DMA ring started; from here
/// the fault path may send on it.
pub fn link(
    uart: Result<Uart<'static, Async>, usart::ConfigError>,
    irq: impl InterruptExt,
    baud: u32,
) -> (UartTx<'static, Async>, RingBufferedUartRx<'static>) {
    let Ok(uart) = uart else {
        refuse("the link UART's configuration")
    };
    irq.set_priority(UART_PRIORITY);
    let polls = bounded::polls_per_char(CORE_HZ.load(Ordering::Relaxed), baud);
    FAULT_POLLS.store(polls, Ordering::Relaxed);
    let (tx, rx) = uart.split();
    let Some(ring) = cortex_m::singleton!(: [u8; RX_RING] = [0; RX_RING]) else {
        refuse("receive ring taken twice")
    };
    let mut rx = rx.into_ring_buffered(ring);
    rx.start_uart();
    (tx, rx)
}

#[embassy_executor::task]
async fn control_task() {
    #[cfg(not(feature = "frame-clock"))]
    app::control_loop::<Selected, _>(app::new_device::<Selected>, DwtStopwatch).await;
    #[cfg(feature = "frame-clock")]
    app::frame_loop::<Selected, _>(app::new_device::<Selected>, DwtStopwatch).await
}

/// The receive task: the bytes the DMA ring holds into the RX pipe, at each IDLE line
/// (a frame ended), half ring or error.
///
/// `rx_overrun` (the Status, through `app::RX_OVERRUN`) counts what the driver reports,
/// with no arithmetic that could jump: one for each receive error the HAL returns
/// (`usart::Error::Overrun`: the UART's overrun flag, or the DMA lapping the ring
/// before the task read it; `Framing`, `Noise`, `Parity`: a corrupted character),
/// since neither the UART nor the ring says how many bytes an error lost; plus each
/// byte the RX pipe had no room for. After an error the HAL stops reception and restarts
/// it at the next read; the frame decoder resynchronises on the next delimiter. (Whether
/// one line fault gives one report or also a second while the HAL re-synchronises its
/// ring is for a board to show; none has run here.) The sum is the runtime's
/// (`Runtime::note_board`), wrapping after 2^32 as every Status counter.
#[embassy_executor::task]
async fn rx_task(mut rx: RingBufferedUartRx<'static>) {
    let mut buf = [0u8; 32];
    loop {
        match rx.read(&mut buf).await {
            Ok(n) => {
                crate::watchdog::rx_ran();
                let mut rest = buf.get(..n).unwrap_or(&[]);
                #[cfg(feature = "frame-clock")]
                let edges = rest.iter().filter(|&&b| b == 0).count() as u32;
                while let Ok(w @ 1..) = app::RX.try_write(rest) {
                    rest = rest.get(w..).unwrap_or(&[]);
                }
                // One tick per frame delimiter, after its bytes are in the pipe.
                #[cfg(feature = "frame-clock")]
                app::edges::add(edges);
                if !rest.is_empty() {
                    app::RX_OVERRUN.fetch_add(rest.len() as u32, Ordering::Relaxed);
                    defmt::warn!("RX pipe full: {=usize} bytes dropped", rest.len());
                }
            }
            Err(e) => {
                app::RX_OVERRUN.fetch_add(1, Ordering::Relaxed);
                defmt::warn!("UART RX error: {}", e);
            }
        }
    }
}

/// The transmit task: the TX pipe's bytes out by DMA, up to [`TX_LEN`] per transfer.
#[embassy_executor::task]
async fn tx_task(mut tx: UartTx<'static, Async>) {
    let mut buf = [0u8; TX_LEN];
    loop {
        let n = app::TX.read(&mut buf).await;
        if tx.write(buf.get(..n).unwrap_or(&[])).await.is_err() {
            defmt::warn!("UART TX error");
        }
    }
}

/// Runs the firmware on a board brought up to here (clocks, time driver, link UART):
/// the control executor with the control task, the communication executor with the RX
/// and TX tasks, and thread mode sleeping in WFI and feeding the independent watchdog
/// when the tick and the receive path have both run (`crate::watchdog`). The watchdog is
/// configured now and started at the first such feed (the host's first bytes and a tick
/// after them), so a board waiting for its host is not reset.
pub fn serve(
    rx: RingBufferedUartRx<'static>,
    tx: UartTx<'static, Async>,
    iwdg: Peri<'static, IWDG>,
) -> ! {
    interrupt::UART4.set_priority(CONTROL_PRIORITY);
    let control = EXEC_CONTROL.start(interrupt::UART4);
    control.spawn(app::token::<Selected, _>(control_task()));

    interrupt::UART5.set_priority(COMMS_PRIORITY);
    let comms = EXEC_COMMS.start(interrupt::UART5);
    comms.spawn(app::token::<Selected, _>(rx_task(rx)));
    comms.spawn(app::token::<Selected, _>(tx_task(tx)));

    let mut iwdg = IndependentWatchdog::new(iwdg, IWDG_TIMEOUT_US);
    let mut started = false;
    loop {
        if crate::watchdog::take_both() {
            if !started {
                iwdg.unleash();
                started = true;
            }
            iwdg.pet();
        }
        cortex_m::asm::wfi();
    }
}

#[allow(non_snake_case)]
#[embassy_stm32::interrupt]
unsafe fn UART5() {
    // SAFETY: this is UART5's handler, the interrupt EXEC_COMMS was started on.
    unsafe { EXEC_COMMS.on_interrupt() }
}

#[allow(non_snake_case)]
#[embassy_stm32::interrupt]
unsafe fn UART4() {
    // SAFETY: this is UART4's handler, the interrupt EXEC_CONTROL was started on.
    unsafe { EXEC_CONTROL.on_interrupt() }
}
