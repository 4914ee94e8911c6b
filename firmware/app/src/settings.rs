//! Build-time configuration of the firmware shared by both boards.

/// Base rate at start, Hz: the core's default (a Config may change it).
pub const BASE_RATE_HZ: u32 = wheelset_control::DEFAULT_BASE_RATE_HZ;

/// embassy-time tick rate (feature `tick-hz-1_000_000`).
pub const TIMER_HZ: u32 = 1_000_000;

const _: () = assert!(TIMER_HZ.is_multiple_of(BASE_RATE_HZ));

/// Bytes buffered between the UART receiver and the control task.
pub const RX_PIPE: usize = 256;

/// Bytes buffered between the control task and the UART transmitter.
pub const TX_PIPE: usize = 256;

/// The numeric build of the control core.
pub const NUMERIC: &str = if cfg!(feature = "f32") {
    "f32"
} else {
    "fixed point"
};

/// QEMU's `-icount shift`: one instruction = 2^shift ns of virtual time.
pub const QEMU_ICOUNT_SHIFT: u32 = 10;
