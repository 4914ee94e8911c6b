//! Modal analysis along the creep-coefficient sweep (Figs. 2-5 of the paper).
//!
//! For each analysis case ([`Case`], as `docs/model.md` defines them) and each creep
//! coefficient `f11 = f22` of the sweep, the closed loop is linearised at pure rolling
//! on straight track ([`crate::linear`]) and its eigenvalues computed (nalgebra, real
//! Schur form). Eigenvalues are tracked from point to point by continuity (greedy
//! nearest-neighbour assignment to a linear prediction), named once at the start of the
//! sweep (10 MN) from their participation factors `|w_k v_k|` (left and right
//! eigenvectors by inverse iteration), and instability crossings are located by
//! bisection on the creep coefficient.
//!
//! The structural zero eigenvalue (free rolling at any speed is an equilibrium) is
//! identified, reported separately as `rolling (structural zero)`, and excluded from
//! every stability verdict.
//!
//! Naming rules (at the highest creep of the sweep): the lateral/yaw-dominated
//! eigenvalue nearest the kinematic eigenvalue `j v sqrt(lambda/(r0 Lg))` is
//! `kinematic`; other lateral complex pairs are `high-frequency`; lateral real ones are
//! `high-frequency` (over-damped) when no other lateral pair exists, else
//! `lateral (real)`; then `torsional` / `longitudinal` (axle and speed states), `gear`,
//! `current loop`, `lead compensator`. Branches keep their names along the sweep, and
//! a mode's value is its least stable branch. Limitation: two real branches named
//! differently at the start that later merge into a complex pair keep both names.

use crate::control::YawLaw;
use crate::linear::closed_loop_a;
use crate::params::Params;
use crate::plant::{ix, STATE_NAMES};
use crate::scenario::Axle;
use nalgebra::{Complex, DMatrix, DVector};
use serde::Serialize;
use std::f64::consts::PI;

/// Name given to the structural zero eigenvalue.
pub const STRUCTURAL_ZERO: &str = "rolling (structural zero)";

/// The analysis cases of `docs/model.md`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub enum Case {
    /// (a) passive yaw spring, rigid axle, no traction dynamics.
    A,
    /// (b) active pure gain, rigid axle.
    B,
    /// (c) active phase lead, rigid axle, plus the compensator state.
    C,
    /// (d) phase lead, flexible axle (40 Hz), motor on its gear spring, armature, PI.
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

    /// Parses `a`..`d`.
    pub fn parse(s: &str) -> Option<Case> {
        Case::ALL.into_iter().find(|c| c.id() == s)
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
        let mut q = p.clone();
        q.f11 = creep;
        q.f22 = creep;
        let (axle, drive, law) = self.setup();
        closed_loop_a(&q, axle, drive, law)
    }
}

/// Eigenvalues of `a`. The matrix is first split into the strongly connected
/// components of its sparsity graph (after a symmetric permutation it is block
/// triangular, so its eigenvalues are those of the diagonal blocks: e.g. the rigid
/// axle's longitudinal motion decouples from the lateral one at pure rolling); each
/// block goes to nalgebra's real Schur form (implicit double-shift QR, no `Q`).
/// `None` if `a` has a non-finite entry.
pub fn eigenvalues(a: &DMatrix<f64>) -> Option<Vec<Complex<f64>>> {
    if !a.iter().all(|v| v.is_finite()) {
        return None;
    }
    let mut out = Vec::with_capacity(a.nrows());
    for block in components(a) {
        if let [i] = block[..] {
            out.push(Complex::new(a[(i, i)], 0.0));
            continue;
        }
        let m = DMatrix::from_fn(block.len(), block.len(), |i, j| a[(block[i], block[j])]);
        out.extend(m.complex_eigenvalues().iter().copied());
    }
    Some(out)
}

/// Strongly connected components of the graph `i -> j` for `a[(i, j)] != 0`
/// (Tarjan's algorithm; at most a few dozen nodes).
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

/// A mode's value at one point.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ModeValue {
    /// Mode name (`kinematic`, `high-frequency`, `torsional`, ...).
    pub name: String,
    /// Real part, 1/s.
    pub re: f64,
    /// Imaginary part (non-negative), rad/s.
    pub im: f64,
    /// Damped frequency `im / 2 pi`, Hz.
    pub freq_hz: f64,
    /// Damping ratio `-re / |lambda|` (1 for a stable real eigenvalue).
    pub zeta: f64,
}

impl ModeValue {
    fn new(name: &str, l: Complex<f64>) -> Self {
        let mag = l.norm();
        ModeValue {
            name: name.to_string(),
            re: l.re,
            im: l.im.abs(),
            freq_hz: l.im.abs() / (2.0 * PI),
            zeta: if mag > 0.0 { -l.re / mag } else { 0.0 },
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

/// Errors of a sweep.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepError(pub String);

impl std::fmt::Display for SweepError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.0)
    }
}

impl std::error::Error for SweepError {}

/// Assigns `new` eigenvalues to the `pred` branches: each branch takes its nearest new
/// eigenvalue when that is a one-to-one match (the usual case on a fine grid);
/// otherwise greedy nearest pairs first.
fn assign(pred: &[Complex<f64>], new: &[Complex<f64>]) -> Vec<Complex<f64>> {
    let n = pred.len();
    let mut out = vec![Complex::new(f64::NAN, f64::NAN); n];
    if new.len() == n {
        let mut taken = vec![false; n];
        let mut ok = true;
        for (i, p) in pred.iter().enumerate() {
            let j = (0..n)
                .min_by(|&x, &y| (new[x] - p).norm_sqr().total_cmp(&(new[y] - p).norm_sqr()))
                .unwrap_or(0);
            if taken[j] {
                ok = false;
                break;
            }
            taken[j] = true;
            out[i] = new[j];
        }
        if ok {
            return out;
        }
    }
    let mut pairs: Vec<(f64, usize, usize)> = Vec::with_capacity(n * new.len());
    for (i, p) in pred.iter().enumerate() {
        for (j, q) in new.iter().enumerate() {
            pairs.push(((p - q).norm_sqr(), i, j));
        }
    }
    pairs.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
    let mut used_b = vec![false; n];
    let mut used_e = vec![false; new.len()];
    for (_, i, j) in pairs {
        if !used_b[i] && !used_e[j] {
            out[i] = new[j];
            used_b[i] = true;
            used_e[j] = true;
        }
    }
    out
}

/// Right or left eigenvector for `lambda` by inverse iteration.
fn eigvec(a: &DMatrix<f64>, lambda: Complex<f64>, left: bool) -> DVector<Complex<f64>> {
    let n = a.nrows();
    let shift = lambda + Complex::new(1e-9 * (lambda.norm() + 1.0), 1e-9 * (lambda.norm() + 1.0));
    let m = DMatrix::from_fn(n, n, |i, j| {
        let v = if left { a[(j, i)] } else { a[(i, j)] };
        Complex::new(v, 0.0)
            - if i == j {
                shift
            } else {
                Complex::new(0.0, 0.0)
            }
    });
    let lu = m.lu();
    let mut x = DVector::from_fn(n, |i, _| Complex::new(1.0 + 0.1 * i as f64, 0.3));
    for _ in 0..3 {
        if let Some(y) = lu.solve(&x) {
            let nrm = y.norm();
            if nrm > 0.0 && nrm.is_finite() {
                x = y / Complex::new(nrm, 0.0);
            }
        }
    }
    x
}

/// Which physical group a state belongs to.
fn group(state: usize) -> usize {
    match state {
        ix::Y | ix::YD | ix::PSI | ix::PSID => 0,
        ix::WR | ix::WL | ix::TWIST | ix::V => 1,
        ix::WIND | ix::WM => 2,
        ix::IA | ix::PI => 3,
        _ => 4, // lead
    }
}

/// Names the eigenvalues of `a` (states `states`) from their participation factors;
/// `kin_omega` is the kinematic frequency `v sqrt(lambda/(r0 Lg))`, rad/s.
pub fn name_modes(
    a: &DMatrix<f64>,
    states: &[usize],
    eig: &[Complex<f64>],
    kin_omega: f64,
) -> Vec<String> {
    let n = eig.len();
    let mut names = vec![String::new(); n];
    // Structural zero: the smallest |lambda|, if it is numerically zero.
    let scale = a.amax().max(1.0);
    if let Some((iz, lz)) = eig
        .iter()
        .enumerate()
        .min_by(|x, y| x.1.norm().total_cmp(&y.1.norm()))
    {
        if lz.norm() < 1e-9 * scale {
            names[iz] = STRUCTURAL_ZERO.to_string();
        }
    }
    let mut dom = vec![0usize; n];
    for (i, &l) in eig.iter().enumerate() {
        let v = eigvec(a, l, false);
        let w = eigvec(a, l, true);
        let mut share = [0.0f64; 5];
        for (k, &s) in states.iter().enumerate() {
            share[group(s)] += (w[k] * v[k]).norm();
        }
        dom[i] = (0..5)
            .max_by(|&x, &y| share[x].total_cmp(&share[y]))
            .unwrap_or(0);
    }
    let tol = |l: Complex<f64>| 1e-7 * (l.norm() + 1.0);
    // Kinematic: the lateral-dominated eigenvalue nearest the free wheelset's kinematic
    // eigenvalue `j omega_k`; other lateral complex pairs are high-frequency.
    let kin = Complex::new(0.0, kin_omega);
    let kin_i = (0..n)
        .filter(|&i| names[i].is_empty() && dom[i] == 0 && eig[i].im >= 0.0)
        .min_by(|&x, &y| (eig[x] - kin).norm().total_cmp(&(eig[y] - kin).norm()));
    let mut taken: Vec<String> = Vec::new();
    let unique = |base: &str, taken: &mut Vec<String>| {
        let mut name = base.to_string();
        let mut k = 2;
        while taken.contains(&name) {
            name = format!("{base} {k}");
            k += 1;
        }
        taken.push(name.clone());
        name
    };
    if let Some(i) = kin_i {
        let name = unique("kinematic", &mut taken);
        names[i] = name.clone();
        if let Some(j) = (0..n).find(|&j| {
            j != i && names[j].is_empty() && (eig[j] - eig[i].conj()).norm() < tol(eig[i]) * 10.0
        }) {
            names[j] = name;
        }
    }
    // Remaining complex pairs first (so lateral pairs are `high-frequency`), then
    // real eigenvalues; real eigenvalues of one kind are one (over-damped) mode.
    let lateral_pair_left =
        (0..n).any(|i| names[i].is_empty() && dom[i] == 0 && eig[i].im.abs() > tol(eig[i]));
    let mut order: Vec<usize> = (0..n).filter(|&i| names[i].is_empty()).collect();
    order.sort_by_key(|&i| eig[i].im.abs() <= tol(eig[i]));
    for i in order {
        if !names[i].is_empty() {
            continue;
        }
        let complex = eig[i].im.abs() > tol(eig[i]);
        let base = match (dom[i], complex) {
            (0, true) => "high-frequency",
            (0, false) if !lateral_pair_left => "high-frequency",
            (0, false) => "lateral (real)",
            (1, true) => "torsional",
            (1, false) => "longitudinal",
            (2, _) => "gear",
            (3, _) => "current loop",
            _ => "lead compensator",
        };
        let name = if complex {
            unique(base, &mut taken)
        } else {
            if !taken.iter().any(|t| t == base) {
                taken.push(base.to_string());
            }
            base.to_string()
        };
        names[i] = name.clone();
        if complex {
            if let Some(j) = (0..n).find(|&j| {
                j != i
                    && names[j].is_empty()
                    && (eig[j] - eig[i].conj()).norm() < tol(eig[i]) * 10.0
            }) {
                names[j] = name;
            }
        }
    }
    names
}

/// Names of the state groups of [`ModeAtPoint::participation`], in order.
pub const GROUPS: [&str; 5] = ["lateral/yaw", "wheels", "gear/motor", "armature/PI", "lead"];

/// One mode of [`modes_at_point`]: its value and how much each state group takes part.
#[derive(Debug, Clone, PartialEq)]
pub struct ModeAtPoint {
    /// Name, eigenvalue, frequency, damping.
    pub mode: ModeValue,
    /// Participation of each group of [`GROUPS`]: the sum over the group's states of
    /// `|w_k v_k|` (left and right eigenvectors), normalised to sum to 1. A mode with
    /// two large shares is a coupled one (e.g. `beating`'s 8.1 Hz mode: lateral/yaw and
    /// gear/motor).
    pub participation: [f64; 5],
}

/// The named modes of one closed loop at its operating point (pure rolling on straight
/// track, the creep coefficients of `p`): the plant `axle`/`drive` with the yaw `law`, the
/// structural zero left out, one entry per complex pair (positive imaginary part) and
/// per real eigenvalue, least damped first. Each is `lambda = re + j im`, `freq_hz =
/// im / 2 pi`, `zeta = -re / |lambda|`. What `sim-host run` prints for a scenario's plant
/// (e.g. `beating`: the gear mode next to the kinematic mode, Fig. 9). `None` if the
/// eigenvalues are not computable (a non-finite matrix).
pub fn modes_at_point(
    p: &Params,
    axle: Axle,
    drive: bool,
    law: YawLaw,
) -> Option<Vec<ModeAtPoint>> {
    let (a, states) = closed_loop_a(p, axle, drive, law);
    let eig = eigenvalues(&a)?;
    let names = name_modes(&a, &states, &eig, 2.0 * PI * p.kinematic_hz());
    let mut out: Vec<ModeAtPoint> = eig
        .iter()
        .zip(&names)
        .filter(|(l, n)| *n != STRUCTURAL_ZERO && l.im >= 0.0)
        .map(|(&l, n)| {
            let v = eigvec(&a, l, false);
            let w = eigvec(&a, l, true);
            let mut share = [0.0f64; 5];
            for (k, &s) in states.iter().enumerate() {
                share[group(s)] += (w[k] * v[k]).norm();
            }
            let sum: f64 = share.iter().sum();
            if sum > 0.0 {
                share.iter_mut().for_each(|x| *x /= sum);
            }
            ModeAtPoint {
                mode: ModeValue::new(n, l),
                participation: share,
            }
        })
        .collect();
    out.sort_by(|x, y| x.mode.zeta.total_cmp(&y.mode.zeta));
    Some(out)
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
        self.mode_names()
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

/// Sweeps `case` over `grid` (ascending). Names modes at the highest creep, tracks
/// downwards, then finds the crossings by bisection. `tick` is called once per point
/// (from worker threads).
pub fn sweep_case(
    p: &Params,
    case: Case,
    grid: &[f64],
    tick: impl Fn() + Sync,
) -> Result<CaseSweep, SweepError> {
    let mut desc: Vec<f64> = grid.to_vec();
    desc.sort_by(|a, b| b.total_cmp(a));
    let Some(&top) = desc.first() else {
        return Err(SweepError("empty creep grid".into()));
    };
    let (a0, states) = case.matrix(p, top);
    // The eigenvalue problems are independent: solve them on all cores, then track.
    let all = eigen_sweep(p, case, &desc, &tick);
    let Some(e0) = all.first().cloned().flatten() else {
        return Err(SweepError(format!(
            "case {}: eigenvalues not computable at {top} N",
            case.id()
        )));
    };
    let names = name_modes(&a0, &states, &e0, 2.0 * PI * p.kinematic_hz());
    let mut eig: Vec<Vec<Complex<f64>>> = vec![e0];
    let mut creep = vec![top];
    let mut failed = Vec::new();
    for (&c, e) in desc.iter().zip(all).skip(1) {
        let Some(e) = e else {
            failed.push(c);
            continue;
        };
        let k = eig.len();
        let pred: Vec<Complex<f64>> = if k >= 2 {
            // linear extrapolation in creep
            let (c1, c2) = (creep[k - 1], creep[k - 2]);
            let s = (c - c1) / (c1 - c2);
            eig[k - 1]
                .iter()
                .zip(&eig[k - 2])
                .map(|(l1, l2)| l1 + (l1 - l2) * s)
                .collect()
        } else {
            eig[k - 1].clone()
        };
        eig.push(assign(&pred, &e));
        creep.push(c);
    }
    eig.reverse();
    creep.reverse();
    let mut sw = CaseSweep {
        case,
        states: states.iter().map(|&s| STATE_NAMES[s]).collect(),
        creep,
        eig,
        branch_names: names,
        crossings: Vec::new(),
        failed_points: failed,
    };
    sw.crossings = find_crossings(p, &sw);
    Ok(sw)
}

/// Eigenvalues at every creep value of `grid`, computed on up to
/// `available_parallelism` threads (scoped; no pool). `tick` is called once per point.
fn eigen_sweep(
    p: &Params,
    case: Case,
    grid: &[f64],
    tick: &(impl Fn() + Sync),
) -> Vec<Option<Vec<Complex<f64>>>> {
    let solve = |c: f64| {
        let r = eigenvalues(&case.matrix(p, c).0);
        tick();
        r
    };
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(grid.len() / 64)
        .max(1);
    if threads == 1 {
        return grid.iter().map(|&c| solve(c)).collect();
    }
    let chunk = grid.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let handles: Vec<_> = grid
            .chunks(chunk)
            .map(|part| scope.spawn(move || part.iter().map(|&c| solve(c)).collect::<Vec<_>>()))
            .collect();
        handles
            .into_iter()
            .flat_map(|h| {
                // A worker cannot panic on these inputs; if one did, its points count as failed.
                h.join().unwrap_or_else(|_| vec![None; chunk])
            })
            .take(grid.len())
            .collect()
    })
}

/// Locates sign changes of each mode's real part between adjacent points by bisection.
fn find_crossings(p: &Params, sw: &CaseSweep) -> Vec<Crossing> {
    let mut out = Vec::new();
    let least_stable = |branches: &[usize], k: usize| {
        branches
            .iter()
            .map(|&b| (b, sw.eig[k][b]))
            .max_by(|x, y| x.1.re.total_cmp(&y.1.re))
    };
    for name in sw.mode_names() {
        let branches: Vec<usize> = (0..sw.branch_names.len())
            .filter(|&b| sw.branch_names[b] == name)
            .collect();
        for k in 0..sw.creep.len().saturating_sub(1) {
            let (Some((b0, l0)), Some((b1, l1))) =
                (least_stable(&branches, k), least_stable(&branches, k + 1))
            else {
                continue;
            };
            if (l0.re > 0.0) == (l1.re > 0.0) {
                continue;
            }
            // Follow the branch that is unstable at its end.
            let b = if l0.re > 0.0 { b0 } else { b1 };
            let (mut lo, mut hi) = (sw.creep[k], sw.creep[k + 1]);
            let (mut vlo, mut vhi) = (sw.eig[k][b], sw.eig[k + 1][b]);
            let unstable_below = vlo.re > 0.0;
            for _ in 0..60 {
                if hi - lo <= 1e-7 * hi {
                    break;
                }
                let mid = 0.5 * (lo + hi);
                let guess = vlo + (vhi - vlo) * 0.5;
                let (a, _) = sw.case.matrix(p, mid);
                let Some(e) = eigenvalues(&a) else { break };
                let Some(&vm) = e
                    .iter()
                    .filter(|l| l.im.signum() == guess.im.signum() || l.im == 0.0)
                    .min_by(|x, y| (*x - guess).norm().total_cmp(&(*y - guess).norm()))
                else {
                    break;
                };
                if (vm.re > 0.0) == (vlo.re > 0.0) {
                    lo = mid;
                    vlo = vm;
                } else {
                    hi = mid;
                    vhi = vm;
                }
            }
            let at = if vlo.re.abs() < vhi.re.abs() {
                vlo
            } else {
                vhi
            };
            out.push(Crossing {
                creep_n: 0.5 * (lo + hi),
                freq_hz: at.im.abs() / (2.0 * PI),
                mode: name.clone(),
                unstable_below,
            });
        }
    }
    out.sort_by(|a, b| a.creep_n.total_cmp(&b.creep_n));
    out
}

/// JSON form of one point.
#[derive(Debug, Serialize)]
pub struct PointJson {
    /// `f11 = f22`, N.
    pub creep_n: f64,
    /// All eigenvalues `[re, im]` (including the structural zero).
    pub eigenvalues: Vec<[f64; 2]>,
    /// Named modes (structural zero excluded).
    pub modes: Vec<ModeValue>,
    /// The structural zero eigenvalue `[re, im]` (excluded from verdicts).
    pub structural_zero: Option<[f64; 2]>,
    /// Whether all modes are stable here (structural zero excluded).
    pub stable: bool,
}

/// JSON form of one case.
#[derive(Debug, Serialize)]
pub struct CaseJson {
    /// `a`..`d`.
    pub id: &'static str,
    /// Description.
    pub label: &'static str,
    /// Closed-loop states.
    pub states: Vec<&'static str>,
    /// Points, ascending creep.
    pub points: Vec<PointJson>,
    /// Instability crossings.
    pub crossings: Vec<Crossing>,
    /// Stable at every point of the sweep (structural zero excluded).
    pub stable_everywhere: bool,
    /// Creep values where the eigenvalue solver failed.
    pub failed_points: Vec<f64>,
}

impl CaseSweep {
    /// The JSON form.
    pub fn to_json(&self) -> CaseJson {
        let points: Vec<PointJson> = (0..self.creep.len())
            .map(|k| PointJson {
                creep_n: self.creep[k],
                eigenvalues: self.eig[k].iter().map(|l| [l.re, l.im]).collect(),
                modes: self.modes_at(k),
                structural_zero: self.structural_zero(k).map(|l| [l.re, l.im]),
                stable: self.stable_at(k),
            })
            .collect();
        CaseJson {
            id: self.case.id(),
            label: self.case.label(),
            states: self.states.clone(),
            stable_everywhere: points.iter().all(|p| p.stable),
            points,
            crossings: self.crossings.clone(),
            failed_points: self.failed_points.clone(),
        }
    }
}
