//! What the STM32 boards share: the DWT stopwatch, the UART's DMA tasks, two interrupt
//! executors, the watchdog, the fault path's end, the clock checks ([`clock`]).
//! Priorities: TIM2 P4 > control executor P6 > link UART and DMA P8 > communication
//! executor P10 > thread mode, so a UART burst cannot delay a tick.

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

use super::Selected;
use crate::app::{self, Stopwatch};
use crate::bounded;
use crate::exec::cyccnt_elapsed;

/// The time driver's TIM2 interrupt: above both executors, so the ticker wakes on time.
const TIME_PRIORITY: Priority = Priority::P4;
const CONTROL_PRIORITY: Priority = Priority::P6;
/// The link UART's and DMA's interrupts: below the control executor (a burst cannot delay
/// a tick), above the communication executor (the driver's state is current for its tasks).
pub const UART_PRIORITY: Priority = Priority::P8;
const COMMS_PRIORITY: Priority = Priority::P10;

/// The receive DMA ring, bytes: more than five worst-case Sensor frames.
pub const RX_RING: usize = 256;
/// The most bytes of one transmit transfer (a longer frame goes in several).
const TX_LEN: usize = 64;

/// The independent watchdog's timeout, us, at the LSI's nominal 32 kHz: far above a
/// period, so only a stalled task or a silent link resets the board (`reset_cause` WATCHDOG).
pub const IWDG_TIMEOUT_US: u32 = 250_000;

/// The core clock, Hz (16 MHz HSI from reset, SYSCLK once [`clocks`] ran).
static CORE_HZ: AtomicU32 = AtomicU32::new(16_000_000);
/// Polls of TXE within which a byte must go out on the fault path (0: UART not configured).
static FAULT_POLLS: AtomicU32 = AtomicU32::new(0);

static EXEC_CONTROL: InterruptExecutor = InterruptExecutor::new();
static EXEC_COMMS: InterruptExecutor = InterruptExecutor::new();

/// The DWT cycle counter as a stopwatch (32-bit, wrapping difference).
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

/// The highest base rate a link at `baud` carries (`wheelset_proto::link`).
pub const fn link_max_rate_hz(baud: u32) -> u32 {
    wheelset_proto::link::max_rate_hz(
        baud,
        wheelset_proto::SENSOR_MAX_FRAME as u32,
        wheelset_proto::ACTUATION_MAX_FRAME as u32,
        LINK_LATENCY_NS,
        wheelset_proto::link::LINK_SHARE_MAX_PERMILLE,
    )
}

/// Whether a link at `baud` carries the build's base rate (asserted at compile time).
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

/// The reset cause from RCC CSR flags, in priority order (the pin flag last: every
/// internal reset sets it too), and whether it was a power-on reset.
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

/// The safe frame by bounded polled writes: a lone delimiter first (ending a half-sent
/// frame), and `tc` last (so the reset does not cut the last byte).
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

/// The end of every fault path but HardFault's: interrupts off, the safe frame, cause
/// FAULT, 0.1 s for a probe to read the log, SYSRESETREQ; no unbounded wait.
pub fn halt() -> ! {
    cortex_m::interrupt::disable();
    crate::panic::send_safe_frame_once();
    crate::boot::record_cause(wheelset_proto::reset_cause::FAULT);
    cortex_m::asm::delay(CORE_HZ.load(Ordering::Relaxed) / 10);
    SCB::sys_reset()
}

/// Stops the board at start-up on a configuration it cannot run: logged, then the fault path.
#[cold]
pub fn refuse(what: &str) -> ! {
    defmt::error!("start-up refused: {=str}", what);
    halt()
}

/// The clock checks: the UART's baud within `tolerance_permille` ([`clock`]), TIM2 exact.
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

/// SYSCLK, PCLK1 and TIM2's clock, Hz, from the configured tree; starts the DWT counter.
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

/// The link UART at `baud`, split, reception into the DMA ring started.
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
    app::control_loop::<Selected>(app::new_device::<Selected>, DwtStopwatch).await;
    #[cfg(feature = "frame-clock")]
    app::frame_loop::<Selected>(app::new_device::<Selected>, DwtStopwatch).await
}

/// The receive task: the DMA ring's bytes into the RX pipe; `rx_overrun` counts one per
/// receive error (the lost bytes are unknown) and each byte the pipe had no room for.
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

/// Runs the firmware: the control executor, the communication executor with the RX and
/// TX tasks, thread mode in WFI feeding the watchdog (started at the first feed).
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
