//! The hardware-in-the-loop harness: the plant of `sim-host` against the device wherever
//! it runs (in process over the simulated link, the firmware under QEMU, a board on a
//! serial port), through one [`transport::Transport`], with timing, numerics and
//! frame-accounting verdicts and reports.
//!
//! - [`transport`]: the trait; [`inproc`]: the in-process device; [`serial`]: a serial
//!   port (lock-step); [`realtime`]: a free-running device paced in real time (with
//!   [`rt_os`], what the operating system grants it); [`serve`]: `hil serve --pty`, the
//!   free-running stand-in for a board; [`qemu_target`]: the firmware under QEMU
//!   (launched by [`qemu`], with the command line of [`qemu_cmd`]);
//!   [`lockstep`]: the bookkeeping of frame-clocked devices.
//! - [`closed_loop`]: the device as the plant's sampled controller.
//! - [`timing`], [`numerics`], [`frames`], [`monitor`]: the checks; [`budget`]: their
//!   limits.
//! - [`run`]: `hil run`; [`report`]: JSON, CSV and the Markdown report; [`table`]: the
//!   one Markdown table writer of every report.
//! - [`sweep`]: `hil sweep`, the closed loop over a parameter grid, sharded and merged.
//! - [`golden`]: `hil golden`, open-loop golden vectors host vs target, bit for bit.
//! - [`audit`]: `hil audit`, the fixed-point accuracy audit of the control core.
#![deny(missing_docs)]

pub mod audit;
pub mod budget;
pub mod closed_loop;
pub mod elf;
pub mod frames;
pub mod golden;
pub mod inproc;
pub mod link_check;
pub mod lockstep;
pub mod machine;
pub mod monitor;
pub mod numerics;
pub mod qemu;
pub mod qemu_cmd;
pub mod qemu_target;
pub mod realtime;
pub mod report;
pub mod rt_os;
pub mod run;
pub mod serial;
pub mod serve;
pub mod sweep;
pub mod table;
pub mod timing;
pub mod transport;
