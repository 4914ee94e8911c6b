//! Modal analysis along the creep-coefficient sweep (Figs. 2-5 of the paper): per case
//! ([`Case`]) and creep coefficient `f11 = f22`, the closed loop's eigenvalues at pure
//! rolling, tracked from point to point, named at the start of the sweep (10 MN) from
//! their participation factors (`modes/naming.rs`), crossings found by bisection. The
//! structural zero (free rolling) is reported apart and excluded from every verdict.

use crate::control::{ContinuousController, YawLaw};
use crate::linear::{closed_loop_a_into, closed_loop_states};
use crate::params::Params;
use crate::plant::PlantConfig;
use crate::scenario::Axle;
use nalgebra::{Complex, DMatrix};
use serde::Serialize;
use std::f64::consts::PI;

mod balance;
mod creep_sweep;
mod json;
mod naming;

pub use creep_sweep::*;
pub use json::*;
pub use naming::*;

/// Name given to the structural zero eigenvalue.
pub const STRUCTURAL_ZERO: &str = "rolling (structural zero)";

/// The analysis cases of `docs/model.md` (each one's figure: [`Case::label`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum Case {
    /// Passive yaw spring, rigid axle, no traction dynamics.
    A,
    /// Active pure gain, rigid axle.
    B,
    /// Active phase lead, rigid axle.
    C,
    /// Phase lead, flexible axle, gear spring, motor, armature, PI current loop.
    D,
}

impl Case {
    /// All four, in order.
    pub const ALL: [Case; 4] = [Case::A, Case::B, Case::C, Case::D];

    /// `a`..`d`.
    pub fn id(self) -> &'static str {
        match self {
            Case::A => "a",
            Case::B => "b",
            Case::C => "c",
            Case::D => "d",
        }
    }

    /// Human-readable description.
    pub fn label(self) -> &'static str {
        match self {
            Case::A => "passive yaw stiffness, rigid axle, no traction dynamics (Fig. 2)",
            Case::B => "active yaw damping, pure gain, rigid axle (Fig. 3)",
            Case::C => "active yaw damping, phase lead, rigid axle (Fig. 4)",
            Case::D => "phase lead, flexible axle 40 Hz, gear spring, motor, armature, PI (Fig. 5)",
        }
    }

    /// Plant and yaw law of the case.
    pub fn setup(self) -> (Axle, bool, YawLaw) {
        match self {
            Case::A => (Axle::Rigid, false, YawLaw::Passive),
            Case::B => (Axle::Rigid, false, YawLaw::Gain),
            Case::C => (Axle::Rigid, false, YawLaw::Lead),
            Case::D => (Axle::Flexible, true, YawLaw::Lead),
        }
    }

    /// The closed-loop `A` and its state list at creep coefficient `creep` (N).
    pub fn matrix(self, p: &Params, creep: f64) -> (DMatrix<f64>, Vec<usize>) {
        let mut lp = CaseLoop::new(self, p);
        (lp.matrix(creep).clone(), lp.states)
    }
}

/// [`Case::matrix`] for many creep coefficients: parameters, controller and states made once.
#[derive(Debug, Clone)]
pub(crate) struct CaseLoop {
    /// The parameters, creep coefficients set per point.
    q: Params,
    cfg: PlantConfig,
    ctrl: ContinuousController,
    states: Vec<usize>,
    a: DMatrix<f64>,
}

impl CaseLoop {
    pub(crate) fn new(case: Case, p: &Params) -> Self {
        let (axle, drive, law) = case.setup();
        let cfg = PlantConfig {
            axle,
            drive,
            yaw_spring: law.has_spring(),
        };
        CaseLoop {
            q: p.clone(),
            cfg,
            ctrl: ContinuousController::new(p, law),
            states: closed_loop_states(&cfg, law),
            a: DMatrix::zeros(0, 0),
        }
    }

    /// The closed-loop `A` at creep coefficient `creep` (N).
    pub(crate) fn matrix(&mut self, creep: f64) -> &DMatrix<f64> {
        self.q.f11 = creep;
        self.q.f22 = creep;
        closed_loop_a_into(&self.q, self.cfg, &self.ctrl, &self.states, &mut self.a);
        &self.a
    }
}

/// Eigenvalues of `a`: split into the strongly connected components of its sparsity graph
/// (block triangular after a permutation), each balanced (LAPACK `dgebal`'s scaling) and
/// solved by nalgebra's real Schur form; block by block, a complex pair adjacent (positive
/// imaginary part first). `None` if `a` has a non-finite entry or the QR does not converge.
pub fn eigenvalues(a: &DMatrix<f64>) -> Option<Vec<Complex<f64>>> {
    let mut out = Vec::with_capacity(a.nrows());
    Eigen::default().solve(a, &mut out).then_some(out)
}

/// Workspace of [`eigenvalues`] for a sweep: the components of the last sparsity
/// pattern are found again only when the pattern changes.
#[derive(Debug, Default)]
pub(crate) struct Eigen {
    /// Order of the last pattern.
    n: usize,
    /// `a[(i, j)] != 0` of the last matrix, column-major.
    pattern: Vec<bool>,
    /// Its strongly connected components.
    blocks: Vec<Vec<usize>>,
}

impl Eigen {
    /// Replaces `out` by the eigenvalues of `a` (see [`eigenvalues`]); false on failure.
    pub(crate) fn solve(&mut self, a: &DMatrix<f64>, out: &mut Vec<Complex<f64>>) -> bool {
        out.clear();
        out.reserve(a.nrows());
        let entries = a.as_slice();
        let n = a.nrows();
        // One pass without early exits (it vectorises): finiteness and the pattern.
        let (finite, same) = if n == self.n && self.pattern.len() == entries.len() {
            entries
                .iter()
                .zip(&self.pattern)
                .fold((true, true), |(fin, eq), (v, &nz)| {
                    (fin & v.is_finite(), eq & ((*v != 0.0) == nz))
                })
        } else {
            (
                entries.iter().fold(true, |fin, v| fin & v.is_finite()),
                false,
            )
        };
        if !finite {
            return false;
        }
        if !same {
            self.n = n;
            self.pattern.clear();
            self.pattern.extend(entries.iter().map(|v| *v != 0.0));
            self.blocks = components(a);
        }
        for block in &self.blocks {
            if !block_eigenvalues(a, block, out) {
                out.clear();
                return false;
            }
        }
        true
    }
}

/// Appends the eigenvalues of the block `a[block, block]` to `out`, at most
/// `30 max(k, 10)` QR steps for `k` states (LAPACK `dlahqr`'s allowance). False
/// (`out` unchanged) when it has not converged.
fn block_eigenvalues(a: &DMatrix<f64>, block: &[usize], out: &mut Vec<Complex<f64>>) -> bool {
    match *block {
        [] => true,
        [i] => {
            out.push(Complex::new(a[(i, i)], 0.0));
            true
        }
        _ => {
            let k = block.len();
            let mut m = DMatrix::from_fn(k, k, |i, j| a[(block[i], block[j])]);
            balance::balance(&mut m);
            nalgebra::Schur::try_new(m, f64::EPSILON, 30 * k.max(10))
                .map(|s| out.extend(s.complex_eigenvalues().iter().copied()))
                .is_some()
        }
    }
}

/// Strongly connected components of `i -> j` for `a[(i, j)] != 0` (Tarjan; a few dozen nodes).
fn components(a: &DMatrix<f64>) -> Vec<Vec<usize>> {
    struct T<'a> {
        a: &'a DMatrix<f64>,
        index: Vec<Option<usize>>,
        low: Vec<usize>,
        on: Vec<bool>,
        stack: Vec<usize>,
        next: usize,
        out: Vec<Vec<usize>>,
    }
    fn visit(t: &mut T, v: usize) {
        t.index[v] = Some(t.next);
        t.low[v] = t.next;
        t.next += 1;
        t.stack.push(v);
        t.on[v] = true;
        for w in 0..t.a.ncols() {
            if w == v || t.a[(v, w)] == 0.0 {
                continue;
            }
            match t.index[w] {
                None => {
                    visit(t, w);
                    t.low[v] = t.low[v].min(t.low[w]);
                }
                Some(iw) if t.on[w] => t.low[v] = t.low[v].min(iw),
                Some(_) => {}
            }
        }
        if Some(t.low[v]) == t.index[v] {
            let mut comp = Vec::new();
            while let Some(w) = t.stack.pop() {
                t.on[w] = false;
                comp.push(w);
                if w == v {
                    break;
                }
            }
            comp.sort_unstable();
            t.out.push(comp);
        }
    }
    let n = a.nrows();
    let mut t = T {
        a,
        index: vec![None; n],
        low: vec![0; n],
        on: vec![false; n],
        stack: Vec::with_capacity(n),
        next: 0,
        out: Vec::new(),
    };
    for v in 0..n {
        if t.index[v].is_none() {
            visit(&mut t, v);
        }
    }
    t.out
}

/// The sweep grid: `n` points evenly spaced over 1-10 MN, plus 1, 2, 5 and 10 MN
/// exactly (points within 1e-9 of those are snapped to them). Ascending.
pub fn creep_grid(n: usize) -> Vec<f64> {
    let n = n.max(2);
    let mut g: Vec<f64> = (0..n)
        .map(|k| 1e6 + 9e6 * k as f64 / (n - 1) as f64)
        .collect();
    for exact in [1e6, 2e6, 5e6, 1e7] {
        match g.iter_mut().find(|v| ((**v - exact) / exact).abs() < 1e-9) {
            Some(v) => *v = exact,
            None => g.push(exact),
        }
    }
    g.sort_by(f64::total_cmp);
    g.dedup();
    g
}

/// One instability crossing.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Crossing {
    /// Creep coefficient at which the mode's real part is zero, N.
    pub creep_n: f64,
    /// Mode frequency there, Hz.
    pub freq_hz: f64,
    /// Mode name.
    pub mode: String,
    /// True when the mode is unstable at lower creep than `creep_n`.
    pub unstable_below: bool,
}

/// A mode's value at one point (fields in alphabetical order: the JSON's keys sorted).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeValue {
    /// Damped frequency `im / 2 pi`, Hz.
    pub freq_hz: f64,
    /// Imaginary part (non-negative), rad/s.
    pub im: f64,
    /// Mode name (`kinematic`, `high-frequency`, `torsional`, ...).
    pub name: String,
    /// Real part, 1/s.
    pub re: f64,
    /// Damping ratio `-re / |lambda|` (1 for a stable real eigenvalue).
    pub zeta: f64,
}

impl ModeValue {
    fn new(name: &str, l: Complex<f64>) -> Self {
        ModeValue {
            name: name.to_string(),
            re: l.re,
            im: l.im.abs(),
            freq_hz: l.im.abs() / (2.0 * PI),
            zeta: crate::sampled::zeta_of(l),
        }
    }
}

/// The tracked sweep of one case.
#[derive(Debug, Clone)]
pub struct CaseSweep {
    /// The case.
    pub case: Case,
    /// State names of the closed loop.
    pub states: Vec<&'static str>,
    /// Creep coefficients, ascending, N.
    pub creep: Vec<f64>,
    /// Eigenvalues per point in tracked (branch) order.
    pub eig: Vec<Vec<Complex<f64>>>,
    /// Name of each branch (a complex pair shares a name).
    pub branch_names: Vec<String>,
    /// Instability crossings found by bisection.
    pub crossings: Vec<Crossing>,
    /// Points where the eigenvalue solver failed (skipped).
    pub failed_points: Vec<f64>,
}

impl CaseSweep {
    /// Unique mode names in order of first appearance (structural zero excluded).
    pub fn mode_names(&self) -> Vec<String> {
        let mut out: Vec<String> = Vec::new();
        for n in &self.branch_names {
            if n != STRUCTURAL_ZERO && !out.contains(n) {
                out.push(n.clone());
            }
        }
        out
    }

    /// The least stable eigenvalue of mode `name` at point `k` and its branch.
    pub fn mode_eig(&self, name: &str, k: usize) -> Option<(usize, Complex<f64>)> {
        self.branch_names
            .iter()
            .enumerate()
            .filter(|(_, n)| *n == name)
            .map(|(b, _)| (b, self.eig[k][b]))
            .max_by(|x, y| x.1.re.total_cmp(&y.1.re).then(x.1.im.total_cmp(&y.1.im)))
    }

    /// Every mode's value at point `k` (structural zero excluded).
    pub fn modes_at(&self, k: usize) -> Vec<ModeValue> {
        self.modes_named(&self.mode_names(), k)
    }

    /// [`Self::modes_at`] with the case's [`Self::mode_names`] given.
    fn modes_named(&self, names: &[String], k: usize) -> Vec<ModeValue> {
        names
            .iter()
            .filter_map(|n| self.mode_eig(n, k).map(|(_, l)| ModeValue::new(n, l)))
            .collect()
    }

    /// The structural zero eigenvalue at point `k`, if identified.
    pub fn structural_zero(&self, k: usize) -> Option<Complex<f64>> {
        self.branch_names
            .iter()
            .position(|n| n == STRUCTURAL_ZERO)
            .map(|b| self.eig[k][b])
    }

    /// Index of the point with creep coefficient `creep` (exact match).
    pub fn index_of(&self, creep: f64) -> Option<usize> {
        self.creep.iter().position(|&c| c == creep)
    }

    /// Whether every mode (structural zero excluded) is stable at point `k`.
    pub fn stable_at(&self, k: usize) -> bool {
        self.modes_at(k).iter().all(|m| m.re < 0.0)
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn eigenvalues_come_block_by_block_with_pairs_adjacent() {
        // A rotation block (-0.1 +- 87 j) feeding a real state (-700) and a companion
        // block of (s + 1)(s + 2)(s - 0.5) feeding the rotation: three components.
        let a = DMatrix::from_row_slice(
            6,
            6,
            &[
                -0.1, 87.0, 5.0, 0.0, 0.0, 0.0, //
                -87.0, -0.1, 0.0, 0.0, 0.0, 0.0, //
                0.0, 0.0, -700.0, 0.0, 0.0, 0.0, //
                1.0, 0.0, 0.0, -2.5, -0.5, 1.0, //
                0.0, 0.0, 0.0, 1.0, 0.0, 0.0, //
                0.0, 0.0, 0.0, 0.0, 1.0, 0.0, //
            ],
        );
        let l = eigenvalues(&a).unwrap();
        assert_eq!(l.len(), 6);
        let pair = l.iter().position(|z| z.im != 0.0).unwrap();
        assert!(l[pair].im > 0.0);
        assert_eq!(l[pair + 1], l[pair].conj());
        let want = [
            Complex::new(-0.1, 87.0),
            Complex::new(-0.1, -87.0),
            Complex::new(-700.0, 0.0),
            Complex::new(-1.0, 0.0),
            Complex::new(-2.0, 0.0),
            Complex::new(0.5, 0.0),
        ];
        for w in want {
            let d = l
                .iter()
                .map(|z| (z - w).norm())
                .fold(f64::INFINITY, f64::min);
            assert!(d < 1e-12 * 700.0, "{w}: {d:e} from the nearest of {l:?}");
        }
        assert_eq!(
            l.iter().filter(|z| z.re == -700.0 && z.im == 0.0).count(),
            1
        );
    }

    #[test]
    fn non_finite_matrices_are_refused() {
        for bad in [f64::NAN, f64::INFINITY] {
            let a = DMatrix::from_fn(3, 3, |i, j| if (i, j) == (1, 2) { bad } else { 1.0 });
            assert_eq!(eigenvalues(&a), None);
        }
        assert_eq!(eigenvalues(&DMatrix::zeros(0, 0)), Some(vec![]));
    }
}
