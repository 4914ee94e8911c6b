//! Following the eigenvalues along the creep sweep (assignment by nearness) and naming
//! each by the states it moves (participation of the right and left eigenvectors).

use super::*;
use crate::control::YawLaw;
use crate::linear::closed_loop_a;
use crate::params::Params;
use crate::plant::ix;
use crate::scenario::Axle;
use nalgebra::{Complex, DMatrix, DVector};
use std::f64::consts::PI;

/// Assigns `new` eigenvalues to the `pred` branches, into `out` (NaN for a branch left
/// without one): each branch its nearest when that is one-to-one (up to 128 branches),
/// otherwise greedy nearest pairs first.
pub(super) fn assign(pred: &[Complex<f64>], new: &[Complex<f64>], out: &mut Vec<Complex<f64>>) {
    let n = pred.len();
    out.clear();
    out.resize(n, Complex::new(f64::NAN, f64::NAN));
    if new.len() == n && n <= 128 {
        let mut taken = 0u128;
        let mut ok = true;
        for (i, p) in pred.iter().enumerate() {
            let j = nearest(*p, new);
            if taken & (1 << j) != 0 {
                ok = false;
                break;
            }
            taken |= 1 << j;
            out[i] = new[j];
        }
        if ok {
            return;
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
}

/// Index of the element of `new` nearest `p` (the first of equal ones); 0 if empty.
fn nearest(p: Complex<f64>, new: &[Complex<f64>]) -> usize {
    // `total_cmp`'s integer keys, mapped once per distance rather than per comparison.
    let key = |d: f64| {
        let b = d.to_bits() as i64;
        b ^ (((b >> 63) as u64) >> 1) as i64
    };
    let mut best = 0;
    let mut best_key = i64::MAX;
    for (j, q) in new.iter().enumerate() {
        let k = key((q - p).norm_sqr());
        if j == 0 || k < best_key {
            best = j;
            best_key = k;
        }
    }
    best
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

/// The participation of each group of [`GROUPS`] in the mode `lambda` of `a` (states
/// `states`): the sum over the group's states of `|w_k v_k|` (left and right eigenvectors).
fn participation(a: &DMatrix<f64>, states: &[usize], lambda: Complex<f64>) -> [f64; 5] {
    let v = eigvec(a, lambda, false);
    let w = eigvec(a, lambda, true);
    let mut share = [0.0f64; 5];
    for (k, &s) in states.iter().enumerate() {
        let group = match s {
            ix::Y | ix::YD | ix::PSI | ix::PSID => 0,
            ix::WR | ix::WL | ix::TWIST | ix::V => 1,
            ix::WIND | ix::WM => 2,
            ix::IA | ix::PI => 3,
            _ => 4, // lead
        };
        share[group] += (w[k] * v[k]).norm();
    }
    share
}

/// Which of the eigenvalues `eig` of `a` is the structural zero: the one of least
/// magnitude, if it is numerically zero (below `1e-9 max(max |a_ij|, 1)`).
pub(crate) fn structural_zero_index(a: &DMatrix<f64>, eig: &[Complex<f64>]) -> Option<usize> {
    let scale = a.amax().max(1.0);
    eig.iter()
        .enumerate()
        .min_by(|x, y| x.1.norm().total_cmp(&y.1.norm()))
        .filter(|(_, l)| l.norm() < 1e-9 * scale)
        .map(|(i, _)| i)
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
    if let Some(iz) = structural_zero_index(a, eig) {
        names[iz] = STRUCTURAL_ZERO.to_string();
    }
    let dom: Vec<usize> = eig
        .iter()
        .map(|&l| {
            let share = participation(a, states, l);
            (0..5)
                .max_by(|&x, &y| share[x].total_cmp(&share[y]))
                .unwrap_or(0)
        })
        .collect();
    let tol = |l: Complex<f64>| 1e-7 * (l.norm() + 1.0);
    // The unnamed conjugate of eigenvalue `i`, other than `i`.
    let partner = |names: &[String], i: usize| {
        (0..n).find(|&j| {
            j != i && names[j].is_empty() && (eig[j] - eig[i].conj()).norm() < tol(eig[i]) * 10.0
        })
    };
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
        if let Some(j) = partner(&names, i) {
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
        if let Some(j) = partner(&names, i).filter(|_| complex) {
            names[j] = name;
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
    /// Participation of each group of [`GROUPS`] (see `participation`), normalised to sum to 1.
    pub participation: [f64; 5],
}

/// The named modes of one closed loop at its operating point (pure rolling, the creep
/// coefficients of `p`), the structural zero left out, one entry per complex pair and
/// per real eigenvalue, least damped first. `None` for a non-finite matrix.
pub fn modes_at_point(
    p: &Params,
    axle: Axle,
    drive: bool,
    law: YawLaw,
) -> Option<Vec<ModeAtPoint>> {
    let (a, states) = closed_loop_a(p, axle, drive, &ContinuousController::new(p, law));
    let eig = eigenvalues(&a)?;
    let names = name_modes(&a, &states, &eig, 2.0 * PI * p.kinematic_hz());
    let mut out: Vec<ModeAtPoint> = eig
        .iter()
        .zip(&names)
        .filter(|(l, n)| *n != STRUCTURAL_ZERO && l.im >= 0.0)
        .map(|(&l, n)| {
            let mut share = participation(&a, &states, l);
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
