//! The checks of a run, each a pass/warn/fail against its limits in [`crate::budget`]:
//! [`timing`], [`numerics`] against the f64 reference, [`frames`] (every frame accounted
//! for) and [`alarms`] (`hil run`'s `monitor` section).

pub mod alarms;
pub mod frames;
pub mod numerics;
pub mod timing;
