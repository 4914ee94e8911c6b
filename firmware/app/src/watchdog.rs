//! The feed condition of the hardware watchdog, shared by the boards.
//!
//! The watchdog is fed only when the control tick **and** the receive path have each
//! run since the last feed: the control task calls [`tick_ran`] after each tick, the
//! receive path (the UART RX interrupt or DMA task, the bulk channel) calls [`rx_ran`]
//! for each chunk of bytes it handled, and the board's idle loop feeds when
//! [`take_both`] says both happened. So a stalled control task, a wedged receiver, or an
//! interrupt storm that starves thread mode all stop the feeding, and the watchdog
//! resets the board (timeouts: the board modules, `board::qemu::wdog` and
//! `board::nucleo::IWDG_TIMEOUT_US`). The boards start their watchdog at the first time
//! [`take_both`] says yes (the host's first bytes and a tick after them), so a board
//! waiting for its host is not reset; the QEMU lock-step build does not start it.

use core::sync::atomic::{AtomicBool, Ordering};

static TICK_RAN: AtomicBool = AtomicBool::new(false);
static RX_RAN: AtomicBool = AtomicBool::new(false);

/// The control task ran a tick.
#[inline(always)]
pub fn tick_ran() {
    TICK_RAN.store(true, Ordering::Relaxed);
}

/// The receive path handled bytes.
#[inline(always)]
pub fn rx_ran() {
    RX_RAN.store(true, Ordering::Relaxed);
}

/// `true` (and both marks cleared) if the tick and the receive path have each run since
/// the last time this returned `true`: the watchdog may be fed.
#[inline(always)]
pub fn take_both() -> bool {
    if TICK_RAN.load(Ordering::Relaxed) && RX_RAN.load(Ordering::Relaxed) {
        TICK_RAN.store(false, Ordering::Relaxed);
        RX_RAN.store(false, Ordering::Relaxed);
        true
    } else {
        false
    }
}
