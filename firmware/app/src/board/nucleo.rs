//! Nucleo-F446RE board layer (STM32F446RE, Cortex-M4F) on embassy-stm32: USART2 (PA2/PA3)
//! with DMA (DMA1 streams 5 and 6), TIM2 time driver, IWDG, defmt over RTT. Free-running
//! at 5.25 Mbaud on Arduino D1/D0, or frame-clocked over the ST-LINK VCP. Clocks: HSI
//! 16 MHz -> PLL (M 16, N 336, P 2, Q 7) -> SYSCLK 168 MHz, APB1 42 MHz, APB2 84 MHz.
//! Not run on silicon here.

use embassy_stm32::interrupt;
use embassy_stm32::usart::{self, Uart};
use embassy_stm32::{bind_interrupts, dma, pac, peripherals, Config};

use super::stm32::{self, clock};
use crate::bounded;

/// Link baud of the free-running build: 5.25 Mbaud (APB1 42 MHz, OVER8, USARTDIV 1:
/// exact), on Arduino D1/D0 (SB13/SB14 open, SB62/SB63 closed).
#[cfg(not(feature = "frame-clock"))]
pub const BAUD: u32 = 5_250_000;

/// Link baud of the frame-clocked build: the ST-LINK VCP's 921600 (USART2 makes -0.93 %).
#[cfg(feature = "frame-clock")]
pub const BAUD: u32 = 921_600;

/// Tolerance of USART2's baud, per mille: exact free-running, 1 % frame-clocked.
#[cfg(not(feature = "frame-clock"))]
pub const BAUD_TOLERANCE_PERMILLE: u32 = 0;
/// See the free-running build's.
#[cfg(feature = "frame-clock")]
pub const BAUD_TOLERANCE_PERMILLE: u32 = 10;

/// The highest base rate USART2 at [`BAUD`] carries.
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

/// The transmit DMA stream: DMA1 stream 6, channel 4 (RM0390 table 28).
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

    fn run() -> ! {
        // A cause a handler recorded (FAULT) wins over that reset's SOFTWARE flag.
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
        let p = embassy_stm32::init(config);
        flash_accelerator_on();
        let (sys_hz, pclk1_hz, tim_hz) = stm32::clocks(&p.RCC);
        let made = clock::made_baud(pclk1_hz, BAUD);
        if let Err(e) = stm32::check_clocks(made, BAUD, BAUD_TOLERANCE_PERMILLE, tim_hz) {
            stm32::refuse(e);
        }
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

    /// The reset cause from the RCC CSR flags (RM0390 6.3.21), then cleared (RMVF).
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

    /// The safe frame by polled writes to USART2, every wait bounded: transmit DMA stopped
    /// (RM0390 9.3.17), then `stm32::send_polled`.
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

/// Switches the flash accelerator on (RM0390 3.4), which embassy-stm32 leaves off: caches
/// reset first (only while disabled), then prefetch and caches on.
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
