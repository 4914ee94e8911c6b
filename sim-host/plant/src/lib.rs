//! The railway wheelset with its traction drive on a canted curve (`docs/model.md`) and
//! its analysis; the closed loop with the device is `wheelset-loop`, the figures `sim-host`'s.
#![deny(missing_docs)]

pub mod adhesion;
pub mod control;
pub mod error;
pub mod fault;
pub mod finite;
pub mod input;
pub mod linear;
pub mod memory;
pub mod modes;
pub mod outcome;
pub mod params;
pub mod plant;
pub mod sampled;
pub mod scenario;
pub mod sim;
pub mod traction;
