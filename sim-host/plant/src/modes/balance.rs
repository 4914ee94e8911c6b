//! Balancing ahead of the eigenvalue solver: LAPACK `dgebal`'s scaling with radix 2.

use nalgebra::DMatrix;

/// Scale factors stay within `2^+-256` of 1, so finite entries cannot overflow.
const FMAX: f64 = 1.157_920_892_373_162e77; // 2^256
/// Sweeps over the rows at most: the loop ends on any input.
const MAX_SWEEPS: usize = 64;

/// Balances the square matrix `a` in place: `A <- D^-1 A D`, `D` diagonal of powers of
/// two (exact: the eigenvalues are unchanged), row `i` scaled by `1/f` and column `i` by
/// `f` when that reduces `c + r` by 5 % (LAPACK `dgebal`'s loop, without its
/// permutation: the caller splits the matrix into irreducible blocks first).
pub(crate) fn balance(a: &mut DMatrix<f64>) {
    let n = a.nrows().min(a.ncols());
    for _ in 0..MAX_SWEEPS {
        let mut changed = false;
        for i in 0..n {
            let (mut c, mut r) = (0.0f64, 0.0f64);
            for k in (0..n).filter(|&k| k != i) {
                c += a[(k, i)].abs();
                r += a[(i, k)].abs();
            }
            if c == 0.0 || r == 0.0 || !(c + r).is_finite() {
                continue;
            }
            // f: the scale of column i; `cf = c f^2` follows it.
            let (mut f, mut cf) = (1.0, c);
            while cf < r / 2.0 && f < FMAX {
                f *= 2.0;
                cf *= 4.0;
            }
            while cf >= r * 2.0 && f > 1.0 / FMAX {
                f /= 2.0;
                cf /= 4.0;
            }
            if (cf + r) / f < 0.95 * (c + r) {
                changed = true;
                a.row_mut(i).scale_mut(1.0 / f);
                a.column_mut(i).scale_mut(f);
            }
        }
        if !changed {
            break;
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used)]
mod tests {
    use super::*;
    use nalgebra::Complex;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    /// The largest distance from each of `got` to the nearest of `want`.
    fn distance(got: &[Complex<f64>], want: &[Complex<f64>]) -> f64 {
        got.iter()
            .map(|g| {
                want.iter()
                    .map(|w| (g - w).norm())
                    .fold(f64::INFINITY, f64::min)
            })
            .fold(0.0, f64::max)
    }

    #[test]
    fn badly_scaled_matrices_are_balanced_exactly() {
        // B = D A D^-1 with D powers of two over 2^+-40: exactly similar to A, with
        // entries from 1e-24 to 1e24. Balancing brings the norm back near A's by an exact
        // diagonal similarity (each entry scaled by a power of two, the diagonal kept),
        // and B's eigenvalues come out as accurate as A's.
        let mut rng = Pcg64::seed_from_u64(3);
        for n in [3, 6, 9, 13] {
            let a = DMatrix::<f64>::from_fn(n, n, |_, _| rng.random_range(-1.0..1.0));
            let d: Vec<f64> = (0..n)
                .map(|_| 2f64.powi(rng.random_range(-40..=40)))
                .collect();
            let b = DMatrix::from_fn(n, n, |i, j| d[i] * a[(i, j)] / d[j]);
            assert!(b.norm() > 1e6 * a.norm());
            let mut bal = b.clone();
            balance(&mut bal);
            assert!(bal.norm() < 10.0 * a.norm(), "order {n}: {}", bal.norm());
            for i in 0..n {
                assert_eq!(bal[(i, i)], b[(i, i)]);
                for j in 0..n {
                    let ratio = bal[(i, j)] / b[(i, j)];
                    assert_eq!(ratio.log2().fract(), 0.0, "order {n} ({i}, {j}): {ratio}");
                }
            }
            let want: Vec<_> = a.complex_eigenvalues().iter().copied().collect();
            let got: Vec<_> = bal.complex_eigenvalues().iter().copied().collect();
            let d = distance(&got, &want);
            assert!(d < 1e-12 * a.norm(), "order {n}: {d:e}");
        }
    }

    #[test]
    fn balanced_and_unscalable_matrices_stay_as_they_are() {
        // Row and column norms already equal: no scaling.
        let sym = DMatrix::from_row_slice(3, 3, &[1.0, 2.0, 3.0, 2.0, 5.0, 4.0, 3.0, 4.0, 6.0]);
        let mut m = sym.clone();
        balance(&mut m);
        assert_eq!(m, sym);
        // A zero column off the diagonal, or a non-finite norm: left alone.
        let tri = DMatrix::from_row_slice(2, 2, &[1.0, 1e20, 0.0, 2.0]);
        let mut m = tri.clone();
        balance(&mut m);
        assert_eq!(m, tri);
        let big = DMatrix::from_row_slice(2, 2, &[0.0, f64::MAX, f64::MAX, 0.0]);
        let mut m = big.clone();
        balance(&mut m);
        assert_eq!(m, big);
    }
}
