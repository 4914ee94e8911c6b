//! The watchdog's feed condition: fed only when the control tick and the receive path
//! have each run since the last feed, so a stall of either leads to a reset.

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

/// `true` (both marks cleared) if the tick and the receive path have each run since.
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
