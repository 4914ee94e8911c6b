//! Guards of the linear algebra: every matrix finite before an eigenvalue or exponential
//! solver, the parameter to blame for a non-finite one, and a conditioning check: the
//! computed eigenvalues of `A` and `A^T` differ by about `kappa(lambda) eps ||A||`.

use crate::params::{Params, RANGES};
use nalgebra::{Complex, DMatrix};

/// Relative eigenvalue disagreement above which results are called ill-conditioned.
pub const ILL_CONDITIONED: f64 = 1e-6;

/// `Ok` when every entry of `m` is finite; else names `what` and the first bad entry.
pub fn check_finite(m: &DMatrix<f64>, what: &str) -> Result<(), String> {
    let Some(k) = m.iter().position(|v| !v.is_finite()) else {
        return Ok(());
    };
    let (i, j, v) = (k % m.nrows(), k / m.nrows(), m[k]);
    Err(format!(
        "{what} is not finite (entry ({i}, {j}) = {v}): not passed to the eigenvalue solver"
    ))
}

/// [`crate::modes::eigenvalues`] of `m`, refusing a non-finite entry or a QR not converged.
pub fn eigenvalues(m: &DMatrix<f64>, what: &str) -> Result<Vec<Complex<f64>>, String> {
    check_finite(m, what)?;
    crate::modes::eigenvalues(m)
        .ok_or_else(|| format!("{what}: the QR iteration for the eigenvalues did not converge"))
}

/// The largest difference between the eigenvalues of `a` and of `a^T` relative to
/// `|lambda|` (to `||A||` below `1e-9 ||A||`); `None` when `a` is not finite or empty.
pub fn eigen_disagreement(a: &DMatrix<f64>) -> Option<f64> {
    if a.is_empty() {
        return None;
    }
    let e1 = eigenvalues(a, "A").ok()?;
    let mut e2 = eigenvalues(&a.transpose(), "A^T").ok()?;
    let norm = a.norm();
    let mut worst: f64 = 0.0;
    for l in &e1 {
        let (k, d) = e2
            .iter()
            .enumerate()
            .map(|(k, m)| (k, (l - m).norm()))
            .min_by(|x, y| x.1.total_cmp(&y.1))?;
        e2.swap_remove(k);
        let scale = if l.norm() < 1e-9 * norm {
            norm
        } else {
            l.norm()
        };
        worst = worst.max(d / scale);
    }
    Some(worst)
}

/// When `build(p)` yields a non-finite matrix: the first parameter (in
/// [`RANGES`] order) whose default value alone makes every matrix finite again.
/// `None` when the matrices are finite, or no single parameter is to blame.
pub fn blame_nonfinite(
    p: &Params,
    build: impl Fn(&Params) -> Vec<DMatrix<f64>>,
) -> Option<&'static str> {
    let finite = |q: &Params| build(q).iter().all(|m| check_finite(m, "").is_ok());
    if finite(p) {
        return None;
    }
    let defaults = Params::default();
    RANGES.iter().map(|r| r.key).find(|&key| {
        let mut q = p.clone();
        reset(&mut q, &defaults, key);
        finite(&q)
    })
}

/// Sets `key` of `q` to its value in `defaults` (through the TOML names).
fn reset(q: &mut Params, defaults: &Params, key: &str) {
    let (Ok(mut t), Ok(d)) = (toml::Table::try_from(&*q), toml::Table::try_from(defaults)) else {
        return;
    };
    match d.get(key) {
        Some(v) => t.insert(key.to_string(), v.clone()),
        None => t.remove(key),
    };
    if let Ok(n) = t.try_into::<Params>() {
        *q = n;
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;

    #[test]
    fn blame_names_the_parameter_that_breaks_the_matrix() {
        let p = Params {
            l_a: 1e-320, // subnormal: R_a / L_a overflows to inf
            ..Params::default()
        };
        let build = |q: &Params| vec![DMatrix::from_row_slice(1, 1, &[-q.r_a / q.l_a])];
        assert_eq!(blame_nonfinite(&p, build), Some("l_a"));
        assert_eq!(blame_nonfinite(&Params::default(), build), None);
        assert!(eigenvalues(&build(&p)[0], "armature").is_err());
    }

    #[test]
    fn disagreement_is_small_for_a_well_posed_matrix_and_large_for_a_defective_one() {
        // A 6x6 Jordan block (eigenvalue -1, defective) in a rotated basis Q J Q with
        // the reflector Q = I - 2 u u^T / u^T u: dense and irreducible, so neither the
        // block split nor balancing makes it better conditioned; computed eigenvalues
        // spread by about eps^(1/6).
        let mut j = DMatrix::<f64>::zeros(6, 6);
        for i in 0..5 {
            j[(i, i + 1)] = 1.0;
            j[(i, i)] = -1.0;
        }
        j[(5, 5)] = -1.0;
        let u = nalgebra::DVector::from_fn(6, |i, _| 1.0 + i as f64);
        let q = DMatrix::identity(6, 6) - &u * u.transpose() * (2.0 / u.norm_squared());
        let a = &q * j * &q;
        assert!(eigen_disagreement(&a).unwrap() > ILL_CONDITIONED);
        let b = DMatrix::from_row_slice(2, 2, &[-1.0, 2.0, -3.0, -0.5]);
        assert!(eigen_disagreement(&b).unwrap() < 1e-12);
        // A triangular matrix splits into 1x1 blocks: its eigenvalues are exact.
        let mut t = DMatrix::<f64>::zeros(6, 6);
        for i in 0..5 {
            t[(i, i + 1)] = 1e4;
            t[(i, i)] = -1.0;
        }
        t[(5, 5)] = -1.0;
        assert_eq!(eigen_disagreement(&t), Some(0.0));
    }
}
