//! Fixed-step RK4 on integer-nanosecond time, with the stage hook the runs use.

use super::*;
use crate::control::{closed_loop_rhs, ContinuousController, Exogenous};
use crate::plant::{ix, Flags, Inputs, Plant, State, NX};

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

    /// Whether state `i` can move; [`rk4_step_with`] copies one that cannot (exact when
    /// its `dx/dt` is `+0.0` at every stage and it is not `-0.0`). Default: all move.
    #[inline(always)]
    fn moves(&self, i: usize) -> bool {
        let _ = i;
        true
    }
}

impl<F: FnMut(usize, &State) -> State> Rhs for F {
    #[inline(always)]
    fn eval(&mut self, stage: usize, x: &State) -> State {
        self(stage, x)
    }
}

/// The plant alone with fixed inputs per stage slot (start, midpoint, end), built once
/// per step and inlined into each stage; bit-identical states.
pub(super) struct PlantStages<'a, F: Flags> {
    pub(super) plant: &'a Plant,
    pub(super) flags: F,
    pub(super) u: [Inputs<f64>; 3],
}

impl<F: Flags> Rhs for PlantStages<'_, F> {
    #[inline(always)]
    fn eval(&mut self, stage: usize, x: &State) -> State {
        let u = &self.u[stage_slot(stage)];
        self.plant.rhs(self.flags, x, u).0
    }

    /// The controller states and the states of absent parts have `dx/dt = +0.0`.
    #[inline(always)]
    fn moves(&self, i: usize) -> bool {
        plant_state_moves(self.flags, i)
    }
}

/// Whether the plant's right-hand side can move state `i` under flags `f`.
#[inline(always)]
fn plant_state_moves<F: Flags>(f: F, i: usize) -> bool {
    match i {
        ix::LEAD | ix::PI => false,
        ix::TWIST => f.cfg().flexible(),
        ix::WIND | ix::WM | ix::IA => f.cfg().drive,
        _ => true,
    }
}

/// The plant closed by the continuous-time controllers, exogenous inputs per stage
/// slot built once per step, [`closed_loop_rhs`] inlined; bit-identical states.
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
        closed_loop_rhs(self.plant, self.flags, self.ctrl, x, e)
    }

    /// [`PlantStages`]'s fixed states less the controller states in use.
    #[inline(always)]
    fn moves(&self, i: usize) -> bool {
        match i {
            ix::LEAD => true,
            ix::PI => self.flags.cfg().drive,
            _ => plant_state_moves(self.flags, i),
        }
    }
}

/// [`rk4_step`] for any [`Rhs`]. State `i` becomes `x + (h / 6) * ((k1 + 2 (k2 + k3)) + k4)`
/// evaluated as written; the partial sum is formed before the fourth stage (same bits),
/// so only it is kept across the last right-hand side.
#[inline(always)]
pub fn rk4_step_with<R: Rhs>(x: &State, h: f64, mut f: R) -> State {
    let moves: [bool; NX] = std::array::from_fn(|i| f.moves(i));
    let half_h = 0.5 * h;
    let sixth_h = h / 6.0;
    let k1 = f.eval(0, x);
    let mut xt = *x;
    for i in 0..NX {
        if moves[i] {
            xt[i] = x[i] + half_h * k1[i];
        }
    }
    let k2 = f.eval(1, &xt);
    for i in 0..NX {
        if moves[i] {
            xt[i] = x[i] + half_h * k2[i];
        }
    }
    let k3 = f.eval(2, &xt);
    let mut sum = [0.0; NX];
    for i in 0..NX {
        if moves[i] {
            xt[i] = x[i] + h * k3[i];
            sum[i] = k1[i] + 2.0 * (k2[i] + k3[i]);
        }
    }
    let k4 = f.eval(3, &xt);
    let mut out = *x;
    for i in 0..NX {
        if moves[i] {
            out[i] = x[i] + sixth_h * (sum[i] + k4[i]);
        }
    }
    out
}
