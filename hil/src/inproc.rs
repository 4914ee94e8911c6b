//! The in-process target: the firmware's own runtime behind the simulated serial link,
//! on simulated time. Defined once in `wheelset_loop::inproc` (the plant's own device loop
//! uses the same device, tick phase and accounting); re-exported here as the harness's
//! `inproc` target, with its deliberately broken devices ([`DeviceFault`]).

pub use wheelset_loop::inproc::{DeviceFault, InProc};
