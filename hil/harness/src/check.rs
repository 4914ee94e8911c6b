//! The checks of a run, each a pass/warn/fail against its limits in [`crate::budget`]:
//!
//! - [`timing`]: execution time, latency, jitter, missed ticks, CPU and link utilisation.
//! - [`numerics`]: the trajectory against the f64 continuous-time reference.
//! - [`frames`]: every frame in either direction accounted for.
//! - [`alarms`]: the stability-monitor and actuator-check alarms against the scenario
//!   (`hil run`'s `monitor` section).

pub mod alarms;
pub mod frames;
pub mod numerics;
pub mod timing;
