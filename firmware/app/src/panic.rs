//! The panic handler: outputs to the safe state first, then halt.
//!
//! No panic is reachable from input (frames are decoded without `unwrap`, indexing is
//! checked); this is the last line of defence against a bug. With interrupts off it
//! sends the safe actuation frame by polling the UART (the plant's actuators go to zero
//! torque and zero traction demand), logs, and halts (QEMU: exits with a failure code).

use core::panic::PanicInfo;
use core::sync::atomic::{AtomicBool, Ordering};

static HALTING: AtomicBool = AtomicBool::new(false);

/// Marks the board as halting; `true` if it already was (a panic while sending the safe
/// frame must not try again).
pub fn enter_halt() -> bool {
    HALTING.swap(true, Ordering::Relaxed)
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    if let Some(loc) = info.location() {
        defmt::error!("panic at {=str}:{=u32}", loc.file(), loc.line());
    } else {
        defmt::error!("panic");
    }
    crate::board::panic_halt()
}
