//! Nucleo-F446RE board layer (STM32F446RE, Cortex-M4F) on embassy-stm32 0.6: its clock
//! tree set-up, its TIM2 time driver (feature `time-driver-tim2`), its USART2 driver
//! (PA2 TX / PA3 RX) with reception into a DMA ring (`RingBufferedUartRx`, DMA1 stream 5)
//! and transmission by DMA (`UartTx`, DMA1 stream 6), its independent watchdog
//! (`wdg::IndependentWatchdog`); defmt over RTT; the DWT cycle counter as stopwatch. What
//! the HAL does not cover (the flash accelerator, the reset-cause flags, the polled safe
//! frame of the fault path) goes through `embassy_stm32::pac`'s typed registers.
//!
//! **On silicon**: nothing of this build has run on a board here. It compiles, links
//! and fits its flash and RAM budget (`cargo fw`); its pure arithmetic (the clock checks
//! of `board::nucleo_clock`, the bounded waits of `crate::bounded`) is tested on the
//! host; the board-independent tasks it shares with the QEMU build (`crate::app`) run
//! under QEMU. Its drivers, clock set-up, priorities and fault path have not run.
//!
//! Two builds: the default one free-running on the ticker at the 5 kHz base rate with
//! USART2 at 5.25 Mbaud on Arduino D1/D0 for a direct serial link ([`BAUD`]; checked
//! against the rate at compile time), and the frame-clocked one (feature `frame-clock`:
//! one tick per frame received, lock-step over the ST-LINK virtual COM port at 921600
//! baud).
//!
//! **Clocks** (`run`): HSI 16 MHz -> PLL (M 16, N 336, P 2, Q 7) -> SYSCLK 168 MHz,
//! AHB 168 MHz, APB1 42 MHz (its timers 84 MHz), APB2 84 MHz, 48 MHz on PLL Q.
//! embassy-stm32 sets voltage scale 1 (a PLL is used), switches the over-drive on
//! whatever the clock (`rcc/f247.rs`, on this part always; 168 MHz would not need it)
//! and sets 5 flash wait states; the board then switches the flash accelerator on (prefetch, instruction and
//! data caches: `flash_accelerator_on`). Every clock figure the firmware uses is read
//! from the configured tree at start-up (`embassy_stm32::rcc::clocks`), not assumed:
//! the USART2 baud (checked against [`BAUD`], which the link budget needs at compile
//! time), the time driver's tick (exact only on a whole multiple of 1 MHz) and the core
//! clock of the DWT counts (logged) and of the fault path's bounds.
//!
//! Executors and priorities (STM32: 4 priority bits, lower = more urgent):
//!
//! | context | priority | job |
//! |---|---|---|
//! | TIM2 (embassy-stm32's time driver) | P4 | wakes the ticker |
//! | UART4 (unused peripheral, software-pended) | P6 | control executor: the control task |
//! | USART2, DMA1 stream 5/6 (embassy-stm32's handlers) | P8 | UART driver |
//! | UART5 (unused peripheral, software-pended) | P10 | communication executor: RX task, TX task |
//! | thread mode | lowest | WFI, feeds the IWDG |
//!
//! A UART burst is handled by the DMA, the driver's interrupts and the communication
//! executor, all of which the control executor preempts: it cannot delay a tick. (Both
//! executors run in interrupt mode, so the thread executor is not linked.)
//!
//! **Fault path** ([`panic_halt`], and the HardFault handler of `crate::panic`): the safe
//! frame by polled writes to USART2 ([`send_safe_frame`]), every wait bounded
//! (`crate::bounded`), then a system reset. It ends in a reset whether or not the
//! watchdog has started.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::{DWT, SCB};
use defmt_rtt as _;
use embassy_executor::InterruptExecutor;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::mode::Async;
use embassy_stm32::usart::{self, RingBufferedUartRx, Uart, UartTx};
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::{bind_interrupts, dma, interrupt, pac, peripherals, Config};

use crate::app::{self, Stopwatch};
use crate::bounded;
use crate::exec::cyccnt_elapsed;

use super::nucleo_clock as clock;

/// Link baud rate of the free-running build: 5.25 Mbaud, USART2's highest (APB1 42 MHz,
/// oversampling by 8, USARTDIV 1: exact; checked against the clock tree at start-up).
/// The 5 kHz base rate needs 4.69 Mbaud (`cargo sim rates`), beyond the ST-LINK virtual
/// COM port: USART2 goes to Arduino D1/D0 (solder bridges SB13/SB14 open, SB62/SB63
/// closed) and a direct serial link. The build checks it against the base rate (the
/// const assertion below).
#[cfg(not(feature = "frame-clock"))]
pub const BAUD: u32 = 5_250_000;

/// Link baud rate of the frame-clocked build (feature `frame-clock`): the ST-LINK
/// virtual COM port at 921600 baud, in lock-step (the host's frames are the clock, so
/// the link need not carry a period's exchange in real time). USART2 makes 913 043 baud
/// of it from APB1 at 42 MHz (-0.93 %, within the VCP's tolerance).
#[cfg(feature = "frame-clock")]
pub const BAUD: u32 = 921_600;

/// How far the baud USART2 makes from the configured PCLK1 may be from [`BAUD`], parts
/// per thousand, checked at start-up: exact for the free-running build (the link budget
/// is computed at [`BAUD`]), 1 % for the frame-clocked one (a UART's receiver
/// tolerates a few percent; the lock-step link has no time budget).
#[cfg(not(feature = "frame-clock"))]
pub const BAUD_TOLERANCE_PERMILLE: u32 = 0;
/// See the free-running build's.
#[cfg(feature = "frame-clock")]
pub const BAUD_TOLERANCE_PERMILLE: u32 = 10;

/// One-way latency of the link the budget allows for (UART FIFO + DMA hand-off), ns.
pub const LINK_LATENCY_NS: u64 = 2_000;

/// The highest base rate USART2 at [`BAUD`] carries: one worst-case Sensor frame up and
/// one Actuation frame down per period within the project's link budget
/// (`wheelset_proto::link`). A host Config above it is refused.
#[cfg(not(feature = "frame-clock"))]
pub const LINK_MAX_RATE_HZ: u32 = wheelset_proto::link::max_rate_hz(
    BAUD,
    wheelset_proto::SENSOR_MAX_FRAME as u32,
    wheelset_proto::ACTUATION_MAX_FRAME as u32,
    LINK_LATENCY_NS,
    wheelset_proto::link::LINK_SHARE_MAX_PERMILLE,
);

/// The frame-clocked build has no link limit on the rate: its frames are the clock.
#[cfg(feature = "frame-clock")]
pub const LINK_MAX_RATE_HZ: u32 = u32::MAX;

// The build's base rate, baud and worst-case frames checked against each other: a
// free-running board whose link cannot carry its own exchange does not build.
#[cfg(not(feature = "frame-clock"))]
const _: () = assert!(
    wheelset_proto::link::link_fits(
        crate::settings::BASE_RATE_HZ,
        BAUD,
        wheelset_proto::SENSOR_MAX_FRAME as u32,
        wheelset_proto::ACTUATION_MAX_FRAME as u32,
        LINK_LATENCY_NS,
        wheelset_proto::link::LINK_SHARE_MAX_PERMILLE,
    )
    .is_ok(),
    "the Nucleo's USART2 baud cannot carry one exchange per period at its base rate"
);

/// The time driver's TIM2 interrupt: above both executors, so the control task's ticker
/// is woken on time whatever the communication executor does.
const TIME_PRIORITY: Priority = Priority::P4;
/// The control executor's.
const CONTROL_PRIORITY: Priority = Priority::P6;
/// USART2's and the DMA streams' interrupts (embassy-stm32 sets every DMA stream's from
/// `Config::dma_interrupt_priority`): below the control executor (a UART burst cannot
/// delay a tick), above the communication executor (the driver's state is up to date
/// whenever the RX and TX tasks run).
const UART_PRIORITY: Priority = Priority::P8;
/// The communication executor's.
const COMMS_PRIORITY: Priority = Priority::P10;

/// The receive DMA ring, bytes: 256 B is 488 us of line at 5.25 Mbaud, more than five
/// worst-case Sensor frames; the RX task empties it at each IDLE line or half ring.
const RX_RING: usize = 256;
/// The most bytes of one transmit transfer (the TX pipe is a byte stream: a longer
/// frame goes in several transfers, back to back).
const TX_LEN: usize = 64;
/// The transmit DMA stream: DMA1 stream 6, channel 4 (USART2_TX, RM0390 table 28), the
/// `DMA1_CH6` given to `Uart::new` in [`run`]; the fault path stops it.
const TX_STREAM: usize = 6;

/// The independent watchdog's timeout, us, at the LSI's nominal 32 kHz (the HAL derives
/// prescaler /4 and reload 1 999 from it). The LSI runs from 17 to 47 kHz over process
/// and temperature (datasheet DS10693, "LSI oscillator characteristics"): 170 to 470 ms.
/// The board feeds it once per control period when the host's frames come (200 us at
/// the 5 kHz base rate): 250 ms is 1 250 periods (850 at the fastest LSI), so neither a
/// late tick nor the frame-clocked build's USB latency (about 1 ms per frame over the
/// ST-LINK VCP) comes near it, while a stalled control task or a silent link puts the
/// outputs back to the reset state within half a second. Once started it runs until the
/// next reset (a debugger halting the core does not stop it: DBGMCU is left as it is);
/// its reset sets RCC CSR IWDGRSTF, which the boot record reports as `reset_cause`
/// WATCHDOG (`reset_flags`).
pub const IWDG_TIMEOUT_US: u32 = 250_000;

/// The core clock, Hz: the HSI's 16 MHz from reset (RM0390 6.2.2), SYSCLK from the
/// configured clock tree once `run` has set it. The fault path's bounds and its delay
/// before the reset are counted in its cycles.
static CORE_HZ: AtomicU32 = AtomicU32::new(16_000_000);
/// Polls of USART2's TXE flag within which a byte must go out on the fault path
/// ([`bounded::polls_per_char`] at the core clock and [`BAUD`]); 0 until USART2 is
/// configured, and then the fault path sends nothing (nobody can hear it).
static FAULT_POLLS: AtomicU32 = AtomicU32::new(0);

bind_interrupts!(struct Irqs {
    USART2 => usart::InterruptHandler<peripherals::USART2>;
    DMA1_STREAM5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
    DMA1_STREAM6 => dma::InterruptHandler<peripherals::DMA1_CH6>;
});

static EXEC_CONTROL: InterruptExecutor = InterruptExecutor::new();
static EXEC_COMMS: InterruptExecutor = InterruptExecutor::new();

/// The DWT cycle counter as a stopwatch: core cycles at SYSCLK (168 MHz, read from the
/// clock tree and logged at start-up; a host converts them to time with it). The
/// counter is 32 bits and wraps every 25.6 s at 168 MHz: a measurement is the wrapping
/// difference of two reads (`crate::exec::cyccnt_elapsed`), right for any tick shorter
/// than that.
pub struct DwtStopwatch;

impl Stopwatch for DwtStopwatch {
    fn start(&mut self) -> u32 {
        DWT::cycle_count()
    }

    fn stop(&mut self, start: u32) -> u32 {
        cyccnt_elapsed(start, DWT::cycle_count())
    }
}

#[embassy_executor::task]
async fn control_task() {
    #[cfg(not(feature = "frame-clock"))]
    app::control_loop(app::new_device, DwtStopwatch).await;
    #[cfg(feature = "frame-clock")]
    app::frame_loop(app::new_device, DwtStopwatch).await
}

/// The receive task: the bytes the DMA ring holds into the RX pipe, at each IDLE line
/// (a frame ended), half ring or error.
///
/// `rx_overrun` (the Status, through `app::RX_OVERRUN`) counts what the driver reports,
/// with no arithmetic that could jump: one for each receive error the HAL returns
/// (`usart::Error::Overrun`: the USART's overrun flag, or the DMA lapping the ring
/// before the task read it; `Framing`, `Noise`, `Parity`: a corrupted character),
/// since neither the USART nor the ring says how many bytes an error lost; plus each
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
                defmt::warn!("USART2 RX error: {}", e);
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
            defmt::warn!("USART2 TX error");
        }
    }
}

/// The hardware timer needs no period: the ticker schedules its own alarms.
pub fn set_period(_ticks: u64) {}

/// Sends the safe frame by polled writes to USART2 (the fault path: interrupts off),
/// every wait bounded (`crate::bounded`): the transmit DMA stream stopped (its EN reads
/// 0 once the current transfer ended, RM0390 9.3.17) and USART2's DMA requests off; a
/// lone delimiter (it ends a frame the DMA left half sent, so that the safe frame
/// arrives whole), the frame, each byte after TXE (RM0390 25.6.1) within
/// `FAULT_POLLS` polls; then TC (the last byte off the shift register, so a reset
/// next does not cut it) within twice that bound. A byte that does not go out
/// within its bound ends the frame. Nothing is sent before USART2 is configured.
pub fn send_safe_frame() {
    let polls = FAULT_POLLS.load(Ordering::Relaxed);
    if polls == 0 {
        return;
    }
    let usart = pac::USART2;
    let stream = pac::DMA1.st(TX_STREAM);
    stream.cr().modify(|w| w.set_en(false));
    let _ = bounded::poll_until(polls, || !stream.cr().read().en());
    usart.cr3().modify(|w| w.set_dmat(false));
    let mut buf = [0u8; wheelset_proto::MAX_FRAME];
    let frame = crate::device::safe_frame(&mut buf);
    let txe = || usart.sr().read().txe();
    let write = |b: u8| usart.dr().write(|w| w.set_dr(u16::from(b)));
    if bounded::write_polled(&[0], polls, txe, write) == 1 {
        let _ = bounded::write_polled(frame, polls, txe, write);
    }
    let _ = bounded::poll_until(polls.saturating_mul(2), || usart.sr().read().tc());
}

/// The end of every fault path but the HardFault handler's: interrupts off, the safe
/// frame ([`send_safe_frame`], bounded), the cause FAULT in the boot record, a tenth of
/// a second of core cycles for a debug probe to read the defmt log from RAM, then a
/// system reset (SCB AIRCR SYSRESETREQ). It never waits on a peripheral without a bound
/// and ends in the reset whether or not the watchdog has started: the board reboots into
/// its safe outputs and reports `reset_cause` FAULT.
pub fn panic_halt() -> ! {
    cortex_m::interrupt::disable();
    if !crate::panic::enter_halt() {
        send_safe_frame();
    }
    crate::boot::record_cause(wheelset_proto::reset_cause::FAULT);
    cortex_m::asm::delay(CORE_HZ.load(Ordering::Relaxed) / 10);
    SCB::sys_reset()
}

/// The reset cause from the RCC CSR flags (RM0390 6.3.21), in priority order (the
/// reset pin flag is set by every internal reset too, so it comes last), and whether it
/// was a power-on or brown-out reset; the flags are then cleared (RMVF) so the next
/// reset reports only its own.
fn reset_flags() -> (u8, bool) {
    use wheelset_proto::reset_cause as rc;
    let rcc = pac::RCC;
    let csr = rcc.csr().read();
    let power_on = csr.porrstf() || csr.borrstf();
    let cause = if power_on {
        rc::POWER_ON
    } else if csr.wdgrstf() || csr.wwdgrstf() {
        rc::WATCHDOG
    } else if csr.sftrstf() {
        rc::SOFTWARE
    } else if csr.padrstf() {
        rc::PIN
    } else {
        rc::UNKNOWN
    };
    rcc.csr().modify(|w| w.set_rmvf(true));
    (cause, power_on)
}

/// Switches the flash accelerator on (RM0390 3.4, "Read interface"; FLASH_ACR 3.8.1):
/// embassy-stm32's clock set-up writes FLASH_ACR with the wait states only, leaving the
/// prefetch buffer and both caches off. The caches are reset first (ICRST and DCRST may
/// be written only while the caches are disabled, which they are after that write),
/// then prefetch and both caches enabled; the barriers make the next fetches see it.
fn flash_accelerator_on() {
    let acr = pac::FLASH.acr();
    acr.modify(|w| {
        w.set_icen(false);
        w.set_dcen(false);
    });
    acr.modify(|w| {
        w.set_icrst(true);
        w.set_dcrst(true);
    });
    acr.modify(|w| {
        w.set_icrst(false);
        w.set_dcrst(false);
    });
    acr.modify(|w| {
        w.set_prften(true);
        w.set_icen(true);
        w.set_dcen(true);
    });
    cortex_m::asm::dsb();
    cortex_m::asm::isb();
}

/// Stops the board at start-up on a configuration it cannot run (the clock tree does not
/// give what the build assumes; a driver refused its configuration): a build error in
/// disguise, logged, then the fault path.
#[cold]
fn refuse(what: &str) -> ! {
    defmt::error!("start-up refused: {=str}", what);
    panic_halt()
}

/// Brings the board up and runs forever.
pub fn run() -> ! {
    // The boot record (crate::boot) with the hardware's reset cause: a cause a handler
    // recorded before its reset (FAULT) wins over the SOFTWARE flag of that reset.
    let (hw_cause, power_on) = reset_flags();
    // (The Status reports them: no log line.)
    let _ = crate::boot::start(Some(hw_cause), power_on);
    let mut config = Config::default();
    {
        use embassy_stm32::rcc::*;
        config.rcc.hsi = true;
        config.rcc.pll_src = PllSource::HSI;
        config.rcc.pll = Some(Pll {
            prediv: PllPreDiv::DIV16,
            mul: PllMul::MUL336,
            divp: Some(PllPDiv::DIV2),
            divq: Some(PllQDiv::DIV7),
            divr: None,
        });
        config.rcc.sys = Sysclk::PLL1_P;
        config.rcc.ahb_pre = AHBPrescaler::DIV1;
        config.rcc.apb1_pre = APBPrescaler::DIV4;
        config.rcc.apb2_pre = APBPrescaler::DIV2;
    }
    config.dma_interrupt_priority = UART_PRIORITY;
    // The clock tree, the DMA interrupts and the time driver (TIM2 started).
    let p = embassy_stm32::init(config);
    flash_accelerator_on();
    interrupt::TIM2.set_priority(TIME_PRIORITY);

    // The figures the firmware needs, from the clock tree just configured.
    let clocks = *embassy_stm32::rcc::clocks(&p.RCC);
    let hz = |h: embassy_stm32::time::MaybeHertz| h.to_hertz().map_or(0, |h| h.0);
    let (sys_hz, pclk1_hz, tim_hz) = (hz(clocks.sys), hz(clocks.pclk1), hz(clocks.pclk1_tim));
    CORE_HZ.store(sys_hz, Ordering::Relaxed);
    if !clock::baud_fits(pclk1_hz, BAUD, BAUD_TOLERANCE_PERMILLE) {
        refuse("USART2 cannot make the build's baud from PCLK1");
    }
    if !clock::timer_divides(tim_hz, embassy_time_driver::TICK_HZ as u32) {
        refuse("TIM2's clock is not a whole multiple of the time driver's tick");
    }

    // The cycle counter: enable tracing, then the counter.
    if let Some(mut core) = cortex_m::Peripherals::take() {
        core.DCB.enable_trace();
        core.DWT.enable_cycle_counter();
    }

    // USART2 (reset and configured by the HAL), 8N1 at the build's baud.
    let mut uart_config = usart::Config::default();
    uart_config.baudrate = BAUD;
    let Ok(uart) = Uart::new(
        p.USART2,
        p.PA3,
        p.PA2,
        p.DMA1_CH6,
        p.DMA1_CH5,
        Irqs,
        uart_config,
    ) else {
        refuse("USART2 configuration")
    };
    interrupt::USART2.set_priority(UART_PRIORITY);
    FAULT_POLLS.store(bounded::polls_per_char(sys_hz, BAUD), Ordering::Relaxed);
    let (tx, rx) = uart.split();
    let Some(ring) = cortex_m::singleton!(: [u8; RX_RING] = [0; RX_RING]) else {
        refuse("receive ring taken twice")
    };
    let mut rx = rx.into_ring_buffered(ring);
    rx.start_uart();

    defmt::info!(
        "wheelset-nucleo: {} Hz base rate, {} build, USART2 at {} baud, {}; SYSCLK {} Hz, PCLK1 {} Hz, TIM2 {} Hz",
        crate::settings::BASE_RATE_HZ,
        crate::settings::NUMERIC,
        BAUD,
        if cfg!(feature = "frame-clock") {
            "frame-clocked lock-step"
        } else {
            "free-running ticker"
        },
        sys_hz,
        pclk1_hz,
        tim_hz
    );

    interrupt::UART4.set_priority(CONTROL_PRIORITY);
    let control = EXEC_CONTROL.start(interrupt::UART4);
    control.spawn(app::token(control_task()));

    interrupt::UART5.set_priority(COMMS_PRIORITY);
    let comms = EXEC_COMMS.start(interrupt::UART5);
    comms.spawn(app::token(rx_task(rx)));
    comms.spawn(app::token(tx_task(tx)));

    // Every task runs in an interrupt executor: thread mode only sleeps, and feeds the
    // independent watchdog when the tick and the receive path have both run
    // (crate::watchdog). It is configured now and started at the first such feed (the
    // host's first bytes and a tick after them), so a board waiting for its host is not
    // reset.
    let mut iwdg = IndependentWatchdog::new(p.IWDG, IWDG_TIMEOUT_US);
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
#[interrupt]
unsafe fn UART5() {
    // SAFETY: this is UART5's handler, the interrupt EXEC_COMMS was started on.
    unsafe { EXEC_COMMS.on_interrupt() }
}

#[allow(non_snake_case)]
#[interrupt]
unsafe fn UART4() {
    // SAFETY: this is UART4's handler, the interrupt EXEC_CONTROL was started on.
    unsafe { EXEC_CONTROL.on_interrupt() }
}
