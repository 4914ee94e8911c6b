//! The plant simulator: the railway wheelset with its traction drive on a canted curve.
//!
//! - [`params`]: typed parameters with the paper's defaults, loadable from TOML.
//! - [`scenario`]: track scenarios as data (built-in `curve`, `beating`, or a file).
//! - [`fault`]: plant-side yaw-actuator faults (scenario data).
//! - [`plant`]: the nonlinear model, eqs. (1)-(10) as corrected in `docs/model.md`.
//! - [`control`]: continuous reference controllers and the [`control::SampledController`]
//!   interface for discrete ones.
//! - [`sim`]: fixed-step RK4 on integer-nanosecond time; continuous and sampled runs.
//! - [`linear`]: linearisation about straight-track pure rolling (analytic and
//!   complex-step Jacobians), the linear model `(A, B, C)`.
//! - [`modes`]: modal sweep over the creep coefficient, mode tracking and naming,
//!   instability crossings.
//! - [`sampled`]: the sampled-data rate analysis of the firmware's loops.
//! - [`adhesion`]: Polach's adhesion-limited creep law, rail conditions as data.
//! - [`traction`]: creep characteristics, the per-section adhesion summary, runaway.
//! - [`finite`]: finiteness before every eigenvalue/exponential, blame, conditioning.
//! - [`outcome`]: a stopped run is a numerical failure or an unstable loop.
//! - [`memory`]: the memory estimate of a run or a sweep, refused above 2 GiB.
//! - [`input`]: the one reader of input files (regular files up to 1 MiB).
//! - [`error`]: the typed errors of parameter and scenario files.
//!
//! The closed loop with the device (the link, the in-process device, the exchange, the
//! control core on the plant) is `wheelset-loop`; the figures are `sim-host`'s.
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
