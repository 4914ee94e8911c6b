//! Fixed-step RK4 on integer-nanosecond time, with the stage hook the runs use.

use super::*;
use crate::control::{closed_loop_rhs_with, ContinuousController, Exogenous};
use crate::plant::{Flags, Inputs, Plant, State, NX};

/// One classical RK4 step of length `h` seconds. `f(stage, x)` returns `dx/dt`; stage 0
/// is at the step start, 1 and 2 at the midpoint, 3 at the end.
#[inline(always)]
pub fn rk4_step<F: FnMut(usize, &State) -> State>(x: &State, h: f64, f: F) -> State {
    rk4_step_with(x, h, f)
}

/// A right-hand side `dx/dt = f(stage, x)` for [`rk4_step_with`].
pub trait Rhs {
    /// `dx/dt` at RK4 stage `stage` (0: step start, 1 and 2: midpoint, 3: end).
    fn eval(&mut self, stage: usize, x: &State) -> State;
}

impl<F: FnMut(usize, &State) -> State> Rhs for F {
    #[inline(always)]
    fn eval(&mut self, stage: usize, x: &State) -> State {
        self(stage, x)
    }
}

/// The plant alone with fixed inputs per stage slot (start, midpoint, end), built once
/// per step. Its right-hand side is inlined into each RK4 stage (a closure would be an
/// out-of-line call per stage). Same arithmetic, bit-identical states.
pub(super) struct PlantStages<'a, F: Flags> {
    pub(super) plant: &'a Plant,
    pub(super) flags: F,
    pub(super) u: [Inputs<f64>; 3],
}

impl<F: Flags> Rhs for PlantStages<'_, F> {
    #[inline(always)]
    fn eval(&mut self, stage: usize, x: &State) -> State {
        let u = &self.u[stage_slot(stage)];
        self.plant.rhs_with(self.flags, x, u).0
    }
}

/// The plant closed by the continuous-time controllers, with the exogenous inputs per
/// stage slot (start, midpoint, end) built once per step: [`closed_loop_rhs`] inlined
/// into each RK4 stage instead of an out-of-line closure call. Same arithmetic as the
/// closure, bit-identical states.
pub(super) struct ClosedLoopStages<'a, F: Flags> {
    pub(super) plant: &'a Plant,
    pub(super) flags: F,
    pub(super) ctrl: &'a ContinuousController,
    pub(super) e: [Exogenous<f64>; 3],
}

impl<F: Flags> Rhs for ClosedLoopStages<'_, F> {
    #[inline(always)]
    fn eval(&mut self, stage: usize, x: &State) -> State {
        let e = &self.e[stage_slot(stage)];
        closed_loop_rhs_with(self.plant, self.flags, self.ctrl, x, e)
    }
}

/// [`rk4_step`] for any [`Rhs`]: the same arithmetic.
#[inline(always)]
pub fn rk4_step_with<R: Rhs>(x: &State, h: f64, mut f: R) -> State {
    let mut f = |stage: usize, x: &State| f.eval(stage, x);
    let k1 = f(0, x);
    let mut xt = [0.0; NX];
    for i in 0..NX {
        xt[i] = x[i] + 0.5 * h * k1[i];
    }
    let k2 = f(1, &xt);
    for i in 0..NX {
        xt[i] = x[i] + 0.5 * h * k2[i];
    }
    let k3 = f(2, &xt);
    for i in 0..NX {
        xt[i] = x[i] + h * k3[i];
    }
    let k4 = f(3, &xt);
    let mut out = [0.0; NX];
    for i in 0..NX {
        out[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
    }
    out
}
