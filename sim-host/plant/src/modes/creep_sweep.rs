//! The sweep of one case over the creep grid, and the crossings of the imaginary axis.

use super::*;
use crate::params::Params;
use crate::plant::STATE_NAMES;
use nalgebra::Complex;
use std::f64::consts::PI;

/// Sweeps `case` over `grid` (ascending): names modes at the highest creep, tracks
/// downwards, finds the crossings by bisection. `tick` is called once per point.
pub fn sweep_case(
    p: &Params,
    case: Case,
    grid: &[f64],
    tick: impl Fn() + Sync,
) -> Result<CaseSweep, String> {
    let mut desc: Vec<f64> = grid.to_vec();
    desc.sort_by(|a, b| b.total_cmp(a));
    let Some(&top) = desc.first() else {
        return Err("empty creep grid".into());
    };
    let (a0, states) = case.matrix(p, top);
    // The eigenvalue problems are independent: solve them on all cores, then track.
    let all = eigen_sweep(p, case, &desc, &tick);
    let Some(e0) = all.first().cloned().flatten() else {
        return Err(format!(
            "case {}: eigenvalues not computable at {top} N",
            case.id()
        ));
    };
    let names = name_modes(&a0, &states, &e0, 2.0 * PI * p.kinematic_hz());
    let mut eig: Vec<Vec<Complex<f64>>> = vec![e0];
    let mut creep = vec![top];
    let mut failed = Vec::new();
    let mut pred: Vec<Complex<f64>> = Vec::new();
    let mut tracked: Vec<Complex<f64>> = Vec::new();
    for (&c, e) in desc.iter().zip(all).skip(1) {
        let Some(mut e) = e else {
            failed.push(c);
            continue;
        };
        let k = eig.len();
        pred.clear();
        if k >= 2 {
            let (c1, c2) = (creep[k - 1], creep[k - 2]);
            let s = (c - c1) / (c1 - c2);
            pred.extend(
                eig[k - 1]
                    .iter()
                    .zip(&eig[k - 2])
                    .map(|(l1, l2)| l1 + (l1 - l2) * s),
            );
        } else {
            pred.extend_from_slice(&eig[k - 1]);
        }
        assign(&pred, &e, &mut tracked);
        e.clear();
        e.extend_from_slice(&tracked);
        eig.push(e);
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

/// Eigenvalues at every creep value of `grid`, on `available_parallelism` scoped threads.
fn eigen_sweep(
    p: &Params,
    case: Case,
    grid: &[f64],
    tick: &(impl Fn() + Sync),
) -> Vec<Option<Vec<Complex<f64>>>> {
    let solve = |(eig, lp): &mut (Eigen, CaseLoop), c: f64| {
        let mut out = Vec::new();
        let ok = eig.solve(lp.matrix(c), &mut out);
        tick();
        ok.then_some(out)
    };
    let workspace = || (Eigen::default(), CaseLoop::new(case, p));
    let threads = std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(grid.len() / 64)
        .max(1);
    if threads == 1 {
        let mut ws = workspace();
        return grid.iter().map(|&c| solve(&mut ws, c)).collect();
    }
    let chunk = grid.len().div_ceil(threads);
    std::thread::scope(|scope| {
        let handles: Vec<_> = grid
            .chunks(chunk)
            .map(|part| {
                scope.spawn(move || {
                    let mut ws = workspace();
                    part.iter().map(|&c| solve(&mut ws, c)).collect::<Vec<_>>()
                })
            })
            .collect();
        handles
            .into_iter()
            .flat_map(|h| h.join().unwrap_or_else(|_| vec![None; chunk]))
            .take(grid.len())
            .collect()
    })
}

/// Locates sign changes of each mode's real part between adjacent points by bisection.
fn find_crossings(p: &Params, sw: &CaseSweep) -> Vec<Crossing> {
    let mut out = Vec::new();
    let mut eig = Eigen::default();
    let mut lp = CaseLoop::new(sw.case, p);
    let mut e = Vec::new();
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
                if !eig.solve(lp.matrix(mid), &mut e) {
                    break;
                }
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
