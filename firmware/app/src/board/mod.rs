//! The board interface, and this build's board ([`Selected`], by its `board-<name>` feature).

use crate::app::Stopwatch;

#[cfg(feature = "board-nucleo")]
pub mod nucleo;
#[cfg(feature = "board-nucleo")]
pub use nucleo::Board as Selected;

#[cfg(feature = "board-nucleo-g474")]
pub mod nucleo_g474;
#[cfg(feature = "board-nucleo-g474")]
pub use nucleo_g474::Board as Selected;

#[cfg(feature = "board-qemu")]
pub mod qemu;
#[cfg(feature = "board-qemu")]
pub use qemu::Board as Selected;

#[cfg(feature = "stm32")]
pub mod stm32;

/// What a board gives the firmware: in [`Board::run`] its clocks, the link into
/// `crate::app::RX`, the tick source, the executors and its watchdog.
pub trait Board {
    /// The highest base rate a host Config may set (`u32::MAX`: no limit, frames are the clock).
    const LINK_MAX_RATE_HZ: u32;
    /// Whether this build's watchdog ends an injected stall (`fault-inject`); default no.
    const WATCHDOG_ENDS_STALL: bool = false;
    /// The execution-time counter of a tick (cycles on silicon, instructions under QEMU).
    type Stopwatch: Stopwatch;

    /// Brings the board up and runs the firmware forever.
    fn run() -> !;
    /// The control period in time-driver ticks, for a tick source that needs it (QEMU's).
    fn set_period(_ticks: u64) {}
    /// The hardware's reset cause (`None`: no register) and whether it was a power-on reset.
    fn reset_cause() -> (Option<u8>, bool);
    /// The safe frame by polled writes to the link, every wait bounded (interrupts off).
    fn send_safe_frame();
    /// The end of every fault path: the safe outputs once, cause FAULT, then the reset.
    fn halt() -> !;
    /// A fault injection the runtime accepted (`crate::panic::inject`); none by default.
    fn inject(_c: wheelset_proto::Command) {}
}
