//! Sampled-data stability of the loops as the firmware runs them: the plant discretised
//! exactly with a zero-order hold, `delay_ticks` of computation and transport delay on
//! the actuation, the controllers of `wheelset-control` (f64), each loop at its own
//! divisor of the base rate.
//!
//! Plant `x' = A x + B u`, `u = [T_psi (N m), u_a (V)]`, `y = C x = [y', i_a, theta_m']`,
//! linearised at pure rolling; over one base period `T0`:
//! `exp([[A, B], [0, 0]] T0) = [[Ad, Bd], [0, I]]`. A loop that runs on tick `k` computes
//! `o[k]` (the yaw law on the predicted `y'_p = y' + alpha (y'[n] - y'[n-1])`,
//! `alpha = yaw_predict_ticks/yaw_divisor`; the PI on `-i_a`, small-signal), one that
//! does not holds `o[k-1]`; the plant sees `o[k-d]` (`d = 1`: the firmware).
//! The state `X = [x; o[k-1], .., o[k-max(d,1)]; lead x1, z; PI I; y'[n-1]]` evolves by
//! `M_k`, periodic over `L = lcm(yaw_divisor, traction_divisor)` ticks; stable iff every
//! eigenvalue `mu` of `Phi = M_{L-1} ... M_0` is inside the unit circle, reported as
//! `s = ln(mu)/(L T0)` and a radius per tick `|mu|^(1/L)`. The free-rolling modes (the
//! continuous loop's zero eigenvalues, `mu = 1`) are left out of the verdict.

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
