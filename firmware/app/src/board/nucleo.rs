//! Nucleo-F446RE board layer (STM32F446RE, Cortex-M4F) on embassy-stm32 0.6: its clock
//! tree set-up, its TIM2 time driver (feature `time-driver-tim2`), its USART2 driver
//! (PA2 TX / PA3 RX) with reception into a DMA ring (`RingBufferedUartRx`, DMA1 stream 5)
//! and transmission by DMA (`UartTx`, DMA1 stream 6), its independent watchdog
//! (`wdg::IndependentWatchdog`, LSI 17 to 47 kHz over process and temperature, datasheet
//! DS10693, "LSI oscillator characteristics": `stm32::IWDG_TIMEOUT_US` is 170 to 470 ms);
//! defmt over RTT; the DWT cycle counter as stopwatch. What
//! the HAL does not cover (the flash accelerator, the reset-cause flags, the polled safe
//! frame of the fault path) goes through `embassy_stm32::pac`'s typed registers.
//!
//! **On silicon**: nothing of this build has run on a board here. It compiles, links
//! and fits its flash and RAM budget (`cargo fw`); its pure arithmetic (the clock checks
//! of `board::stm32::clock`, the bounded waits of `crate::bounded`) is tested on the
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
//! clock of the DWT counts (logged) and of the fault path's bounds (`stm32::clock`).
//!
//! Executors, priorities, the tasks and the watchdog: `board::stm32`, what the STM32
//! boards share.
//!
//! **Fault path** (`stm32::halt`, and the HardFault handler of `crate::panic`): the safe
//! frame by polled writes to USART2 (`Board::send_safe_frame`), every wait bounded
//! (`crate::bounded`), then a system reset. It ends in a reset whether or not the
//! watchdog has started.

use embassy_stm32::interrupt;
use embassy_stm32::usart::{self, Uart};
use embassy_stm32::{bind_interrupts, dma, pac, peripherals, Config};

use super::stm32::{self, clock};
use crate::bounded;

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

/// The highest base rate USART2 at [`BAUD`] carries (`stm32::link_max_rate_hz`); a host
/// Config above it is refused.
#[cfg(not(feature = "frame-clock"))]
pub const LINK_MAX_RATE_HZ: u32 = stm32::link_max_rate_hz(BAUD);

/// The frame-clocked build has no link limit on the rate: its frames are the clock.
#[cfg(feature = "frame-clock")]
pub const LINK_MAX_RATE_HZ: u32 = u32::MAX;

// A free-running board whose link cannot carry its own exchange does not build.
#[cfg(not(feature = "frame-clock"))]
const _: () = assert!(
    stm32::carries_base_rate(BAUD),
    "the Nucleo's USART2 baud cannot carry one exchange per period at its base rate"
);

/// The transmit DMA stream: DMA1 stream 6, channel 4 (USART2_TX, RM0390 table 28), the
/// `DMA1_CH6` given to `Uart::new` in `Board::run`; the fault path stops it.
const TX_STREAM: usize = 6;

bind_interrupts!(struct Irqs {
    USART2 => usart::InterruptHandler<peripherals::USART2>;
    DMA1_STREAM5 => dma::InterruptHandler<peripherals::DMA1_CH5>;
    DMA1_STREAM6 => dma::InterruptHandler<peripherals::DMA1_CH6>;
});

/// The Nucleo-F446RE.
pub struct Board;

impl super::Board for Board {
    const LINK_MAX_RATE_HZ: u32 = LINK_MAX_RATE_HZ;
    type Stopwatch = stm32::DwtStopwatch;

    /// Brings the board up and runs forever.
    fn run() -> ! {
        // The boot record (crate::boot) with the hardware's reset cause: a cause a handler
        // recorded before its reset (FAULT) wins over the SOFTWARE flag of that reset.
        // (The Status reports them: no log line.)
        let _ = crate::boot::start_on::<Self>();
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
        config.dma_interrupt_priority = stm32::UART_PRIORITY;
        // The clock tree, the DMA interrupts and the time driver (TIM2 started).
        let p = embassy_stm32::init(config);
        flash_accelerator_on();
        // The figures the firmware needs, from the clock tree just configured.
        let (sys_hz, pclk1_hz, tim_hz) = stm32::clocks(&p.RCC);
        let made = clock::made_baud(pclk1_hz, BAUD);
        if let Err(e) = stm32::check_clocks(made, BAUD, BAUD_TOLERANCE_PERMILLE, tim_hz) {
            stm32::refuse(e);
        }
        // USART2, reset and configured by the HAL.
        let cfg = stm32::uart_config(BAUD);
        let uart = Uart::new(p.USART2, p.PA3, p.PA2, p.DMA1_CH6, p.DMA1_CH5, Irqs, cfg);
        let (tx, rx) = stm32::link(uart, interrupt::USART2, BAUD);

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

        stm32::serve(rx, tx, p.IWDG)
    }

    /// The reset cause from the RCC CSR flags (RM0390 6.3.21; `stm32::reset_cause`); the
    /// flags are then cleared (RMVF) so the next reset reports only its own.
    fn reset_cause() -> (Option<u8>, bool) {
        let csr = pac::RCC.csr().read();
        pac::RCC.csr().modify(|w| w.set_rmvf(true));
        stm32::reset_cause(
            csr.porrstf() || csr.borrstf(),
            csr.wdgrstf() || csr.wwdgrstf(),
            csr.sftrstf(),
            csr.padrstf(),
        )
    }

    /// Sends the safe frame by polled writes to USART2 (the fault path: interrupts off),
    /// every wait bounded (`crate::bounded`): the transmit DMA stream stopped (its EN reads
    /// 0 once the current transfer ended, RM0390 9.3.17) and USART2's DMA requests off,
    /// then `stm32::send_polled` on TXE and TC (RM0390 25.6.1). Nothing is sent before
    /// USART2 is configured.
    fn send_safe_frame() {
        let usart = pac::USART2;
        stm32::send_polled(
            |polls| {
                let stream = pac::DMA1.st(TX_STREAM);
                stream.cr().modify(|w| w.set_en(false));
                let _ = bounded::poll_until(polls, || !stream.cr().read().en());
                usart.cr3().modify(|w| w.set_dmat(false));
            },
            || usart.sr().read().txe(),
            |b| usart.dr().write(|w| w.set_dr(u16::from(b))),
            || usart.sr().read().tc(),
        );
    }

    fn halt() -> ! {
        stm32::halt()
    }
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
