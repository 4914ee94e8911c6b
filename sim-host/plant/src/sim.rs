//! Time integration: fixed-step RK4 on integer-nanosecond time (`k * dt_ns`, never
//! accumulated in floats), the continuous-time reference run and the sampled-data run.
//! The track is evaluated at each RK4 stage; the step inputs (demand, `F_run`) once at
//! each step's start, so a step at 5 s acts from exactly 5 s.

use std::fmt;

mod continuous;
mod rk4;
mod sampled_run;
mod trajectory;

pub use continuous::*;
pub use rk4::*;
pub use sampled_run::*;
pub use trajectory::*;

/// Errors of a sampled run's configuration.
#[derive(Debug, Clone, PartialEq)]
pub enum SimError {
    /// The controller period is not a positive multiple of the integration step.
    Period {
        /// Period, ns.
        period_ns: u64,
        /// Step, ns.
        dt_ns: u64,
    },
    /// The actuator delay is not a multiple of the integration step.
    Delay {
        /// Delay, ns.
        delay_ns: u64,
        /// Step, ns.
        dt_ns: u64,
    },
}

impl fmt::Display for SimError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SimError::Period { period_ns, dt_ns } => write!(
                f,
                "controller period {period_ns} ns is not a positive multiple of the integration step {dt_ns} ns"
            ),
            SimError::Delay { delay_ns, dt_ns } => write!(
                f,
                "actuator delay {delay_ns} ns is not a multiple of the integration step {dt_ns} ns"
            ),
        }
    }
}

impl std::error::Error for SimError {}
