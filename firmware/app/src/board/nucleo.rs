//! Nucleo-F446RE board layer (STM32F446RE, Cortex-M4F): embassy-stm32 for the clock
//! tree and the interrupt table, the board's own TIM2 time driver (`board::nucleo_tim2`)
//! and USART2 (PA2 TX / PA3 RX) with DMA (`board::nucleo_usart`), defmt over RTT, the
//! DWT cycle counter as stopwatch.
//!
//! Two builds: the default one free-running on the ticker at the 5 kHz base rate with
//! USART2 at 5.25 Mbaud on a direct link ([`BAUD`]; checked against the rate at compile
//! time), and the frame-clocked one (feature `frame-clock`: one tick per frame received,
//! lock-step over the ST-LINK virtual COM port at 921600 baud).
//!
//! Clocks: HSI 16 MHz -> PLL (M 16, N 336, P 2) -> SYSCLK 168 MHz, APB1 42 MHz,
//! APB2 84 MHz (no over-drive needed below 180 MHz).
//!
//! Executors and priorities (STM32: 4 priority bits, lower = more urgent):
//!
//! | context | priority | job |
//! |---|---|---|
//! | TIM2 (time driver, `board::nucleo_tim2`) | P4 | wakes the ticker |
//! | UART4 (unused peripheral, software-pended) | P6 | control executor: the control task |
//! | USART2, DMA1 stream 5/6 (`board::nucleo_usart`) | P8 | UART driver |
//! | UART5 (unused peripheral, software-pended) | P10 | communication executor: RX task, TX task |
//! | thread mode | lowest | WFI only |
//!
//! A UART burst is handled by the DMA and the communication executor, which the control
//! executor preempts: it cannot delay a tick. (Both executors run in interrupt mode, so
//! the thread executor is not linked: 0.4 KiB less flash.)

use core::sync::atomic::Ordering;

use cortex_m::peripheral::DWT;
use defmt_rtt as _;
use embassy_executor::InterruptExecutor;
use embassy_stm32::interrupt::{InterruptExt, Priority};
use embassy_stm32::{interrupt, pac, Config};

use crate::app::{self, Stopwatch};
use crate::exec::cyccnt_elapsed;

use super::nucleo_usart::{self as usart, RxLost};

/// Link baud rate of the free-running build: 5.25 Mbaud, USART2's highest (APB1 42 MHz,
/// oversampling by 8, USARTDIV 1: exact). The 5 kHz base rate needs 4.69 Mbaud
/// (`cargo sim rates`), beyond the ST-LINK virtual COM port: USART2 goes to Arduino
/// D1/D0 (solder bridges SB13/SB14 open, SB62/SB63 closed) and a direct serial link.
/// The build checks it against the base rate (the const assertion below).
#[cfg(not(feature = "frame-clock"))]
pub const BAUD: u32 = 5_250_000;

/// Link baud rate of the frame-clocked build (feature `frame-clock`): the ST-LINK
/// virtual COM port at 921600 baud, in lock-step (the host's frames are the clock, so
/// the link need not carry a period's exchange in real time).
#[cfg(feature = "frame-clock")]
pub const BAUD: u32 = 921_600;

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
        crate::config::BASE_RATE_HZ,
        BAUD,
        wheelset_proto::SENSOR_MAX_FRAME as u32,
        wheelset_proto::ACTUATION_MAX_FRAME as u32,
        LINK_LATENCY_NS,
        wheelset_proto::link::LINK_SHARE_MAX_PERMILLE,
    )
    .is_ok(),
    "the Nucleo's USART2 baud cannot carry one exchange per period at its base rate"
);

static EXEC_CONTROL: InterruptExecutor = InterruptExecutor::new();
static EXEC_COMMS: InterruptExecutor = InterruptExecutor::new();

/// The DWT cycle counter as a stopwatch (core cycles at 168 MHz).
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

#[embassy_executor::task]
async fn rx_task(mut rx: usart::Rx) {
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
                    // Lost: counted for the Status (`rx_overrun`).
                    app::RX_OVERRUN.fetch_add(rest.len() as u32, Ordering::Relaxed);
                    defmt::warn!("RX pipe full: {=usize} bytes dropped", rest.len());
                }
            }
            // Overrun, framing or noise error: the bytes in flight are lost (counted as
            // one per error in `rx_overrun`: the USART does not say how many); the frame
            // decoder resynchronises on the next delimiter. Reception goes on.
            Err(RxLost::Errors(n)) => {
                app::RX_OVERRUN.fetch_add(n, Ordering::Relaxed);
                defmt::warn!("USART2 RX error")
            }
            // The DMA lapped the ring: every byte not read is lost, counted.
            Err(RxLost::Lapped(n)) => {
                app::RX_OVERRUN.fetch_add(n, Ordering::Relaxed);
                defmt::warn!("RX ring lapped: {=u32} bytes dropped", n)
            }
        }
    }
}

#[embassy_executor::task]
async fn tx_task(mut tx: usart::Tx) {
    loop {
        let n = app::TX.read(tx.buf()).await;
        if tx.send(n).await.is_err() {
            defmt::warn!("USART2 TX error");
        }
    }
}

/// The hardware timer needs no period: the ticker schedules its own alarms.
pub fn set_period(_ticks: u64) {}

/// Sends the safe frame by polling USART2 (the transmit DMA stopped).
pub fn send_safe_frame() {
    usart::stop_tx_dma();
    let usart = pac::USART2;
    let mut buf = [0u8; wheelset_proto::MAX_FRAME];
    // A lone delimiter first: the handler may have cut a frame half sent (the DMA
    // stopped above); it ends that one, so that the safe frame arrives whole.
    for &b in core::iter::once(&0).chain(crate::device::safe_frame(&mut buf).iter()) {
        while !usart.sr().read().txe() {}
        usart.dr().write(|w| w.set_dr(u16::from(b)));
    }
}

/// Sends the safe frame, then sleeps forever; probe-rs shows the defmt panic message.
pub fn panic_halt() -> ! {
    if !crate::panic::enter_halt() {
        send_safe_frame();
    }
    loop {
        cortex_m::asm::wfi();
    }
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

/// Brings the board up and runs forever.
pub fn run() -> ! {
    // The boot record (crate::boot) with the hardware's reset cause: a cause a handler
    // recorded before its reset (FAULT) wins over the SOFTWARE flag of that reset.
    let (hw_cause, power_on) = reset_flags();
    // (The Status reports them: no log line, for flash.)
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
    let _ = embassy_stm32::init(config);
    // The time driver's TIM2, on the clocks just set (84 MHz timer clock).
    super::nucleo_tim2::start();

    // The cycle counter: enable tracing, then the counter.
    if let Some(mut core) = cortex_m::Peripherals::take() {
        core.DCB.enable_trace();
        core.DWT.enable_cycle_counter();
    }

    let Some((tx, rx)) = usart::start() else {
        defmt::error!("USART2 configuration refused");
        panic_halt()
    };

    defmt::info!(
        "wheelset-nucleo: {} Hz base rate, {} build, USART2 at {} baud, {}",
        crate::config::BASE_RATE_HZ,
        crate::config::NUMERIC,
        BAUD,
        if cfg!(feature = "frame-clock") {
            "frame-clocked lock-step"
        } else {
            "free-running ticker"
        }
    );

    interrupt::UART4.set_priority(Priority::P6);
    let control = EXEC_CONTROL.start(interrupt::UART4);
    control.spawn(app::token(control_task()));

    interrupt::UART5.set_priority(Priority::P10);
    let comms = EXEC_COMMS.start(interrupt::UART5);
    comms.spawn(app::token(rx_task(rx)));
    comms.spawn(app::token(tx_task(tx)));

    // Every task runs in an interrupt executor: thread mode only sleeps, and feeds the
    // independent watchdog when the tick and the receive path have both run
    // (crate::watchdog). It starts at the first such feed (the host's first bytes and a
    // tick after them), so a board waiting for its host is not reset.
    let mut started = false;
    loop {
        if crate::watchdog::take_both() {
            if !started {
                iwdg::start();
                started = true;
            }
            iwdg::feed();
        }
        cortex_m::asm::wfi();
    }
}

/// The STM32's independent watchdog (RM0390 section 19), on the LSI oscillator (32 kHz
/// typical, 17 to 47 kHz over process and temperature: datasheet DS10693, table
/// "LSI oscillator characteristics"), independent of the system clock. Once started it
/// runs until the next reset; its reset sets RCC CSR IWDGRSTF, which the boot record
/// reports as `reset_cause` WATCHDOG ([`reset_flags`]).
///
/// **Timeout**: prescaler /32 (PR = 3, one count per ~1 ms) and reload [`RELOAD`] = 250:
/// 250 ms at 32 kHz, between 170 ms (47 kHz) and 470 ms (17 kHz). The board feeds it
/// once per control period when the host's frames come (200 us at the 5 kHz base
/// rate): 250 ms is 1 250 periods (850 at the fastest LSI), so neither a late tick nor
/// the frame-clocked build's USB latency (about 1 ms per frame over the ST-LINK VCP)
/// comes near it, while a stalled control task or a silent link puts the outputs back
/// to the reset state within half a second. (A debugger halting the core does not stop
/// it: DBGMCU is left as it is.)
mod iwdg {
    use core::ptr::{read_volatile, write_volatile};

    const KR: usize = 0x4000_3000;
    const PR: usize = KR + 0x04;
    const RLR: usize = KR + 0x08;
    const SR: usize = KR + 0x0C;

    /// Counts of the /32 prescaled LSI (~1 ms each) to the reset.
    pub const RELOAD: u32 = 250;

    fn write(addr: usize, value: u32) {
        // SAFETY: `addr` is one of the IWDG's registers above (STM32F446 memory map,
        // RM0390 table 1): a valid, aligned MMIO word; only this module touches it.
        unsafe { write_volatile(addr as *mut u32, value) }
    }

    /// Starts the count (from 0xFFF at /4, 512 ms), unlocks PR and RLR, sets the
    /// prescaler and the reload and waits until both reached the LSI domain (SR's PVU
    /// and RVU clear: a few LSI periods; a dead LSI leaves the default count to reset
    /// the board), as ST's HAL does. The caller feeds it next.
    pub fn start() {
        write(KR, 0xCCCC);
        write(KR, 0x5555);
        write(PR, 3);
        write(RLR, RELOAD);
        // SAFETY: as in `write`; reading SR has no side effect.
        while unsafe { read_volatile(SR as *const u32) } & 0b11 != 0 {}
    }

    /// Reloads the count with [`RELOAD`].
    pub fn feed() {
        write(KR, 0xAAAA);
    }
}

#[allow(non_snake_case)]
#[interrupt]
unsafe fn USART2() {
    usart::on_usart2()
}

#[allow(non_snake_case)]
#[interrupt]
unsafe fn DMA1_STREAM5() {
    usart::on_rx_dma()
}

#[allow(non_snake_case)]
#[interrupt]
unsafe fn DMA1_STREAM6() {
    usart::on_tx_dma()
}

#[allow(non_snake_case)]
#[interrupt]
unsafe fn TIM2() {
    super::nucleo_tim2::on_interrupt()
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
