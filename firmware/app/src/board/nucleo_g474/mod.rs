//! Nucleo-G474RE board layer (STM32G474RET6, Cortex-M4F) on embassy-stm32 0.6: its clock
//! tree set-up, its 32-bit TIM2 time driver (feature `time-driver-tim2`), LPUART1 on
//! PA2 TX / PA3 RX (the ST-LINK V3 virtual COM port) with reception into a DMA ring
//! (`RingBufferedUartRx`, DMA1 channel 1) and transmission by DMA (`UartTx`, DMA1
//! channel 2; DMAMUX routes the requests), its independent watchdog
//! (`stm32::IWDG_TIMEOUT_US`); defmt over RTT; the DWT cycle counter as stopwatch. The
//! executors, the tasks and the watchdog's feeding are `board::stm32`'s, as the F446's.
//!
//! **On silicon**: nothing of this build has run on a board here. It compiles, links
//! and fits its flash and RAM budget (`cargo fw`); its clock arithmetic
//! (`board::stm32::clock`) is tested on the host.
//!
//! **Clocks** (`run`): HSI 16 MHz -> PLL (M 4, N 85, R 2) -> SYSCLK 170 MHz in range-1
//! boost mode (embassy-stm32 sets it and the flash wait states), AHB, APB1 and APB2 at
//! 170 MHz (TIM2 at 170 MHz). The board switches the flash prefetch on (the caches are
//! set on too). Every clock figure the firmware uses is read from the configured tree:
//! LPUART1's kernel clock (its baud checked against [`BAUD`]), TIM2's clock (a whole
//! multiple of the 1 MHz tick) and the core clock of the DWT counts and of the fault
//! path's bounds.
//!
//! **Fault path** (`stm32::halt`, and the HardFault handler of `crate::panic`): the safe
//! frame by polled writes to LPUART1 (`Board::send_safe_frame`), every wait bounded, then a
//! system reset.

use embassy_stm32::interrupt;
use embassy_stm32::usart::{self, Uart};
use embassy_stm32::{bind_interrupts, dma, pac, peripherals, Config};

use super::stm32::{self, clock};

/// Link baud rate: 5.3125 Mbaud, 170 MHz / 32 (LPUARTDIV 8 192: exact). The 5 kHz base
/// rate needs 4.69 Mbaud (`cargo sim rates`); the build checks it against the base rate
/// (the const assertion below) and the clock tree at start-up. Whether the ST-LINK V3's
/// virtual COM port carries it has not been tried here.
pub const BAUD: u32 = 5_312_500;

/// The highest base rate LPUART1 at [`BAUD`] carries (`stm32::link_max_rate_hz`); a host
/// Config above it is refused.
pub const LINK_MAX_RATE_HZ: u32 = stm32::link_max_rate_hz(BAUD);

// A board whose link cannot carry its own exchange does not build.
const _: () = assert!(
    stm32::carries_base_rate(BAUD),
    "the G474's LPUART1 baud cannot carry one exchange per period at its base rate"
);

/// The transmit DMA channel: DMA1 channel 2, the `DMA1_CH2` given to `Uart::new` in
/// `Board::run` (registers count channels from 0); the fault path stops it.
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

    /// Brings the board up and runs forever.
    fn run() -> ! {
        // (The Status reports them: no log line.)
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
        // The clock tree, the DMA interrupts and the time driver (TIM2 started).
        let p = embassy_stm32::init(config);
        pac::FLASH.acr().modify(|w| {
            w.set_prften(true);
            w.set_icen(true);
            w.set_dcen(true);
        });
        // The figures the firmware needs, from the clock tree just configured.
        let (sys_hz, _, tim_hz) = stm32::clocks(&p.RCC);
        let uart_hz = embassy_stm32::rcc::frequency::<peripherals::LPUART1>().0;
        let made = clock::lpuart_made_baud(uart_hz, BAUD);
        if let Err(e) = stm32::check_clocks(made, BAUD, 0, tim_hz) {
            stm32::refuse(e);
        }
        // LPUART1, reset and configured by the HAL.
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

    /// The reset cause from the RCC CSR flags (`stm32::reset_cause`; the brown-out flag is
    /// the power-on one); the flags are then cleared (RMVF) so the next reset reports only
    /// its own.
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

    /// Sends the safe frame by polled writes to LPUART1 (the fault path: interrupts off),
    /// every wait bounded: the transmit DMA channel stopped and LPUART1's DMA requests off,
    /// then `stm32::send_polled` on TXE and TC. Nothing is sent before LPUART1 is
    /// configured.
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
