//! The device's homes other than the process (QEMU, a board on a serial port, its stand-in
//! behind a pseudo-terminal), each a [`wheelset_loop::transport::Transport`].
#![deny(missing_docs)]

pub mod elf;
pub mod lockstep;
pub mod qemu;
pub mod realtime;
pub mod serial;
