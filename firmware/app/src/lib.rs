//! The wheelset controller firmware: the embassy task structure shared by the boards
//! and the two board layers.
//!
//! - `wheelset-nucleo` (feature `board-nucleo`): Nucleo-F446RE on embassy-stm32's drivers
//!   (clock tree, TIM2 time driver, USART2 with a DMA receive ring and DMA transmission,
//!   independent watchdog), defmt over RTT, DWT cycle counter. **Not run on silicon
//!   here**: it compiles, links and fits its budget (`cargo fw`); see `board::nucleo`.
//! - `wheelset-qemu` (feature `board-qemu`): QEMU `mps2-an386`, the crate's own board
//!   layer (`board`, built for the MCU only), frame-clocked lock-step, SysTick instruction counts, defmt over
//!   semihosting.
//!
//! `cargo fw` builds both for `thumbv7em-none-eabihf`, one cargo invocation per board,
//! so one board's HAL can never be linked into the other's binary. On the host only the
//! board-independent modules build (and are tested).
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod bounded;
pub mod device;
pub mod exec;
#[allow(unsafe_code)]
pub mod ring;
pub mod settings;
pub mod tick;
#[cfg(target_os = "none")]
pub mod watchdog;
// The Nucleo's clock-tree checks, tested on the host (on the board they are
// `board::nucleo_clock`).
#[cfg(test)]
#[path = "board/nucleo_clock.rs"]
mod nucleo_clock;

#[cfg(all(target_os = "none", feature = "board-nucleo", feature = "board-qemu"))]
compile_error!("enable exactly one of the features `board-nucleo` and `board-qemu`");
#[cfg(all(
    target_os = "none",
    not(any(feature = "board-nucleo", feature = "board-qemu"))
))]
compile_error!(
    "the firmware needs a board: `--features board-nucleo` or `board-qemu` (or use `cargo fw`)"
);

#[cfg(target_os = "none")]
pub mod app;
#[cfg(target_os = "none")]
#[allow(unsafe_code)]
pub mod board;
#[cfg(target_os = "none")]
#[allow(unsafe_code)]
pub mod boot;
#[cfg(target_os = "none")]
#[allow(unsafe_code)]
mod mem;
#[cfg(target_os = "none")]
#[allow(unsafe_code)]
pub mod panic;
#[cfg(target_os = "none")]
#[allow(unsafe_code)]
pub mod stack;

#[cfg(target_os = "none")]
defmt::timestamp!("{=u64:us}", embassy_time::Instant::now().as_micros());
