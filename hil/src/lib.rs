//! The hardware-in-the-loop harness.
#![deny(missing_docs)]

pub mod audit;
pub mod qemu;
