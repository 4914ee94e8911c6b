//! Build-time configuration of the firmware shared by both boards.

/// Base (control) rate of the tick, Hz. Until the runtime supplies its validated
/// configuration this is the link-test stub's rate.
pub const BASE_RATE_HZ: u32 = 4_000;

/// embassy-time tick rate (feature `tick-hz-1_000_000`).
pub const TIMER_HZ: u32 = 1_000_000;

/// Tick period in timer ticks.
pub const PERIOD_TICKS: u64 = (TIMER_HZ / BASE_RATE_HZ) as u64;

/// A tick starting more than this many timer ticks after its deadline counts as late.
pub const LATE_AFTER_TICKS: u64 = PERIOD_TICKS / 4;

/// Bytes buffered between the UART receiver and the control task.
pub const RX_PIPE: usize = 256;

/// Bytes buffered between the control task and the UART transmitter.
pub const TX_PIPE: usize = 128;

/// The numeric build of the control core.
pub const NUMERIC: &str = if cfg!(feature = "f32") {
    "f32"
} else {
    "fixed point"
};

/// The `-icount shift` the QEMU launcher passes: one instruction = 2^shift ns of virtual
/// time; the SysTick stopwatch converts counts to instructions with it.
pub const QEMU_ICOUNT_SHIFT: u32 = 10;
