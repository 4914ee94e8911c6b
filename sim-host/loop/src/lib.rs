//! The closed loop of the plant with the device, wherever it runs, through one
//! [`transport::Transport`] (each module's docs say its part).
#![deny(missing_docs)]

pub mod core;
pub mod device_loop;
pub mod drive;
pub mod exchange;
pub mod inproc;
pub mod rate_check;
pub mod sim_link;
pub mod transport;
