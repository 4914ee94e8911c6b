//! The closed loop of the plant with the device: the plant of `wheelset-plant` against
//! the firmware's runtime, wherever the device runs, through one [`transport::Transport`].
//!
//! - [`transport`]: the one transport trait (bytes out, bytes in with a deadline).
//! - [`sim_link`]: the simulated serial link (baud, latency, faults, frame accounting).
//! - [`inproc`]: the in-process device (the flashed `Runtime`) as a transport.
//! - [`exchange`]: the closed-loop adapter every device loop uses (one exchange per
//!   control period).
//! - [`device_loop`]: a device-in-the-loop run of a scenario (`sim-host run --loop
//!   device`): its options, the device's configuration, the deviation from a reference.
//! - [`core`]: the control core (e.g. f64) on the plant without the link.
//! - [`rate_check`]: the warning before a device run at a rate the analysis finds unstable.
#![deny(missing_docs)]

pub mod core;
pub mod device_loop;
pub mod exchange;
pub mod inproc;
pub mod rate_check;
pub mod sim_link;
pub mod transport;
