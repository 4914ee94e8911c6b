//! The panic and HardFault handlers: outputs to the safe state first, then the board's
//! end of the path.
//!
//! No panic is reachable from input (frames are decoded without `unwrap`, indexing is
//! checked); this is the last line of defence against a bug. With interrupts off it
//! logs, sends the safe actuation frame by polling the UART (the plant's actuators go to
//! zero torque and zero traction demand) and ends as the board's `Board::halt` says: the
//! Nucleo records the cause FAULT and resets (SCB), whether or not its watchdog has
//! started; QEMU exits with a failure code. On the Nucleo every wait of the path is
//! bounded (`crate::bounded`): a UART that is not clocked or is wedged cannot keep it
//! from the reset.

use core::panic::PanicInfo;
use core::sync::atomic::{AtomicBool, Ordering};

use crate::board::{Board, Selected};

static HALTING: AtomicBool = AtomicBool::new(false);

/// Marks the board as halting; `true` if it already was (a panic while sending the safe
/// frame must not try again).
pub fn enter_halt() -> bool {
    HALTING.swap(true, Ordering::Relaxed)
}

/// The HardFault handler, every build: the safe outputs first (as the panic handler;
/// bounded on the Nucleo), then the cause FAULT in the boot record (`crate::boot`), then
/// a system reset (SYSRESETREQ), which ends the path: the board boots into its safe
/// outputs, reports `reset_cause` FAULT with `FAULT_LATCHED`, and rejoins the loop.
#[cortex_m_rt::exception(trampoline = false)]
unsafe fn HardFault() -> ! {
    cortex_m::interrupt::disable();
    if !enter_halt() {
        Selected::send_safe_frame();
    }
    crate::boot::record_cause(wheelset_proto::reset_cause::FAULT);
    cortex_m::peripheral::SCB::sys_reset()
}

/// Carries out a fault injection (`Command::InjectStall`, `InjectHardFault`; a board
/// whose `Board::inject` calls it, QEMU's, in builds with `fault-inject`): the control
/// task loops forever without letting the watchdog be fed, or executes an undefined
/// instruction (a UsageFault, escalated to HardFault since the UsageFault handler is not
/// enabled).
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
