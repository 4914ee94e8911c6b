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
//! - [`svg`]: a small dependency-free SVG plotting module (line, scatter, bars).
//! - [`figures`]: the paper's figures (time histories, root loci).
//! - [`adhesion`]: Polach's adhesion-limited creep law, rail conditions as data.
//! - [`traction`]: creep characteristics, the per-section adhesion summary, runaway.
//! - [`numeric`]: finiteness before every eigenvalue/exponential, blame, conditioning.
//! - [`outcome`]: a stopped run is a numerical failure or an unstable loop.
//! - [`rate_check`]: the warning before a device run at a rate the analysis finds unstable.
//! - [`memory`]: the memory estimate of a run or a sweep, refused above 2 GiB.
//! - [`input`]: the one reader of input files (regular files up to 1 MiB).
//! - [`output`]: output paths checked before any work.
//! - [`core_loop`]: the control core (e.g. f64) on the plant without the link.
//! - [`link`], [`device`]: the simulated serial link and the device runtime behind it;
//!   [`transport`]: the one transport trait (bytes out, bytes in with a deadline);
//!   [`inproc`]: the in-process device as a transport; [`exchange`]: the closed-loop
//!   adapter every device loop uses.
#![deny(missing_docs)]

pub mod adhesion;
pub mod control;
pub mod core_loop;
pub mod device;
pub mod error;
pub mod exchange;
pub mod fault;
pub mod figures;
pub mod inproc;
pub mod input;
pub mod linear;
pub mod link;
pub mod memory;
pub mod modes;
pub mod numeric;
pub mod out;
pub mod outcome;
pub mod output;
pub mod params;
pub mod plant;
pub mod rate_check;
pub mod sampled;
pub mod scenario;
pub mod sim;
pub mod svg;
pub mod traction;
pub mod transport;
