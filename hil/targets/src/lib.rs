//! The device's homes other than the process, each a [`wheelset_loop::transport::Transport`]:
//! [`qemu`] (the firmware under QEMU, over its UART or the bulk channel), [`serial`] (a board,
//! lock-step), [`realtime`] (a free-running device paced in real time; [`realtime::serve`], a
//! board's stand-in behind a pseudo-terminal), [`lockstep`] (frame-clocked bookkeeping),
//! [`elf`] (the firmware image checked before QEMU is launched).
#![deny(missing_docs)]

pub mod elf;
pub mod lockstep;
pub mod qemu;
pub mod realtime;
pub mod serial;
