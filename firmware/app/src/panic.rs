//! The panic and HardFault handlers, the last line of defence (no panic is reachable from
//! input): interrupts off, the safe frame by bounded polling, then `Board::halt`.

use core::panic::PanicInfo;
use core::sync::atomic::{AtomicBool, Ordering};

use crate::board::{Board, Selected};

static HALTING: AtomicBool = AtomicBool::new(false);

/// The safe frame ([`Board::send_safe_frame`]) by the first fault path only.
pub fn send_safe_frame_once() {
    if !HALTING.swap(true, Ordering::Relaxed) {
        Selected::send_safe_frame();
    }
}

/// The HardFault handler: the safe outputs (bounded), cause FAULT, then SYSRESETREQ.
#[cortex_m_rt::exception(trampoline = false)]
unsafe fn HardFault() -> ! {
    cortex_m::interrupt::disable();
    send_safe_frame_once();
    crate::boot::record_cause(wheelset_proto::reset_cause::FAULT);
    cortex_m::peripheral::SCB::sys_reset()
}

/// Carries out a fault injection (`fault-inject`): a stall that starves the watchdog, or
/// an undefined instruction (escalated to HardFault).
pub fn inject(c: wheelset_proto::Command) {
    match c {
        wheelset_proto::Command::InjectStall => {
            defmt::warn!("fault injection: control task stalled");
            loop {
                core::hint::spin_loop();
            }
        }
        wheelset_proto::Command::InjectHardFault => {
            defmt::warn!("fault injection: HardFault");
            cortex_m::asm::udf()
        }
        _ => {}
    }
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    cortex_m::interrupt::disable();
    if let Some(loc) = info.location() {
        defmt::error!("panic at {=str}:{=u32}", loc.file(), loc.line());
    } else {
        defmt::error!("panic");
    }
    Selected::halt()
}
