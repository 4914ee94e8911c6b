//! The wheelset controller firmware: the embassy task structure shared by the boards
//! (`app`), generic over the `board::Board` interface, and the board layers; the one
//! `board-<name>` feature of a build selects its board (`board::Selected`), its chip and
//! its memory map (`build.rs`).
//!
//! - `board-nucleo`: Nucleo-F446RE on embassy-stm32's drivers (`board::nucleo`).
//! - `board-nucleo-g474`: Nucleo-G474RE on embassy-stm32's drivers (`board::nucleo_g474`).
//! - `board-qemu`: QEMU `mps2-an386`, the crate's own board layer (`board::qemu`),
//!   frame-clocked lock-step, SysTick instruction counts, defmt over semihosting.
//!
//! The STM32 boards are **not run on silicon here**: they compile, link and fit their
//! budget (`cargo fw`). `cargo fw` builds each board in its own cargo invocation, so one
//! board's HAL can never be linked into another's binary. On the host only the
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
// The STM32 boards' clock-tree checks, tested on the host (on a board they are
// `board::stm32::clock`).
#[cfg(test)]
#[path = "board/stm32/clock.rs"]
mod stm32_clock;

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
