//! Nucleo-G474RE board layer (STM32G474RET6) on embassy-stm32: LPUART1 on PA2/PA3 (the
//! ST-LINK V3 VCP) with DMA, TIM2, IWDG, defmt over RTT. Clocks: HSI 16 MHz -> PLL (M 4,
//! N 85, R 2) -> SYSCLK 170 MHz (range-1 boost). Not run on silicon here.

use embassy_stm32::interrupt;
use embassy_stm32::usart::{self, Uart};
use embassy_stm32::{bind_interrupts, dma, pac, peripherals, Config};

use super::stm32::{self, clock};

/// Link baud: 5.3125 Mbaud, 170 MHz / 32 (LPUARTDIV 8 192: exact).
pub const BAUD: u32 = 5_312_500;

/// The highest base rate LPUART1 at [`BAUD`] carries.
pub const LINK_MAX_RATE_HZ: u32 = stm32::link_max_rate_hz(BAUD);

// A board whose link cannot carry its own exchange does not build.
const _: () = assert!(
    stm32::carries_base_rate(BAUD),
    "the G474's LPUART1 baud cannot carry one exchange per period at its base rate"
);

/// The transmit DMA channel: DMA1 channel 2 (registers count from 0); the fault path stops it.
const TX_CHANNEL: usize = 1;

bind_interrupts!(struct Irqs {
    LPUART1 => usart::InterruptHandler<peripherals::LPUART1>;
    DMA1_CHANNEL1 => dma::InterruptHandler<peripherals::DMA1_CH1>;
    DMA1_CHANNEL2 => dma::InterruptHandler<peripherals::DMA1_CH2>;
});

/// The Nucleo-G474RE.
pub struct Board;

impl super::Board for Board {
    const LINK_MAX_RATE_HZ: u32 = LINK_MAX_RATE_HZ;
    type Stopwatch = stm32::DwtStopwatch;

    fn run() -> ! {
        let _ = crate::boot::start_on::<Self>();
        let mut config = Config::default();
        {
            use embassy_stm32::rcc::*;
            config.rcc.hsi = true;
            config.rcc.pll = Some(Pll {
                source: PllSource::HSI,
                prediv: PllPreDiv::DIV4,
                mul: PllMul::MUL85,
                divp: None,
                divq: None,
                divr: Some(PllRDiv::DIV2),
            });
            config.rcc.sys = Sysclk::PLL1_R;
            config.rcc.boost = true;
        }
        // The G4's DMA controllers are the "BDMA" kind to embassy-stm32.
        config.bdma_interrupt_priority = stm32::UART_PRIORITY;
        let p = embassy_stm32::init(config);
        pac::FLASH.acr().modify(|w| {
            w.set_prften(true);
            w.set_icen(true);
            w.set_dcen(true);
        });
        let (sys_hz, _, tim_hz) = stm32::clocks(&p.RCC);
        let uart_hz = embassy_stm32::rcc::frequency::<peripherals::LPUART1>().0;
        let made = clock::lpuart_made_baud(uart_hz, BAUD);
        if let Err(e) = stm32::check_clocks(made, BAUD, 0, tim_hz) {
            stm32::refuse(e);
        }
        let cfg = stm32::uart_config(BAUD);
        let uart = Uart::new(p.LPUART1, p.PA3, p.PA2, p.DMA1_CH2, p.DMA1_CH1, Irqs, cfg);
        let (tx, rx) = stm32::link(uart, interrupt::LPUART1, BAUD);

        defmt::info!(
            "wheelset-nucleo-g474: {} Hz base rate, {} build, LPUART1 at {} baud; SYSCLK {} Hz, LPUART1 clock {} Hz, TIM2 {} Hz",
            crate::settings::BASE_RATE_HZ,
            crate::settings::NUMERIC,
            BAUD,
            sys_hz,
            uart_hz,
            tim_hz
        );

        stm32::serve(rx, tx, p.IWDG)
    }

    /// The reset cause from the RCC CSR flags (brown-out is power-on), then cleared (RMVF).
    fn reset_cause() -> (Option<u8>, bool) {
        let csr = pac::RCC.csr().read();
        pac::RCC.csr().modify(|w| w.set_rmvf(true));
        stm32::reset_cause(
            csr.borrstf(),
            csr.iwdgrstf() || csr.wwdgrstf(),
            csr.sftrstf(),
            csr.pinrstf(),
        )
    }

    /// The safe frame by polled writes to LPUART1, every wait bounded (transmit DMA stopped).
    fn send_safe_frame() {
        let uart = pac::LPUART1;
        stm32::send_polled(
            |_| {
                pac::DMA1.ch(TX_CHANNEL).cr().modify(|w| w.set_en(false));
                uart.cr3().modify(|w| w.set_dmat(false));
            },
            || uart.isr().read().txe(),
            |b| uart.tdr().write(|w| w.set_dr(u16::from(b))),
            || uart.isr().read().tc(),
        );
    }

    fn halt() -> ! {
        stm32::halt()
    }
}
