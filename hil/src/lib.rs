//! The hardware-in-the-loop harness.

pub mod qemu;
