//! CMSDK APB UART0 of the mps2-an386: the control link. No FIFO, so the RX interrupt is
//! the receiver (each 0x00 advances the frame clock); transmission is a task.

use core::future::poll_fn;
use core::ptr::{read_volatile, write_volatile};
use core::sync::atomic::Ordering;
use core::task::Poll;

use embassy_sync::waitqueue::AtomicWaker;

const BASE: usize = 0x4000_4000;
const DATA: usize = BASE;
const STATE: usize = BASE + 0x04;
const CTRL: usize = BASE + 0x08;
const INTCLEAR: usize = BASE + 0x0C;
const BAUDDIV: usize = BASE + 0x10;

const STATE_TXFULL: u32 = 1 << 0;
const STATE_RXFULL: u32 = 1 << 1;
const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;
const CTRL_TX_INTEN: u32 = 1 << 2;
const CTRL_RX_INTEN: u32 = 1 << 3;
const INT_TX: u32 = 1 << 0;
const INT_RX: u32 = 1 << 1;

/// 25 MHz / 115200 baud. QEMU does not time the bytes, but ignores a divider below 16.
const BAUD_DIVIDER: u32 = 217;

static TX_WAKER: AtomicWaker = AtomicWaker::new();

fn read(addr: usize) -> u32 {
    // SAFETY: `addr` is a UART0 register: valid, aligned MMIO; only DATA's read has an effect.
    unsafe { read_volatile(addr as *const u32) }
}

fn write(addr: usize, value: u32) {
    // SAFETY: as in `read`; the UART is owned by this module alone.
    unsafe { write_volatile(addr as *mut u32, value) }
}

/// Enables the transmitter and the receiver with its interrupt.
pub fn init() {
    write(BAUDDIV, BAUD_DIVIDER);
    write(INTCLEAR, INT_TX | INT_RX);
    write(CTRL, CTRL_TX_EN | CTRL_RX_EN | CTRL_RX_INTEN);
}

/// UART0 RX interrupt: the holding register into the RX pipe (deadline: one byte time).
pub fn on_rx_interrupt() {
    loop {
        // Clear first, then read: a byte arriving after the read raises a new interrupt.
        write(INTCLEAR, INT_RX);
        if read(STATE) & STATE_RXFULL == 0 {
            break;
        }
        let byte = (read(DATA) & 0xFF) as u8;
        crate::watchdog::rx_ran();
        if crate::app::RX.try_write(&[byte]) != Ok(1) {
            crate::app::RX_OVERRUN.fetch_add(1, Ordering::Relaxed);
        }
        // The free-running build's clock is TIMER0, not the host's frames.
        if byte == 0 && !cfg!(feature = "free-run") {
            super::clock::frame_edge();
        }
    }
}

/// UART0 TX interrupt: the holding register has room again.
pub fn on_tx_interrupt() {
    write(INTCLEAR, INT_TX);
    write(CTRL, read(CTRL) & !CTRL_TX_INTEN);
    TX_WAKER.wake();
}

/// Writes `bytes`, waiting (asynchronously) whenever the holding register is full.
pub async fn write_all(bytes: &[u8]) {
    for &b in bytes {
        poll_fn(|cx| {
            if read(STATE) & STATE_TXFULL == 0 {
                return Poll::Ready(());
            }
            TX_WAKER.register(cx.waker());
            critical_section::with(|_| write(CTRL, read(CTRL) | CTRL_TX_INTEN));
            if read(STATE) & STATE_TXFULL == 0 {
                Poll::Ready(())
            } else {
                Poll::Pending
            }
        })
        .await;
        write(DATA, u32::from(b));
    }
}

/// Polled write for the panic handler (interrupts are off there).
pub fn write_blocking(bytes: &[u8]) {
    for &b in bytes {
        while read(STATE) & STATE_TXFULL != 0 {}
        write(DATA, u32::from(b));
    }
}
