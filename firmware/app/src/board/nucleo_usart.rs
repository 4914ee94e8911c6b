//! The Nucleo's USART2 (PA2 TX, PA3 RX, AF7) with DMA, register access of the board's
//! own instead of embassy-stm32's `Uart` / `RingBufferedUartRx` / `UartTx` (their DMA
//! and ring-buffer code, and the bounds check of the ring buffer that linked
//! `core::fmt`'s integer formatting). The arithmetic (BRR, the receive ring's totals) is
//! in `board::nucleo_link`, tested on the host.
//!
//! - **Receive**: DMA1 stream 5 channel 4 (USART2_RX, RM0390 9.3.3 table 28) in circular
//!   mode over [`RX_RING`] (256 B). Its half-transfer and transfer-complete interrupts
//!   count the halves filled; USART2's IDLE interrupt (the line idle for one character
//!   after a frame) and its error interrupt (overrun, framing, noise: CR3 EIE) wake the
//!   receive task, which takes what the DMA wrote since it last looked ([`Rx::read`]).
//! - **Transmit**: DMA1 stream 6 channel 4 (USART2_TX) in normal mode from [`TX_BUF`],
//!   one transfer per frame; its transfer-complete interrupt wakes the transmit task.
//!
//! Interrupts USART2, DMA1_STREAM5 and DMA1_STREAM6 at [`PRIORITY`]: below the control
//! executor (P6: a UART burst cannot delay a tick) and above the communication executor
//! (P10: the half counts are up to date, or one behind, whenever the receive task runs).
//! A DMA transfer error (a bus error: not reachable with these fixed addresses) stops
//! the stream; the receive path then stops feeding the watchdog and the IWDG resets the
//! board (`board::nucleo::iwdg`).

use core::future::poll_fn;
use core::ptr::{addr_of, addr_of_mut, read_volatile, write_volatile};
use core::sync::atomic::{compiler_fence, AtomicBool, AtomicU32, Ordering};
use core::task::Poll;

use embassy_stm32::interrupt::{self, InterruptExt, Priority};
use embassy_stm32::pac;
use embassy_sync::waitqueue::AtomicWaker;

use super::nucleo_link::{self as link, RING};

/// The interrupts' priority (see the module docs).
pub const PRIORITY: Priority = Priority::P8;

/// APB1's clock, USART2's kernel clock, Hz (SYSCLK 168 MHz / 4: `board::nucleo::run`).
pub const PCLK1_HZ: u32 = 42_000_000;

/// BRR and OVER8 for the build's baud; a baud USART2 cannot make does not build.
const BRR: (u16, bool) = match link::brr(PCLK1_HZ, super::nucleo::BAUD) {
    Some(b) => b,
    None => panic!("USART2 cannot make the build's baud from APB1"),
};

/// The most bytes of one transmit transfer (the TX pipe is a byte stream: a longer
/// frame goes in several transfers, back to back).
pub const TX_LEN: usize = 64;

// USART2 (RM0390 2.2.2 memory map: 0x4000_4400; registers 25.6).
const USART2: usize = 0x4000_4400;
const USART_SR: usize = USART2;
const USART_DR: usize = USART2 + 0x04;
const USART_BRR: usize = USART2 + 0x08;
const USART_CR1: usize = USART2 + 0x0C;
const USART_CR3: usize = USART2 + 0x14;
/// SR's error flags: parity, framing, noise, overrun (bits 0-3), and IDLE (bit 4).
const SR_ERRORS: u32 = 0b1111;
const SR_ORE_NF_FE: u32 = 0b1110;
const SR_IDLE: u32 = 1 << 4;
const CR1_RE: u32 = 1 << 2;
const CR1_TE: u32 = 1 << 3;
const CR1_IDLEIE: u32 = 1 << 4;
const CR1_UE: u32 = 1 << 13;
const CR1_OVER8: u32 = 1 << 15;
const CR3_EIE: u32 = 1 << 0;
const CR3_DMAR: u32 = 1 << 6;
const CR3_DMAT: u32 = 1 << 7;

// DMA1 (0x4002_6000; registers RM0390 9.5).
const DMA1: usize = 0x4002_6000;
const DMA_HISR: usize = DMA1 + 0x04;
const DMA_HIFCR: usize = DMA1 + 0x0C;
const RX_STREAM: usize = 5;
const TX_STREAM: usize = 6;
const fn sxcr(s: usize) -> usize {
    DMA1 + 0x10 + 0x18 * s
}
const fn sxndtr(s: usize) -> usize {
    DMA1 + 0x14 + 0x18 * s
}
const fn sxpar(s: usize) -> usize {
    DMA1 + 0x18 + 0x18 * s
}
const fn sxm0ar(s: usize) -> usize {
    DMA1 + 0x1C + 0x18 * s
}
/// A stream's flags in HISR / HIFCR (streams 4-7): FEIF, DMEIF, TEIF, HTIF, TCIF at
/// bits 0, 2, 3, 4, 5 of its field, the fields at 0, 6, 16, 22.
/// (Evaluated at compile time only: the constants below.)
const fn hshift(s: usize) -> u32 {
    [0, 6, 16, 22][s - 4]
}
const RX_FLAGS: u32 = 0b11_1101 << hshift(RX_STREAM);
const RX_HTIF: u32 = (1 << 4) << hshift(RX_STREAM);
const RX_TCIF: u32 = (1 << 5) << hshift(RX_STREAM);
const TX_FLAGS: u32 = 0b11_1101 << hshift(TX_STREAM);
const TX_TEIF: u32 = (1 << 3) << hshift(TX_STREAM);
const CR_EN: u32 = 1 << 0;
const CR_TEIE: u32 = 1 << 2;
const CR_HTIE: u32 = 1 << 3;
const CR_TCIE: u32 = 1 << 4;
const CR_DIR_M2P: u32 = 0b01 << 6;
const CR_CIRC: u32 = 1 << 8;
const CR_MINC: u32 = 1 << 10;
const CR_PL_HIGH: u32 = 0b10 << 16;
const CR_PL_VERY_HIGH: u32 = 0b11 << 16;
/// Channel 4: USART2's requests on streams 5 and 6 (RM0390 table 28).
const CR_CHSEL_4: u32 = 4 << 25;

// GPIOA (0x4002_0000; RM0390 7.4).
const GPIOA: usize = 0x4002_0000;
const GPIO_MODER: usize = GPIOA;
const GPIO_OSPEEDR: usize = GPIOA + 0x08;
const GPIO_AFRL: usize = GPIOA + 0x20;

fn read(addr: usize) -> u32 {
    // SAFETY: `addr` is one of the USART2, DMA1 or GPIOA registers above (STM32F446
    // memory map): a valid, aligned MMIO word; only this module touches them after
    // `start` (the safe frame path takes USART2 over after a panic, interrupts off).
    unsafe { read_volatile(addr as *const u32) }
}

fn write(addr: usize, value: u32) {
    // SAFETY: as in `read`.
    unsafe { write_volatile(addr as *mut u32, value) }
}

fn modify(addr: usize, clear: u32, set: u32) {
    write(addr, (read(addr) & !clear) | set);
}

/// The receive ring the DMA writes (circularly) and the receive task reads.
static mut RX_RING: [u8; RING] = [0; RING];
/// The transmit transfer's bytes (the transmit task writes them while the stream is
/// off; the DMA reads them while it is on).
static mut TX_BUF: [u8; TX_LEN] = [0; TX_LEN];

/// Halves of the ring the DMA filled since start (modulo 2^32).
static RX_HALVES: AtomicU32 = AtomicU32::new(0);
/// USART error events (overrun, framing, noise) since the receive task last looked.
static RX_ERRORS: AtomicU32 = AtomicU32::new(0);
static RX_WAKER: AtomicWaker = AtomicWaker::new();
static TX_WAKER: AtomicWaker = AtomicWaker::new();
static TX_ERROR: AtomicBool = AtomicBool::new(false);

/// What a receive lost.
pub enum RxLost {
    /// USART error events (overrun, framing, noise): the bytes in flight, one each.
    Errors(u32),
    /// Bytes the DMA overwrote before they were read (the task was not run for more
    /// than a ring's worth of bytes).
    Lapped(u32),
}

/// The receive side: the bytes read so far (modulo 2^32).
pub struct Rx {
    read: u32,
}

impl Rx {
    /// Waits until the DMA has written bytes not yet read, then copies up to
    /// `out.len()` of them (at least one; 0 only for an empty `out`).
    pub async fn read(&mut self, out: &mut [u8]) -> Result<usize, RxLost> {
        poll_fn(|cx| {
            RX_WAKER.register(cx.waker());
            let errors = RX_ERRORS.swap(0, Ordering::Relaxed);
            if errors > 0 {
                return Poll::Ready(Err(RxLost::Errors(errors)));
            }
            let written = rx_written();
            let (new, lost) = link::rx_take(self.read, written);
            if lost > 0 {
                self.read = written;
                return Poll::Ready(Err(RxLost::Lapped(lost)));
            }
            let n = (new as usize).min(out.len());
            if n == 0 && !out.is_empty() {
                return Poll::Pending;
            }
            // The DMA's writes before the index that was read, then the bytes.
            compiler_fence(Ordering::Acquire);
            let ring = addr_of!(RX_RING).cast::<u8>();
            for (i, o) in out.iter_mut().take(n).enumerate() {
                let at = (self.read as usize).wrapping_add(i) % RING;
                // SAFETY: `at < RING`, within RX_RING; a volatile read of a byte the DMA
                // wrote (no reference to the ring is formed while the DMA writes it).
                *o = unsafe { read_volatile(ring.add(at)) };
            }
            // The DMA may have lapped the reader during the copy: those bytes are lost.
            let now = rx_written();
            let (_, lost) = link::rx_take(self.read, now);
            if lost > 0 {
                self.read = now;
                return Poll::Ready(Err(RxLost::Lapped(lost)));
            }
            self.read = self.read.wrapping_add(n as u32);
            Poll::Ready(Ok(n))
        })
        .await
    }
}

/// Bytes the receive DMA wrote since start (halves first, then the index: see
/// `nucleo_link::rx_written` for the race).
fn rx_written() -> u32 {
    let halves = RX_HALVES.load(Ordering::Relaxed);
    compiler_fence(Ordering::Acquire);
    link::rx_written(halves, link::rx_index(read(sxndtr(RX_STREAM))))
}

/// The transmit side.
pub struct Tx {
    _private: (),
}

/// A transmit transfer ended on a DMA transfer error.
pub struct TxError;

impl Tx {
    /// The transfer buffer, to fill before [`Tx::send`] (no transfer runs: `send` waits
    /// for its transfer's end).
    pub fn buf(&mut self) -> &mut [u8; TX_LEN] {
        // SAFETY: TX_BUF is reached only through the one `Tx` (`start` makes it once),
        // and the DMA reads it only inside `send`, which holds `&mut self`: no other
        // reference exists while this one lives.
        unsafe { &mut *addr_of_mut!(TX_BUF) }
    }

    /// Sends the first `n` bytes of the buffer by DMA and waits for the transfer's end.
    pub async fn send(&mut self, n: usize) -> Result<(), TxError> {
        let n = n.min(TX_LEN);
        if n == 0 {
            return Ok(());
        }
        // The stream is off (its last transfer ended); its old flags must be cleared
        // before it is enabled again (RM0390 9.3.17, "Stream configuration procedure").
        write(DMA_HIFCR, TX_FLAGS);
        write(sxm0ar(TX_STREAM), addr_of!(TX_BUF) as u32);
        write(sxndtr(TX_STREAM), n as u32);
        // The buffer's writes before the DMA may read it.
        compiler_fence(Ordering::SeqCst);
        // The configuration with EN clear, then EN (9.3.17: enabling is the last step).
        let cr = CR_CHSEL_4 | CR_PL_HIGH | CR_MINC | CR_DIR_M2P | CR_TCIE | CR_TEIE;
        write(sxcr(TX_STREAM), cr);
        write(sxcr(TX_STREAM), cr | CR_EN);
        poll_fn(|cx| {
            TX_WAKER.register(cx.waker());
            // EN is cleared by the hardware at the transfer's end or on its error.
            if read(sxcr(TX_STREAM)) & CR_EN == 0 {
                Poll::Ready(())
            } else {
                Poll::Pending
            }
        })
        .await;
        compiler_fence(Ordering::SeqCst);
        if TX_ERROR.swap(false, Ordering::Relaxed) {
            Err(TxError)
        } else {
            Ok(())
        }
    }
}

/// Clocks and configures PA2/PA3, USART2 at the build's baud and both DMA streams,
/// starts reception and enables the interrupts. Called once, after the clock tree is set
/// (`embassy_stm32::init`); `None` if called again.
pub fn start() -> Option<(Tx, Rx)> {
    static STARTED: AtomicBool = AtomicBool::new(false);
    if STARTED.swap(true, Ordering::Relaxed) {
        return None;
    }
    let rcc = pac::RCC;
    // Clocks of GPIOA and DMA1 (RM0390 6.3.10 RCC_AHB1ENR) and USART2 (6.3.13
    // RCC_APB1ENR); the read back lets the enables take effect before the peripherals'
    // registers are written.
    rcc.ahb1enr().modify(|w| {
        w.set_gpioaen(true);
        w.set_dma1en(true);
    });
    rcc.apb1enr().modify(|w| w.set_usart2en(true));
    let _ = rcc.apb1enr().read();

    // PA2 and PA3 in alternate function 7, USART2 (datasheet DS10693 table 11): MODER
    // 0b10 each (RM0390 7.4.1), AFRL 7 each (7.4.9), PA2's output at high speed (7.4.3:
    // 5.25 Mbaud edges); RX without pull, as embassy-stm32's default.
    modify(GPIO_AFRL, 0xFF << 8, 0x77 << 8);
    modify(GPIO_OSPEEDR, 0b11 << 4, 0b10 << 4);
    modify(GPIO_MODER, 0b1111 << 4, 0b1010 << 4);

    // USART2 off while configured: 8 data bits, no parity, 1 stop bit (CR1/CR2 at
    // reset), the baud (BRR, RM0390 25.6.3) and OVER8 (25.6.4).
    write(USART_CR1, 0);
    write(USART_BRR, u32::from(BRR.0));

    // Receive DMA first (RM0390 25.4, "Continuous communication using DMA", reception;
    // the stream per 9.3.17, "Stream configuration procedure"): from DR to the ring,
    // circular, byte transfers (PSIZE/MSIZE 0), memory increment, interrupts at half
    // and end of the ring and on a transfer error, channel 4, very high priority.
    write(DMA_HIFCR, RX_FLAGS);
    write(sxpar(RX_STREAM), USART_DR as u32);
    write(sxm0ar(RX_STREAM), addr_of!(RX_RING) as u32);
    write(sxndtr(RX_STREAM), RING as u32);
    let rx_cr = CR_CHSEL_4 | CR_PL_VERY_HIGH | CR_MINC | CR_CIRC | CR_HTIE | CR_TCIE | CR_TEIE;
    // The configuration with EN clear, then EN (9.3.17: enabling is the last step).
    write(sxcr(RX_STREAM), rx_cr);
    write(sxcr(RX_STREAM), rx_cr | CR_EN);
    // The transmit stream's fixed part: to DR (each transfer sets address and count).
    write(sxpar(TX_STREAM), USART_DR as u32);

    // DMA requests on receive and transmit, error interrupt (CR3, 25.6.6), then the
    // USART on with receiver, transmitter and the IDLE interrupt (CR1).
    write(USART_CR3, CR3_DMAR | CR3_DMAT | CR3_EIE);
    let over8 = if BRR.1 { CR1_OVER8 } else { 0 };
    write(USART_CR1, CR1_UE | CR1_TE | CR1_RE | CR1_IDLEIE | over8);

    for irq in [
        interrupt::USART2,
        interrupt::DMA1_STREAM5,
        interrupt::DMA1_STREAM6,
    ] {
        irq.unpend();
        irq.set_priority(PRIORITY);
        // SAFETY: the handlers (`board::nucleo`) use this module's atomics and wakers
        // only; no critical section is in progress here.
        unsafe { irq.enable() };
    }
    Some((Tx { _private: () }, Rx { read: 0 }))
}

/// Stops the transmit DMA (interrupts off: the panic and fault path) and hands USART2
/// to polled writes: stream 6 off and waited for (RM0390 9.3.17: EN reads 0 once the
/// stream stopped), then DMAT clear.
pub fn stop_tx_dma() {
    modify(sxcr(TX_STREAM), CR_EN, 0);
    while read(sxcr(TX_STREAM)) & CR_EN != 0 {}
    modify(USART_CR3, CR3_DMAT, 0);
}

/// USART2's interrupt: IDLE (a frame ended) or an error. SR then DR read clears IDLE,
/// ORE, NF and FE (RM0390 25.6.1); the DMA has taken every byte before the line went
/// idle, so the DR read takes none from it.
pub fn on_usart2() {
    let sr = read(USART_SR);
    if sr & (SR_IDLE | SR_ERRORS) != 0 {
        let _ = read(USART_DR);
    }
    if sr & SR_ORE_NF_FE != 0 {
        RX_ERRORS.fetch_add(1, Ordering::Relaxed);
    }
    RX_WAKER.wake();
}

/// DMA1 stream 5's interrupt: a half of the ring filled (HT at its middle, TC at its
/// end), or a transfer error. Clears the flags read (HIFCR, RM0390 9.5.4).
pub fn on_rx_dma() {
    let hisr = read(DMA_HISR);
    write(DMA_HIFCR, hisr & RX_FLAGS);
    let halves = u32::from(hisr & RX_HTIF != 0) + u32::from(hisr & RX_TCIF != 0);
    RX_HALVES.fetch_add(halves, Ordering::Relaxed);
    RX_WAKER.wake();
}

/// DMA1 stream 6's interrupt: the transmit transfer ended, or failed.
pub fn on_tx_dma() {
    let hisr = read(DMA_HISR);
    write(DMA_HIFCR, hisr & TX_FLAGS);
    if hisr & TX_TEIF != 0 {
        TX_ERROR.store(true, Ordering::Relaxed);
    }
    TX_WAKER.wake();
}
