//! The wheelset controller firmware: the embassy task structure shared by the boards
//! (`app`) and the board layers; the one `board-<name>` feature selects the board.
#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![cfg_attr(test, allow(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod bounded;
pub mod device;
pub mod exec;
#[allow(unsafe_code)]
pub mod ring;
pub mod settings;
#[cfg(test)]
#[path = "board/stm32/clock.rs"]
mod stm32_clock;
pub mod tick;
#[cfg(target_os = "none")]
pub mod watchdog;

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
