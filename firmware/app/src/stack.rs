//! The stack's high-water mark (`Status.stack_peak`): [`paint`] fills up to [`WINDOW`]
//! bytes below the stack pointer with [`PAINT`]; the peak is `_stack_start` minus the
//! lowest repainted word, scanned every [`SCAN_TICKS`] ticks outside the measured tick.

use core::sync::atomic::{AtomicUsize, Ordering};

/// Bytes painted below the stack pointer (far more than the firmware uses).
pub const WINDOW: usize = 16 * 1024;
/// The paint: a word no pointer or small integer of the program looks like.
pub const PAINT: u32 = 0xC5AC_CE55;
/// The peak is read every this many ticks (0.2 s at 5 kHz).
pub const SCAN_TICKS: u32 = 1024;

/// The lowest painted address; 0: not painted.
static BOTTOM: AtomicUsize = AtomicUsize::new(0);

extern "C" {
    /// The initial stack pointer (the top of RAM).
    static _stack_start: u32;
    /// The end of the statics (`.bss`, `.uninit`): the stack may grow down to here.
    static _stack_end: u32;
}

/// Paints the window below the current stack pointer (once; interrupts off).
pub fn paint() {
    cortex_m::interrupt::free(|_| {
        let sp = cortex_m::register::msp::read() as usize;
        // Below this frame nothing is live (interrupts are off): keep 64 B of margin.
        let end = sp.saturating_sub(64) & !3;
        let floor = (core::ptr::addr_of!(_stack_end) as usize + 3) & !3;
        let bottom = end.saturating_sub(WINDOW).max(floor);
        let mut a = bottom;
        while a < end {
            // SAFETY: `a` is word aligned, above the statics and below the live stack (interrupts off).
            unsafe { core::ptr::write_volatile(a as *mut u32, PAINT) };
            a += 4;
        }
        BOTTOM.store(bottom, Ordering::Relaxed);
    });
}

/// Bytes of stack used since [`paint`] (0 if it has not painted).
pub fn peak() -> u32 {
    let bottom = BOTTOM.load(Ordering::Relaxed);
    if bottom == 0 {
        return 0;
    }
    let top = core::ptr::addr_of!(_stack_start) as usize;
    let mut a = bottom;
    // SAFETY: word-aligned reads between the painted bottom and the top of RAM.
    while a < top && unsafe { core::ptr::read_volatile(a as *const u32) } == PAINT {
        a += 4;
    }
    u32::try_from(top - a).unwrap_or(u32::MAX)
}
