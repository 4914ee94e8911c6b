//! The hardware-in-the-loop harness: the plant of `wheelset-plant` against the device
//! wherever it runs (in process over the simulated link, the firmware under QEMU, a
//! board on a serial port), through the one `wheelset_loop::transport::Transport`,
//! with timing, numerics and frame-accounting verdicts and reports.
//!
//! The targets are `wheelset-targets` (QEMU, serial, real time) and `wheelset_loop::inproc`
//! (in process); the closed loop is `wheelset_loop::exchange`; the fixed-point audit is
//! `wheelset-audit`. This crate is the harness's own:
//!
//! - [`run`]: `hil run` (the link checked against the rate before a run).
//! - [`check`]: the checks ([`check::timing`], [`check::numerics`], [`check::frames`],
//!   [`check::alarms`]); [`budget`]: their limits.
//! - [`report`]: JSON, CSV and the Markdown report of a run.
//! - [`sweep`]: `hil sweep`, the closed loop over a parameter grid, sharded and merged,
//!   with its report ([`sweep::document`]).
//! - [`golden`]: `hil golden`, open-loop golden vectors host vs target, bit for bit.
//! - [`soak`]: `hil soak`, hours of simulated service in process (streamed, checked at
//!   every tick), or minutes of real time against the free-running firmware under QEMU.
#![deny(missing_docs)]

pub mod budget;
pub mod check;
pub mod golden;
pub mod report;
pub mod run;
pub mod soak;
pub mod sweep;
