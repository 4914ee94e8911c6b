//! defmt global logger over semihosting (QEMU's stdout), off the control UART.

use core::ptr::addr_of_mut;
use core::sync::atomic::{AtomicBool, Ordering};

use cortex_m_semihosting::hio::{self, HostStream};
use critical_section::RestoreState;

#[defmt::global_logger]
struct SemihostingLogger;

static TAKEN: AtomicBool = AtomicBool::new(false);
// These statics are touched only between `acquire` and `release`, with TAKEN set.
static mut RESTORE: RestoreState = RestoreState::invalid();
static mut ENCODER: defmt::Encoder = defmt::Encoder::new();
static mut STREAM: Option<HostStream> = None;

fn emit(bytes: &[u8]) {
    // SAFETY: called by the encoder only, between `acquire` and `release` (see above).
    let stream = unsafe { &mut *addr_of_mut!(STREAM) };
    if stream.is_none() {
        *stream = hio::hstdout().ok();
    }
    if let Some(s) = stream.as_mut() {
        let _ = s.write_all(bytes);
    }
}

// SAFETY: `acquire` enters a critical section that `release` leaves, so one context uses
// the encoder at a time; TAKEN refuses a nested `acquire`.
unsafe impl defmt::Logger for SemihostingLogger {
    fn acquire() {
        // SAFETY: paired with the `release` below (defmt guarantees the pairing).
        let restore = unsafe { critical_section::acquire() };
        if TAKEN.swap(true, Ordering::Relaxed) {
            // SAFETY: leaves the section just entered; this log call is dropped.
            unsafe { critical_section::release(restore) };
            return;
        }
        // SAFETY: inside the critical section, TAKEN held (see the statics).
        unsafe {
            RESTORE = restore;
            (*addr_of_mut!(ENCODER)).start_frame(emit);
        }
    }

    unsafe fn flush() {}

    unsafe fn release() {
        // SAFETY: defmt calls this after `acquire`, inside its critical section.
        unsafe {
            (*addr_of_mut!(ENCODER)).end_frame(emit);
            TAKEN.store(false, Ordering::Relaxed);
            critical_section::release(RESTORE);
        }
    }

    unsafe fn write(bytes: &[u8]) {
        // SAFETY: defmt calls this between `acquire` and `release`.
        unsafe { (*addr_of_mut!(ENCODER)).write(bytes, emit) }
    }
}
