//! Time integration: fixed-step RK4 on integer-nanosecond time (`k * dt_ns`, never
//! accumulated in floats), the continuous-time reference run and the sampled-data run.
//! The track is evaluated at each RK4 stage; the step inputs (demand, `F_run`) once at
//! each step's start, so a step at 5 s acts from exactly 5 s.

mod continuous;
mod rk4;
mod sampled_run;
mod trajectory;

pub use continuous::*;
pub use rk4::*;
pub use sampled_run::*;
pub use trajectory::*;

/// Errors of a sampled run's configuration.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum SimError {
    /// The controller period is not a positive multiple of the integration step.
    #[error("controller period {period_ns} ns is not a positive multiple of the integration step {dt_ns} ns")]
    Period {
        /// Period, ns.
        period_ns: u64,
        /// Step, ns.
        dt_ns: u64,
    },
    /// The actuator delay is not a multiple of the integration step.
    #[error("actuator delay {delay_ns} ns is not a multiple of the integration step {dt_ns} ns")]
    Delay {
        /// Delay, ns.
        delay_ns: u64,
        /// Step, ns.
        dt_ns: u64,
    },
}
