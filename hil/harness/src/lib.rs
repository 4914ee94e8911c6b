//! The hardware-in-the-loop harness: the plant against the device wherever it runs,
//! through the one `wheelset_loop::transport::Transport`, with timing, numerics and
//! frame-accounting verdicts and reports: [`run`] (`hil run`), [`check`] and [`budget`],
//! [`report`], [`sweep`] (`hil sweep`), [`golden`] (`hil golden`), [`soak`] (`hil soak`).
//! The targets are `wheelset-targets` and `wheelset_loop::inproc`; the fixed-point audit
//! is `wheelset-audit`.
#![deny(missing_docs)]

pub mod budget;
pub mod check;
pub mod golden;
pub mod report;
pub mod run;
pub mod soak;
pub mod sweep;
