//! The closed loop of the plant with the device, wherever it runs, through one
//! [`transport::Transport`]: the simulated link ([`sim_link`]), the in-process device
//! ([`inproc`]), the exchange per period ([`exchange`]), a device run of a scenario
//! ([`device_loop`]), the control core on the plant ([`core`]), the one driver of a
//! controller on the plant ([`drive`]) and the rate warning ([`rate_check`]).
#![deny(missing_docs)]

pub mod core;
pub mod device_loop;
pub mod drive;
pub mod exchange;
pub mod inproc;
pub mod rate_check;
pub mod sim_link;
pub mod transport;
