//! The board interface the firmware is generic over, and the board of this build: the
//! one `board-<name>` feature selects the module `board::<name>` as [`Selected`].

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

/// What a board gives the board-independent firmware (`crate::app`, `crate::panic`).
///
/// A board brings itself up in [`Board::run`]: its clocks (checked against what the
/// build assumes), the link (UART) and its receive path into `crate::app::RX`, the tick
/// source (the embassy-time driver its feature chose), the executors with the control
/// task (`crate::app::control_loop::<Self>`), and its watchdog, fed by the rule of
/// `crate::watchdog`; its reset cause goes to the boot record first.
pub trait Board {
    /// The highest base rate a host Config may set: what the link carries in real time
    /// (`u32::MAX`: no limit, the host's frames are the clock).
    const LINK_MAX_RATE_HZ: u32;
    /// Whether this build's watchdog runs, so that an injected stall
    /// (`Command::InjectStall`, builds with `fault-inject`) ends in a reset; no by
    /// default (no board but QEMU's honours an injection).
    const WATCHDOG_ENDS_STALL: bool = false;
    /// The execution-time counter of a tick (cycles on silicon, instructions under QEMU).
    type Stopwatch: Stopwatch;

    /// Brings the board up and runs the firmware forever.
    fn run() -> !;
    /// The control period, time-driver ticks, for a tick source that needs it (the QEMU
    /// frame clock); by default nothing: a hardware timer's driver schedules its own
    /// alarms.
    fn set_period(_ticks: u64) {}
    /// The hardware's reset cause (`wheelset_proto::reset_cause`; `None`: the board has
    /// no such register) and whether it was a power-on reset, read once at start-up for
    /// the boot record (`crate::boot::start_on`).
    fn reset_cause() -> (Option<u8>, bool);
    /// The safe outputs: the safe frame by polled writes to the link, every wait bounded
    /// (interrupts off; the fault paths call it).
    fn send_safe_frame();
    /// The end of every fault path: the safe outputs (once), the cause FAULT in the boot
    /// record where the board resets, then the board's reset (or, under QEMU, exit).
    fn halt() -> !;
    /// A fault injection the runtime accepted (`crate::panic::inject`); none by default.
    fn inject(_c: wheelset_proto::Command) {}
}
