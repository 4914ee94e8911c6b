//! The board layers; exactly one is compiled into a firmware binary.

#[cfg(feature = "board-nucleo")]
pub mod nucleo;
#[cfg(feature = "board-nucleo")]
pub mod nucleo_clock;
#[cfg(feature = "board-nucleo")]
pub use nucleo::{panic_halt, run, send_safe_frame, set_period, LINK_MAX_RATE_HZ};

#[cfg(feature = "board-qemu")]
pub mod qemu;
#[cfg(feature = "board-qemu")]
pub use qemu::{panic_halt, run, send_safe_frame, set_period, LINK_MAX_RATE_HZ};
