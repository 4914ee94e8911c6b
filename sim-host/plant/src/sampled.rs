//! Sampled-data stability of the loops as the firmware runs them: the plant discretised
//! exactly with a zero-order hold, one base period (or `delay_ticks`) of computation and
//! transport delay on the actuation, and the controllers of `wheelset-control` with the
//! f64 coefficients it computes, each loop at its own divisor of the base rate.
//!
//! # Method
//!
//! Continuous plant `x' = A x + B u`, `u = [T_psi (N m), u_a (V)]`, measured
//! `y = C x = [y' (m/s), i_a (A), theta_m' (rad/s)]`, linearised about straight track at
//! pure rolling. Over one base period `T0` with `u` held:
//!
//! ```text
//! exp([[A, B], [0, 0]] T0) = [[Ad, Bd], [0, I]]          (exact ZOH, nalgebra's expm)
//! ```
//!
//! Tick `k` samples `y[k] = C x[k]`; a loop that runs on tick `k` computes its new output
//! `o[k]` (the lead or gain on the predicted `y'_p = y' + alpha (y'[n] - y'[n-1])`,
//! `alpha = yaw_predict_ticks/yaw_divisor`; the PI on `-i_a`: small-signal deviations,
//! so the limits and the reference drop out); a loop that does not run holds `o[k-1]`. With
//! `delay_ticks = d` the plant sees `o[k-d]` during `[k T0, (k+1) T0)`: `d = 1` is the
//! firmware (the Actuation frame computed from the Sensor frame of tick `k` is applied
//! at the next tick boundary); `d = 0` the ideal ZOH without delay, for comparison.
//!
//! The loop state `X = [x; o[k-1], .., o[k-max(d,1)]; lead x1, z; PI I; y'[n-1]]` evolves by a
//! tick-dependent matrix `M_k`; the loop is periodic with the hyper-period
//! `L = lcm(yaw_divisor, traction_divisor)` ticks, and stable iff every eigenvalue `mu`
//! of the monodromy `Phi = M_{L-1} ... M_0` is inside the unit circle. Each is reported
//! as an equivalent continuous mode `s = ln(mu)/(L T0)`: frequency `|Im s|/2 pi`,
//! damping `zeta = -Re s/|s|`, and the spectral radius per base tick `|mu|^(1/L)`.
//!
//! Free rolling at any speed is an equilibrium of the loop (with the current held by the
//! PI; open loop the back-EMF brakes it): the continuous closed loop's zero eigenvalues
//! map to `mu = 1`; the same number of eigenvalues nearest `mu = 1` are left out of the
//! verdict and reported as excluded.
//!
//! # Files
//!
//! - `sampled/matrices.rs`: the loop matrices (ZOH, tick matrices, monodromy, modes, the
//!   continuous closed loop);
//! - `sampled/design.rs`: the gains designed per rate and delay, their criteria and
//!   the verdict on every candidate;
//! - `sampled/margins.rs`: the loops' gain and phase margins (Nyquist-safe for the
//!   open-loop unstable yaw plant);
//! - `sampled/rate_grid.rs`: the rate grid over creep and conicity, the link budget, and the
//!   choice of the rates;
//! - `sampled/summary.rs`: the rate table as JSON and text;
//! - the plant variants ([`LinearPlant`], [`Model`], [`Reduced`], [`armature`]) live
//!   with the linearisation in [`crate::linear`].

mod design;
mod link_choice;
mod margins;
mod matrices;
mod rate_grid;
mod summary;

pub use crate::linear::{armature, LinearPlant, Model, Reduced};
pub use design::*;
pub use link_choice::*;
pub use margins::*;
pub use matrices::*;
pub use rate_grid::*;
pub use summary::*;
