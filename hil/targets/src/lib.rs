//! The device's homes other than the process, each a [`wheelset_loop::transport::Transport`]:
//!
//! - [`qemu`]: the firmware under QEMU, launched with the project's one command line
//!   ([`qemu::cmd`]) on a [`qemu::machine::Machine`], over its UART or the semihosting
//!   bulk channel; [`qemu::target::QemuTarget`] is the lock-step transport.
//! - [`serial`]: a board on a serial port, lock-step.
//! - [`realtime`]: a free-running device paced in real time (a serial board, the
//!   free-running QEMU build), with [`realtime::os`], what the operating system grants
//!   the loop; [`realtime::serve`]: the free-running stand-in for a board behind a
//!   pseudo-terminal (`hil serve`).
//! - [`lockstep`]: the bookkeeping of frame-clocked devices.
//! - [`elf`]: the firmware image checked before QEMU is launched.
//!
//! The in-process device is `wheelset_loop::inproc`; the checks and reports of a run are
//! the harness's (`hil`).
#![deny(missing_docs)]

pub mod elf;
pub mod lockstep;
pub mod qemu;
pub mod realtime;
pub mod serial;
