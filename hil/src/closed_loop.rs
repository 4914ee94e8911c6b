//! The closed loop through a [`crate::transport::Transport`]: the one adapter, defined in
//! `wheelset_loop::exchange` (also behind `sim-host run --loop device`) and re-exported here.
//! See its docs for the exchange per control period and the Status fetch at the end.

pub use wheelset_loop::exchange::{
    close_loop, ClosedLoop, DeviceController, HostCounts, LinkSample, LoopSetup, Period,
    RxActuation, STATUS_TRIES,
};
