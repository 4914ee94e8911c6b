//! Eigenvalues of a small dense real matrix, on the stack: balancing, reduction to upper
//! Hessenberg form by stabilised elimination, then the Francis implicit double-shift QR
//! iteration without the Schur vectors (EISPACK `balanc` + `elmhes` + `hqr`, with the
//! deflation test, shifts and 2x2 standardisation of LAPACK `dlahqr` / `dlanv2`).
//!
//! 1. Balancing (`balanc`'s scaling loop, radix 2): `A <- D^-1 A D` with `D` diagonal of
//!    powers of two, chosen so that each row and column have comparable off-diagonal
//!    1-norms. Powers of two make the similarity exact (no rounding), and the smaller
//!    norm bounds the rounding errors of the next steps. There is no permutation step:
//!    a matrix with isolated eigenvalues is first split into its irreducible diagonal
//!    blocks by the caller ([`crate::modes::eigenvalues`] does).
//! 2. Hessenberg reduction (`elmhes`): for each column `m - 1`, the largest entry at or
//!    below row `m` is swapped into row `m` (rows and columns, a permutation
//!    similarity), then row `i > m` loses `y = a[i][m-1] / a[m][m-1]` (`|y| <= 1`) times
//!    row `m` and column `m` gains `y` times column `i` (the inverse on the right).
//!    Zero multipliers are skipped, which the sparse closed-loop matrices profit from.
//! 3. QR iteration on the active window `H[l..=i, l..=i]`: a subdiagonal entry is set to
//!    zero when negligible (`dlahqr`'s test with the conservative criterion of Ahues &
//!    Kressner, relative to the neighbouring entries, which keeps small eigenvalues
//!    accurate); a trailing 1x1 block is a real eigenvalue, a 2x2 block a real or
//!    complex-conjugate pair (standardised as `dlanv2` does). Otherwise one double-shift
//!    step with the eigenvalues of the trailing 2x2 block as shifts (one of them twice
//!    when both are real): a bulge chased down by 3-element Householder reflectors from
//!    the top of the window (the textbook Francis step; `dlahqr` also looks for a lower
//!    start where two consecutive subdiagonals are small, which cost more in the search
//!    than it saved on these matrices of at most 16 states). The 10th, 30th,
//!    ... step without a deflation uses the exceptional shifts of the 2x2 block
//!    `[[d, -0.4375 s], [s, d]]`, `d = h[l][l] + 0.75 s` with `s` the window's first two
//!    subdiagonals; the 20th, 40th, ... the same from the last two and `h[i][i]`.
//!
//! Cost: about `5 n^3 / 3` flops for a dense reduction and `10 w^2` per QR step on a
//! window of order `w`, one to two steps per eigenvalue; no heap, no Schur vectors.

use nalgebra::Complex;

/// Largest order handled on the stack.
pub const MAX_ORDER: usize = 16;

/// QR steps allowed for a matrix of order `n`: `30 max(n, 10)` in all (as `dlahqr`
/// allows per deflated block).
fn step_budget(n: usize) -> usize {
    30 * n.max(10)
}

/// Unit roundoff times the base, `2^-52` (LAPACK `dlamch('P')`).
const ULP: f64 = f64::EPSILON;
/// Smallest normal number (LAPACK `dlamch('S')`).
const SAFE_MIN: f64 = f64::MIN_POSITIVE;

/// A real square matrix of order `n <= MAX_ORDER`, row-major on the stack.
#[derive(Debug, Clone)]
pub struct SmallMatrix {
    n: usize,
    a: [[f64; MAX_ORDER]; MAX_ORDER],
}

/// The eigenvalues of a [`SmallMatrix`]: `len()` values, on the stack.
#[derive(Debug, Clone, Copy)]
pub struct Eigenvalues {
    n: usize,
    values: [Complex<f64>; MAX_ORDER],
}

impl Eigenvalues {
    /// The eigenvalues as a slice.
    pub fn as_slice(&self) -> &[Complex<f64>] {
        &self.values[..self.n]
    }
}

impl std::ops::Deref for Eigenvalues {
    type Target = [Complex<f64>];
    fn deref(&self) -> &[Complex<f64>] {
        self.as_slice()
    }
}

/// Appends the eigenvalues of the `n x n` matrix with entries `f(i, j)` to `out`, as
/// `SmallMatrix::from_fn(n, f)?.eigenvalues()` gives them (the matrix built in place,
/// not moved); `None` (and `out` unchanged) when `n > MAX_ORDER` or when
/// [`SmallMatrix::eigenvalues`] returns `None`.
pub fn append_eigenvalues(
    n: usize,
    f: impl FnMut(usize, usize) -> f64,
    out: &mut Vec<Complex<f64>>,
) -> Option<()> {
    if n > MAX_ORDER {
        return None;
    }
    let mut m = SmallMatrix::filled(n, f);
    let l = m.eigenvalues_in_place()?;
    out.extend_from_slice(&l);
    Some(())
}

impl SmallMatrix {
    /// The `n x n` matrix with entries `f(i, j)`; `None` when `n > MAX_ORDER`.
    pub fn from_fn(n: usize, f: impl FnMut(usize, usize) -> f64) -> Option<Self> {
        (n <= MAX_ORDER).then(|| Self::filled(n, f))
    }

    /// [`Self::from_fn`] for `n <= MAX_ORDER` (a larger `n` is cut to `MAX_ORDER`).
    fn filled(n: usize, mut f: impl FnMut(usize, usize) -> f64) -> Self {
        let n = n.min(MAX_ORDER);
        let mut a = [[0.0; MAX_ORDER]; MAX_ORDER];
        for (i, row) in a.iter_mut().enumerate().take(n) {
            for (j, v) in row.iter_mut().enumerate().take(n) {
                *v = f(i, j);
            }
        }
        SmallMatrix { n, a }
    }

    /// The order `n`.
    pub fn order(&self) -> usize {
        self.n
    }

    /// The eigenvalues of the matrix (see the module doc for the algorithm).
    ///
    /// Returns the `n` eigenvalues in the order of the diagonal of the computed real
    /// Schur form, top to bottom: a complex-conjugate pair is adjacent, the one with the
    /// positive imaginary part first; a real eigenvalue has imaginary part `0.0`. They are
    /// the exact eigenvalues of a matrix within a small multiple of `eps ||A||` of `A`
    /// (the QR iteration is backward stable; the elimination's growth, bounded by the
    /// pivoting, is small in practice), so a well-conditioned eigenvalue is accurate to
    /// about `eps ||A||`.
    ///
    /// `None` when an entry is not finite (checked first), or when the QR iteration has
    /// not converged after `30 max(n, 10)` steps in all (not seen on a finite matrix:
    /// the exceptional shifts break the known cycles). Never panics.
    ///
    /// ```
    /// use wheelset_plant::eig::SmallMatrix;
    /// // x'' + 0.2 x' + 4 x = 0: lambda = -0.1 +- j sqrt(3.99).
    /// let a = SmallMatrix::from_fn(2, |i, j| [[0.0, 1.0], [-4.0, -0.2]][i][j]).unwrap();
    /// let l = a.eigenvalues().unwrap();
    /// assert!((l[0].re + 0.1).abs() < 1e-15 && (l[0].im - 3.99f64.sqrt()).abs() < 1e-15);
    /// assert_eq!(l[1], l[0].conj());
    /// ```
    pub fn eigenvalues(mut self) -> Option<Eigenvalues> {
        self.eigenvalues_in_place()
    }

    /// [`Self::eigenvalues`], leaving `self` overwritten (balanced, then reduced).
    fn eigenvalues_in_place(&mut self) -> Option<Eigenvalues> {
        let n = self.n;
        let mut out = Eigenvalues {
            n,
            values: [Complex::new(0.0, 0.0); MAX_ORDER],
        };
        if !self.balance() {
            return None;
        }
        self.hessenberg();
        self.hqr(&mut out.values)?;
        Some(out)
    }

    /// `balanc`'s scaling (no permutation): row and column `i` scaled by `1/f` and `f`
    /// (a power of 2) when that reduces `c + r` (the off-diagonal 1-norms of column and
    /// row `i`) by 5 %, sweeping `i` until no scaling is made. The diagonal is
    /// unchanged by the similarity: it is set aside meanwhile, so the norms are sums
    /// over whole rows and columns, found once and updated after each scaling.
    ///
    /// Returns `false`, the matrix unchanged, when an entry is not finite: the row
    /// norms, found first, tell (an entry that is not finite makes its row's norm
    /// infinite or NaN; only then are the entries themselves checked, since a norm
    /// can also overflow).
    fn balance(&mut self) -> bool {
        const RADIX: f64 = 2.0;
        const RADIX2: f64 = RADIX * RADIX;
        // Scale factors kept within 2^+-256 of 1 and sweeps bounded: finite entries
        // cannot overflow and the loop ends on any input.
        const FMAX: f64 = 1.157_920_892_373_162e77; // 2^256
        let n = self.n.min(MAX_ORDER);
        let a = &mut self.a;
        let mut diag = [0.0; MAX_ORDER];
        for (i, d) in diag[..n].iter_mut().enumerate() {
            *d = std::mem::take(&mut a[i][i]);
        }
        // c[k], r[k]: 1-norms of column k and row k (entries beyond n are zero: whole
        // rows of MAX_ORDER are summed), kept up to date through the scalings.
        let mut c = [0.0f64; MAX_ORDER];
        let mut r = [0.0f64; MAX_ORDER];
        for (row, rk) in a[..n].iter().zip(&mut r) {
            let mut acc = [0.0f64; 4];
            for (q, cq) in row.chunks_exact(4).zip(c.chunks_exact_mut(4)) {
                for t in 0..4 {
                    cq[t] += q[t].abs();
                    acc[t] += q[t].abs();
                }
            }
            *rk = (acc[0] + acc[1]) + (acc[2] + acc[3]);
        }
        let suspect = r[..n]
            .iter()
            .zip(&diag[..n])
            .fold(false, |s, (rk, d)| s | !(rk + d).is_finite());
        if suspect
            && (diag[..n].iter().any(|d| !d.is_finite())
                || a[..n]
                    .iter()
                    .any(|row| row[..n].iter().any(|v| !v.is_finite())))
        {
            for (i, d) in diag[..n].iter().enumerate() {
                a[i][i] = *d;
            }
            return false;
        }
        for _sweep in 0..64 {
            let mut changed = false;
            for i in 0..n {
                let (mut ci, ri) = (c[i], r[i]);
                if ci == 0.0 || ri == 0.0 {
                    continue;
                }
                let s = ci + ri;
                let mut f = 1.0;
                let g = ri / RADIX;
                while ci < g && f < FMAX {
                    f *= RADIX;
                    ci *= RADIX2;
                }
                let g = ri * RADIX;
                while ci >= g && f > 1.0 / FMAX {
                    f /= RADIX;
                    ci /= RADIX2;
                }
                if (ci + ri) / f < 0.95 * s {
                    changed = true;
                    let g = 1.0 / f;
                    // Row i by g: column k's norm changes by (g - 1) |a_ik|.
                    for (v, ck) in a[i].iter_mut().zip(&mut c) {
                        *ck += (g - 1.0) * v.abs();
                        *v *= g;
                    }
                    // Column i by f: row k's norm changes by (f - 1) |a_ki|.
                    for (row, rk) in a[..n].iter_mut().zip(&mut r) {
                        *rk += (f - 1.0) * row[i].abs();
                        row[i] *= f;
                    }
                    c[i] *= f;
                    r[i] *= g;
                }
            }
            if !changed {
                break;
            }
        }
        for (i, d) in diag[..n].iter().enumerate() {
            a[i][i] = *d;
        }
        true
    }

    /// Reduction to upper Hessenberg form by stabilised elementary similarity
    /// transformations (EISPACK `elmhes`: Gaussian elimination with partial pivoting,
    /// each multiplier at most 1 in magnitude). Zero entries are skipped, so a sparse
    /// matrix costs less than the `5 n^3 / 3` flops of a dense one.
    fn hessenberg(&mut self) {
        let n = self.n.min(MAX_ORDER);
        let a = &mut self.a;
        for m in 1..n.saturating_sub(1) {
            // Pivot: the largest |a[j][m-1]|, j >= m.
            let mut x = 0.0f64;
            let mut piv = m;
            for (j, row) in a[..n].iter().enumerate().skip(m) {
                if row[m - 1].abs() > x.abs() {
                    x = row[m - 1];
                    piv = j;
                }
            }
            if x == 0.0 {
                continue;
            }
            if piv != m {
                a.swap(piv, m);
                for row in &mut a[..n] {
                    row.swap(piv, m);
                }
            }
            for i in m + 1..n {
                let y = a[i][m - 1];
                if y == 0.0 {
                    continue;
                }
                let y = y / x;
                a[i][m - 1] = 0.0;
                // Row i -= y row m, then column m += y column i.
                let (top, rest) = a.split_at_mut(i);
                for (v, p) in rest[0][m..n].iter_mut().zip(&top[m][m..n]) {
                    *v -= y * p;
                }
                for row in &mut a[..n] {
                    row[m] += y * row[i];
                }
            }
        }
    }

    /// The double-shift QR iteration on the Hessenberg matrix (LAPACK `dlahqr` with
    /// `wantt = wantz = false`); writes the eigenvalues to `out[..n]`.
    fn hqr(&mut self, out: &mut [Complex<f64>; MAX_ORDER]) -> Option<()> {
        let n = self.n.min(MAX_ORDER);
        if n == 0 {
            return Some(());
        }
        let h = &mut self.a;
        // Entries below the first subdiagonal are zero after the reduction.
        let smlnum = SAFE_MIN * (n as f64 / ULP);
        let mut budget = step_budget(n);
        let mut since_deflation = 0usize;
        // Active window: rows/columns l..=i; everything below i is done.
        let mut i = n - 1;
        loop {
            // Find l: the lowest negligible subdiagonal in the window.
            let mut l = i;
            while l > 0 {
                let k = l;
                let sub = h[k][k - 1].abs();
                if sub <= smlnum {
                    break;
                }
                let mut tst = h[k - 1][k - 1].abs() + h[k][k].abs();
                if tst == 0.0 {
                    if k >= 2 {
                        tst += h[k - 1][k - 2].abs();
                    }
                    if k + 1 < n {
                        tst += h[k + 1][k].abs();
                    }
                }
                if sub <= ULP * tst {
                    let sup = h[k - 1][k].abs();
                    let (ab, ba) = (sub.max(sup), sub.min(sup));
                    let diff = (h[k - 1][k - 1] - h[k][k]).abs();
                    let hkk = h[k][k].abs();
                    let (aa, bb) = (hkk.max(diff), hkk.min(diff));
                    let s = aa + ab;
                    if ba * (ab / s) <= smlnum.max(ULP * (bb * (aa / s))) {
                        break;
                    }
                }
                l -= 1;
            }
            if l > 0 {
                h[l][l - 1] = 0.0;
            }
            if l == i {
                // A real eigenvalue.
                out[i] = Complex::new(h[i][i], 0.0);
                since_deflation = 0;
                if i == 0 {
                    return Some(());
                }
                i -= 1;
                continue;
            }
            if l + 1 == i {
                // A 2x2 block: a real or complex-conjugate pair.
                let (p, q) = standard_2x2(h[i - 1][i - 1], h[i - 1][i], h[i][i - 1], h[i][i]);
                out[i - 1] = p;
                out[i] = q;
                since_deflation = 0;
                if i < 2 {
                    return Some(());
                }
                i -= 2;
                continue;
            }
            if budget == 0 {
                return None;
            }
            budget -= 1;
            since_deflation += 1;

            // The two shifts, as the eigenvalues (rt1, rt2) of a 2x2 block.
            let (h11, h12, h21, h22) = if since_deflation.is_multiple_of(20) {
                let s = h[i][i - 1].abs() + h[i - 1][i - 2].abs();
                let d = 0.75 * s + h[i][i];
                (d, -0.4375 * s, s, d)
            } else if since_deflation.is_multiple_of(10) {
                let s = h[l + 1][l].abs() + h[l + 2][l + 1].abs();
                let d = 0.75 * s + h[l][l];
                (d, -0.4375 * s, s, d)
            } else {
                (h[i - 1][i - 1], h[i - 1][i], h[i][i - 1], h[i][i])
            };
            let s = h11.abs() + h12.abs() + h21.abs() + h22.abs();
            let (rt1r, rt1i, rt2r, rt2i) = if s == 0.0 {
                (0.0, 0.0, 0.0, 0.0)
            } else {
                let (h11, h12, h21, h22) = (h11 / s, h12 / s, h21 / s, h22 / s);
                let tr = (h11 + h22) / 2.0;
                let det = (h11 - tr) * (h22 - tr) - h12 * h21;
                let rtdisc = det.abs().sqrt();
                if det >= 0.0 {
                    // Complex pair.
                    (tr * s, rtdisc * s, tr * s, -rtdisc * s)
                } else {
                    // Real pair: use the one nearer h22 twice.
                    let (r1, r2) = (tr + rtdisc, tr - rtdisc);
                    let r = if (r1 - h22).abs() <= (r2 - h22).abs() {
                        r1
                    } else {
                        r2
                    };
                    (r * s, 0.0, r * s, 0.0)
                }
            };

            // The first column of (H - rt1)(H - rt2) in the window (three non-zero
            // entries), scaled by 1/rs against overflow, then normalised.
            let m = l;
            let rs = 1.0 / ((h[m][m] - rt2r).abs() + rt2i.abs() + h[m + 1][m].abs());
            let h21s = h[m + 1][m] * rs;
            let mut v = [
                h21s * h[m][m + 1] + (h[m][m] - rt1r) * ((h[m][m] - rt2r) * rs)
                    - rt1i * (rt2i * rs),
                h21s * (h[m][m] + h[m + 1][m + 1] - rt1r - rt2r),
                h21s * h[m + 2][m + 1],
            ];
            let rs = 1.0 / (v[0].abs() + v[1].abs() + v[2].abs());
            for x in &mut v {
                *x *= rs;
            }

            chase_bulge(h, l, i, v);
        }
    }
}

/// The double-shift step on the window `l..=i` (at least three rows) whose first
/// reflector maps `v` to a multiple of `e1`: the bulge is chased from `l` down to `i`
/// with reflectors of order 3 (the first from `v`, the next ones from the bulge in
/// column `k - 1`), then one of order 2 at `k = i - 1`. Kept out of line: the chase
/// then has the registers to itself.
///
/// Each reflector `P_k` is applied as `H <- P_k H P_k`: rows `k..k + 3` from the left
/// over columns `k..=i`, then columns `k..k + 3` from the right over rows
/// `l..=min(k + 3, i)`. Only the part the next reflector depends on is applied at
/// once: the left product on columns `k..k + 3` and the right one on rows
/// `k + 1..=min(k + 3, i)`. The rest (left on columns `k + 3..=i`, right on rows
/// `l..=k`) waits until the next reflector is computed, so that the processor can do
/// it during that reflector's square root and divisions; it still comes before
/// anything else that touches the same entries, so every entry sees the same
/// operations in the same order as with the whole products applied in turn.
#[inline(never)]
fn chase_bulge(h: &mut [[f64; MAX_ORDER]; MAX_ORDER], l: usize, i: usize, v: [f64; 3]) {
    // The reflector (k, t1, v2, v3) whose deferred part is still to apply.
    let mut pending = None;
    for k in l..i - 1 {
        let x = if k == l {
            v
        } else {
            [h[k][k - 1], h[k + 1][k - 1], h[k + 2][k - 1]]
        };
        let next = reflector(x);
        if let Some((k0, t1, v2, v3)) = pending.take() {
            apply_deferred3(h, k0, l, i, t1, v2, v3);
        }
        let Some((beta, t1, v2, v3)) = next else {
            continue;
        };
        if k > l {
            h[k][k - 1] = beta;
            h[k + 1][k - 1] = 0.0;
            h[k + 2][k - 1] = 0.0;
        }
        apply_leading3(h, k, i, t1, v2, v3);
        pending = Some((k, t1, v2, v3));
    }
    let k = i - 1;
    let next = reflector([h[k][k - 1], h[k + 1][k - 1], 0.0]);
    if let Some((k0, t1, v2, v3)) = pending {
        apply_deferred3(h, k0, l, i, t1, v2, v3);
    }
    if let Some((beta, t1, v2, _)) = next {
        h[k][k - 1] = beta;
        h[k + 1][k - 1] = 0.0;
        apply_reflector2(h, k, l, i, t1, v2);
    }
}

/// The leading part of `H <- P H P` for the reflector `P = I - t1 v v^T`, `v = [1, v2,
/// v3]` on rows and columns `k..k + 3` (`k + 2 <= i`): rows `k..k + 3` from the left
/// over columns `k..k + 3`, then columns `k..k + 3` from the right over rows
/// `k + 1..=min(k + 3, i)`.
#[inline(always)]
fn apply_leading3(
    h: &mut [[f64; MAX_ORDER]; MAX_ORDER],
    k: usize,
    i: usize,
    t1: f64,
    v2: f64,
    v3: f64,
) {
    let (t2, t3) = (t1 * v2, t1 * v3);
    left3(h, k, k..k + 3, [v2, v3], [t1, t2, t3]);
    let right = |row: &mut [f64; MAX_ORDER]| {
        if let [x, y, z] = &mut row[k..k + 3] {
            reflect3(x, y, z, [v2, v3], [t1, t2, t3]);
        }
    };
    // Straight-line code for the two or three rows.
    if k + 3 <= i {
        if let [_, a, b, c, ..] = &mut h[k..] {
            right(a);
            right(b);
            right(c);
        }
    } else if let [_, a, b, ..] = &mut h[k..] {
        right(a);
        right(b);
    }
}

/// The rest of `H <- P H P` after [`apply_leading3`]: rows `k..k + 3` from the left over
/// columns `k + 3..=i`, columns `k..k + 3` from the right over rows `l..=k`.
#[inline(always)]
fn apply_deferred3(
    h: &mut [[f64; MAX_ORDER]; MAX_ORDER],
    k: usize,
    l: usize,
    i: usize,
    t1: f64,
    v2: f64,
    v3: f64,
) {
    let (t2, t3) = (t1 * v2, t1 * v3);
    left3(h, k, (k + 3).min(i + 1)..i + 1, [v2, v3], [t1, t2, t3]);
    for row in &mut h[l..=k] {
        if let [x, y, z] = &mut row[k..k + 3] {
            reflect3(x, y, z, [v2, v3], [t1, t2, t3]);
        }
    }
}

/// `H <- P H P` in the window `l..=i` for the reflector `P = I - t1 v v^T`, `v = [1,
/// v2]` on rows and columns `k..k + 2` with `k + 1 = i`: rows from the left over columns
/// `k..=i`, then columns from the right over rows `l..=i`.
#[inline(always)]
fn apply_reflector2(
    h: &mut [[f64; MAX_ORDER]; MAX_ORDER],
    k: usize,
    l: usize,
    i: usize,
    t1: f64,
    v2: f64,
) {
    let t2 = t1 * v2;
    if let [r0, r1, ..] = &mut h[k..] {
        for (x, y) in r0[k..=i].iter_mut().zip(&mut r1[k..=i]) {
            reflect2(x, y, v2, [t1, t2]);
        }
    }
    for row in &mut h[l..=i] {
        if let [x, y] = &mut row[k..k + 2] {
            reflect2(x, y, v2, [t1, t2]);
        }
    }
}

/// One column (from the left) or row (from the right) of `P x` for the reflector
/// `P = I - t1 v v^T`, `v = [1, v2, v3]`: `s = x + v2 y + v3 z`, then `x -= s t1`,
/// `y -= s t1 v2`, `z -= s t1 v3` (`t = [t1, t1 v2, t1 v3]`).
#[inline(always)]
fn reflect3(x: &mut f64, y: &mut f64, z: &mut f64, [v2, v3]: [f64; 2], t: [f64; 3]) {
    let sum = *x + v2 * *y + v3 * *z;
    *x -= sum * t[0];
    *y -= sum * t[1];
    *z -= sum * t[2];
}

/// [`reflect3`] from the left on rows `k..k + 3`, over the columns `cols`.
#[inline(always)]
fn left3(
    h: &mut [[f64; MAX_ORDER]; MAX_ORDER],
    k: usize,
    cols: std::ops::Range<usize>,
    v: [f64; 2],
    t: [f64; 3],
) {
    if let [r0, r1, r2, ..] = &mut h[k..] {
        let (r0, r1, r2) = (&mut r0[cols.clone()], &mut r1[cols.clone()], &mut r2[cols]);
        for ((x, y), z) in r0.iter_mut().zip(r1).zip(r2) {
            reflect3(x, y, z, v, t);
        }
    }
}

/// [`reflect3`] for `v = [1, v2]` (`t = [t1, t1 v2]`).
#[inline(always)]
fn reflect2(x: &mut f64, y: &mut f64, v2: f64, t: [f64; 2]) {
    let sum = *x + v2 * *y;
    *x -= sum * t[0];
    *y -= sum * t[1];
}

/// An elementary reflector of order 3 (LAPACK `dlarfg`; order 2 when `x[2] = 0`):
/// returns `(beta, tau, v2, v3)` such that `(I - tau v v^T) x = [beta, 0, 0]` for
/// `v = [1, v2, v3]`; `None` when `x[1] = x[2] = 0` (no reflection needed).
#[inline]
fn reflector(x: [f64; 3]) -> Option<(f64, f64, f64, f64)> {
    // Within these bounds the plain sum of squares neither overflows nor underflows
    // and beta is far from the underflow threshold.
    const TINY: f64 = 1.0e-280;
    const HUGE: f64 = 1.0e280;
    let [a, x1, x2] = x;
    let ss = x1 * x1 + x2 * x2;
    if ss > TINY && ss < HUGE && a.abs() < 1.0e140 {
        let beta = -(a * a + ss).sqrt().copysign(a);
        let tau = (beta - a) / beta;
        let scale = 1.0 / (a - beta);
        return Some((beta, tau, x1 * scale, x2 * scale));
    }
    reflector_scaled(a, x1, x2)
}

/// [`reflector`] for entries near the overflow or underflow thresholds: `dlarfg` with
/// its scaled norm and rescaling.
///
/// The entries are passed one by one: they stay in registers (an array would be
/// stored to memory on every call of [`reflector`] for this rare path).
#[cold]
fn reflector_scaled(mut a: f64, mut x1: f64, mut x2: f64) -> Option<(f64, f64, f64, f64)> {
    let xnorm = norm2(x1, x2);
    if xnorm == 0.0 {
        return None;
    }
    let mut beta = -a.hypot(xnorm).copysign(a);
    // Rescale when beta would lose precision to underflow.
    let safmin = SAFE_MIN / ULP;
    let mut scaled = 0;
    while beta.abs() < safmin && scaled < 20 {
        scaled += 1;
        x1 /= safmin;
        x2 /= safmin;
        beta /= safmin;
        a /= safmin;
    }
    if scaled > 0 {
        beta = -a.hypot(norm2(x1, x2)).copysign(a);
    }
    let tau = (beta - a) / beta;
    let scale = 1.0 / (a - beta);
    for _ in 0..scaled {
        beta *= safmin;
    }
    Some((beta, tau, x1 * scale, x2 * scale))
}

/// `sqrt(x1^2 + x2^2)`, scaled against overflow and underflow.
fn norm2(x1: f64, x2: f64) -> f64 {
    x1.hypot(x2)
}

/// The eigenvalues of the 2x2 block `[[a, b], [c, d]]` as LAPACK `dlanv2` computes
/// them (standardising the block to a real Schur form), in the order of the
/// standardised diagonal: a real pair (for `a != d` and distinct eigenvalues, the first
/// on `a`'s side of their mean), or a complex pair `p + jq, p - jq` with `q > 0`.
fn standard_2x2(a: f64, b: f64, c: f64, d: f64) -> (Complex<f64>, Complex<f64>) {
    const MULTPL: f64 = 4.0;
    let eps = ULP / 2.0;
    // 2^-484 and 2^484 (dlanv2's SAFMN2, SAFMX2 for IEEE double).
    let safmn2 = (2.0f64).powi(-484);
    let safmx2 = 1.0 / safmn2;
    let real = |x: f64, y: f64| (Complex::new(x, 0.0), Complex::new(y, 0.0));
    if c == 0.0 {
        return real(a, d);
    }
    if b == 0.0 {
        // Swap rows and columns.
        return real(d, a);
    }
    if a - d == 0.0 && b.signum() != c.signum() {
        let q = b.abs().sqrt() * c.abs().sqrt();
        return (Complex::new(a, q), Complex::new(d, -q));
    }
    let temp = a - d;
    let p = 0.5 * temp;
    let bcmax = b.abs().max(c.abs());
    let bcmis = b.abs().min(c.abs()) * 1f64.copysign(b) * 1f64.copysign(c);
    let scale = p.abs().max(bcmax);
    let z = (p / scale) * p + (bcmax / scale) * bcmis;
    if z >= MULTPL * eps {
        // Real eigenvalues.
        let z = p + (scale.sqrt() * z.sqrt()).copysign(p);
        let a1 = d + z;
        let d1 = d - (bcmax / z) * bcmis;
        return real(a1, d1);
    }
    // Complex or nearly equal real eigenvalues: make the diagonal entries equal.
    let mut sigma = b + c;
    let mut temp = temp;
    for _ in 0..=20 {
        let scale = temp.abs().max(sigma.abs());
        if scale >= safmx2 {
            sigma *= safmn2;
            temp *= safmn2;
        } else if scale <= safmn2 {
            sigma *= safmx2;
            temp *= safmx2;
        } else {
            break;
        }
    }
    let p = 0.5 * temp;
    let tau = sigma.hypot(temp);
    let cs = (0.5 * (1.0 + sigma.abs() / tau)).sqrt();
    let sn = -(p / (tau * cs)) * 1f64.copysign(sigma);
    // [aa bb; cc dd] = [a b; c d] [cs -sn; sn cs]
    let (aa, bb) = (a * cs + b * sn, -a * sn + b * cs);
    let (cc, dd) = (c * cs + d * sn, -c * sn + d * cs);
    // [a b; c d] = [cs sn; -sn cs] [aa bb; cc dd]
    let b = bb * cs + dd * sn;
    let c = -aa * sn + cc * cs;
    let temp = 0.5 * ((aa * cs + cc * sn) + (-bb * sn + dd * cs));
    if c != 0.0 && b != 0.0 && b.signum() == c.signum() {
        // Real eigenvalues after all.
        let sab = b.abs().sqrt();
        let sac = c.abs().sqrt();
        let p = (sab * sac).copysign(c);
        return real(temp + p, temp - p);
    }
    if c == 0.0 || b == 0.0 {
        return real(temp, temp);
    }
    let q = b.abs().sqrt() * c.abs().sqrt();
    (Complex::new(temp, q), Complex::new(temp, -q))
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::expect_used)]
mod tests {
    use super::*;
    use crate::modes::{creep_grid, Case};
    use crate::params::Params;
    use nalgebra::DMatrix;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg64;

    fn small(a: &DMatrix<f64>) -> SmallMatrix {
        SmallMatrix::from_fn(a.nrows(), |i, j| a[(i, j)]).unwrap()
    }

    fn solve(a: &DMatrix<f64>) -> Vec<Complex<f64>> {
        small(a).eigenvalues().expect("converges").to_vec()
    }

    /// The oracle: nalgebra's real Schur form.
    fn oracle(a: &DMatrix<f64>) -> Vec<Complex<f64>> {
        a.complex_eigenvalues().iter().copied().collect()
    }

    /// `got` and `want` are the same multiset within `tol` (each of `got` matched to the
    /// nearest unmatched of `want`); returns the largest distance.
    fn assert_same(got: &[Complex<f64>], want: &[Complex<f64>], tol: f64, what: &str) -> f64 {
        assert_eq!(got.len(), want.len(), "{what}: count");
        let mut used = vec![false; want.len()];
        let mut worst: f64 = 0.0;
        for g in got {
            let (k, d) = want
                .iter()
                .enumerate()
                .filter(|(k, _)| !used[*k])
                .map(|(k, w)| (k, (g - w).norm()))
                .min_by(|x, y| x.1.total_cmp(&y.1))
                .unwrap();
            used[k] = true;
            assert!(d <= tol, "{what}: {g} is {d:e} from the nearest expected ({tol:e} allowed)\n got {got:?}\n want {want:?}");
            worst = worst.max(d);
        }
        worst
    }

    /// Conjugate pairs adjacent, positive imaginary part first; real ones exactly real.
    fn assert_pairs(l: &[Complex<f64>]) {
        let mut k = 0;
        while k < l.len() {
            if l[k].im == 0.0 {
                k += 1;
                continue;
            }
            assert!(l[k].im > 0.0 && k + 1 < l.len(), "pair order in {l:?}");
            assert_eq!(l[k + 1], l[k].conj(), "pair in {l:?}");
            k += 2;
        }
    }

    /// A random orthogonal matrix (product of reflectors).
    fn orthogonal(n: usize, rng: &mut Pcg64) -> DMatrix<f64> {
        let mut q = DMatrix::<f64>::identity(n, n);
        for _ in 0..3 {
            let u = DMatrix::<f64>::from_fn(n, 1, |_, _| rng.random_range(-1.0..1.0));
            let h = DMatrix::identity(n, n) - &u * u.transpose() * (2.0 / u.norm_squared());
            q = h * q;
        }
        q
    }

    #[test]
    fn random_matrices_of_orders_1_to_13_match_nalgebra() {
        let mut rng = Pcg64::seed_from_u64(0x5eed);
        let mut worst: f64 = 0.0;
        for n in 1..=13 {
            for trial in 0..40 {
                let a = DMatrix::<f64>::from_fn(n, n, |_, _| {
                    // Some exact zeros, as in the sparse closed-loop matrices.
                    if rng.random_bool(0.2) {
                        0.0
                    } else {
                        rng.random_range(-1.0..1.0)
                    }
                });
                let got = solve(&a);
                assert_pairs(&got);
                let tol = 1e-10 * a.norm();
                let d = assert_same(&got, &oracle(&a), tol, &format!("order {n}, trial {trial}"));
                worst = worst.max(d / a.norm());
            }
        }
        assert!(worst < 1e-12, "largest difference {worst:e} ||A||");
    }

    #[test]
    fn companion_matrix_has_the_polynomial_roots() {
        // (s + 1)(s + 2)(s - 0.5)(s^2 + 6 s + 10)(s - 4): roots -1, -2, 0.5, -3 +- j, 4.
        let roots = [
            Complex::new(-1.0, 0.0),
            Complex::new(-2.0, 0.0),
            Complex::new(0.5, 0.0),
            Complex::new(-3.0, 1.0),
            Complex::new(-3.0, -1.0),
            Complex::new(4.0, 0.0),
        ];
        // Coefficients of prod (s - r), highest first.
        let mut c = vec![Complex::new(1.0, 0.0)];
        for r in roots {
            let mut next = vec![Complex::new(0.0, 0.0); c.len() + 1];
            for (k, ck) in c.iter().enumerate() {
                next[k] += ck;
                next[k + 1] -= ck * r;
            }
            c = next;
        }
        let n = roots.len();
        let a = DMatrix::<f64>::from_fn(n, n, |i, j| {
            if i == 0 {
                -c[j + 1].re
            } else if i == j + 1 {
                1.0
            } else {
                0.0
            }
        });
        let got = solve(&a);
        assert_pairs(&got);
        assert_same(&got, &roots, 1e-10 * 4.0, "companion");
    }

    #[test]
    fn rotation_blocks_in_a_rotated_basis() {
        let mut rng = Pcg64::seed_from_u64(7);
        // Block diagonal: [[a, b], [-b, a]] blocks (a +- j b) and two real ones.
        let pairs = [(-0.1, 87.0), (-30.0, 2.0), (0.02, 1e-3), (-5.0, 5.0)];
        let n = 2 * pairs.len() + 2;
        let mut d = DMatrix::<f64>::zeros(n, n);
        let mut want = Vec::new();
        for (k, &(a, b)) in pairs.iter().enumerate() {
            let i = 2 * k;
            d[(i, i)] = a;
            d[(i + 1, i + 1)] = a;
            d[(i, i + 1)] = b;
            d[(i + 1, i)] = -b;
            want.push(Complex::new(a, b));
            want.push(Complex::new(a, -b));
        }
        d[(n - 2, n - 2)] = -700.0;
        d[(n - 1, n - 1)] = 0.0;
        want.push(Complex::new(-700.0, 0.0));
        want.push(Complex::new(0.0, 0.0));
        let q = orthogonal(n, &mut rng);
        let a = &q * d * q.transpose();
        let got = solve(&a);
        assert_pairs(&got);
        // A normal matrix: every eigenvalue is perfectly conditioned.
        assert_same(&got, &want, 1e-13 * a.norm(), "rotations");
    }

    #[test]
    fn defective_jordan_block_within_its_conditioning() {
        // J_4(2) in a rotated basis: computed eigenvalues spread by about
        // (eps ||A||)^(1/4).
        let mut rng = Pcg64::seed_from_u64(11);
        let mut j = DMatrix::<f64>::zeros(4, 4);
        for i in 0..4 {
            j[(i, i)] = 2.0;
            if i + 1 < 4 {
                j[(i, i + 1)] = 1.0;
            }
        }
        let q = orthogonal(4, &mut rng);
        let a = &q * j * q.transpose();
        let got = solve(&a);
        assert_pairs(&got);
        assert_same(&got, &[Complex::new(2.0, 0.0); 4], 1e-3, "Jordan");
        // Their mean is the well-conditioned trace / 4.
        let mean = got.iter().sum::<Complex<f64>>() / 4.0;
        assert!((mean - Complex::new(2.0, 0.0)).norm() < 1e-13);
    }

    #[test]
    fn badly_scaled_matrices_are_balanced_exactly() {
        // D A D^-1 with D powers of two over 2^+-40: exactly similar to A, with entries
        // from 1e-24 to 1e24; balancing undoes the scaling, so the eigenvalues are as
        // accurate as those of A itself.
        let mut rng = Pcg64::seed_from_u64(3);
        for n in [3, 6, 9, 13] {
            let a = DMatrix::<f64>::from_fn(n, n, |_, _| rng.random_range(-1.0..1.0));
            let d: Vec<f64> = (0..n)
                .map(|_| 2f64.powi(rng.random_range(-40..=40)))
                .collect();
            let b = DMatrix::from_fn(n, n, |i, j| d[i] * a[(i, j)] / d[j]);
            assert!(b.norm() > 1e6 * a.norm());
            let got = solve(&b);
            assert_pairs(&got);
            assert_same(
                &got,
                &oracle(&a),
                1e-12 * a.norm(),
                &format!("scaled, order {n}"),
            );
        }
    }

    #[test]
    fn cyclic_permutation_needs_the_exceptional_shifts() {
        // Standard shifts stall on the cyclic shift (every shift is 0); its
        // eigenvalues are the 4th roots of unity.
        let a = DMatrix::<f64>::from_fn(4, 4, |i, j| if i == (j + 1) % 4 { 1.0 } else { 0.0 });
        let got = solve(&a);
        assert_pairs(&got);
        let want = [
            Complex::new(1.0, 0.0),
            Complex::new(-1.0, 0.0),
            Complex::new(0.0, 1.0),
            Complex::new(0.0, -1.0),
        ];
        assert_same(&got, &want, 1e-14, "cyclic");
    }

    #[test]
    fn small_orders_and_refusals() {
        assert!(SmallMatrix::from_fn(0, |_, _| 1.0)
            .unwrap()
            .eigenvalues()
            .unwrap()
            .is_empty());
        let one = SmallMatrix::from_fn(1, |_, _| -3.5)
            .unwrap()
            .eigenvalues()
            .unwrap();
        assert_eq!(one.as_slice(), &[Complex::new(-3.5, 0.0)]);
        let zero = SmallMatrix::from_fn(5, |_, _| 0.0)
            .unwrap()
            .eigenvalues()
            .unwrap();
        assert!(zero.iter().all(|l| *l == Complex::new(0.0, 0.0)));
        // Upper triangular: the diagonal.
        let t = SmallMatrix::from_fn(4, |i, j| if j >= i { (1 + i + j) as f64 } else { 0.0 });
        let mut d: Vec<f64> = t
            .unwrap()
            .eigenvalues()
            .unwrap()
            .iter()
            .map(|l| l.re)
            .collect();
        d.sort_by(f64::total_cmp);
        assert_eq!(d, [1.0, 3.0, 5.0, 7.0]);
        assert!(SmallMatrix::from_fn(MAX_ORDER + 1, |_, _| 0.0).is_none());
        assert_eq!(
            SmallMatrix::from_fn(MAX_ORDER, |_, _| 0.0).unwrap().order(),
            MAX_ORDER
        );
        for bad in [f64::NAN, f64::INFINITY] {
            let m = SmallMatrix::from_fn(3, |i, j| if (i, j) == (1, 2) { bad } else { 1.0 });
            assert!(m.unwrap().eigenvalues().is_none());
        }
    }

    #[test]
    fn finite_entries_whose_row_norms_overflow_are_accepted() {
        // The row norm 2e308 overflows; the entries are finite, so the matrix is solved.
        let t = [[1e308, 1e308], [0.0, 1e308]];
        let l = SmallMatrix::from_fn(2, |i, j| t[i][j])
            .unwrap()
            .eigenvalues()
            .unwrap();
        assert_eq!(l.as_slice(), &[Complex::new(1e308, 0.0); 2]);
    }

    #[test]
    fn no_panic_on_extreme_finite_entries() {
        // Entries over the whole exponent range, zeros and subnormals included: the
        // solver returns (converged or not) and never panics; when the matrix is not
        // near overflow, the eigenvalues sum to the trace.
        let mut rng = Pcg64::seed_from_u64(99);
        for trial in 0..3000 {
            let n = rng.random_range(1..=MAX_ORDER);
            let e_max = rng.random_range(-320..=300);
            let m = SmallMatrix::from_fn(n, |_, _| match rng.random_range(0..10) {
                0..=2 => 0.0,
                3 => f64::MIN_POSITIVE / 8.0,
                _ => rng.random_range(-1.0..1.0) * 10f64.powi(rng.random_range(e_max - 20..=e_max)),
            })
            .unwrap();
            let trace: f64 = (0..n).map(|i| m.a[i][i]).sum();
            let scale = m.a.iter().flatten().fold(0.0f64, |s, v| s.max(v.abs()));
            if let Some(l) = m.eigenvalues() {
                if scale < 1e100 && scale > 1e-100 {
                    let sum: Complex<f64> = l.iter().sum();
                    assert!(
                        (sum.re - trace).abs() <= 1e-8 * scale * n as f64
                            && sum.im.abs() <= 1e-8 * scale * n as f64,
                        "trial {trial}: trace {trace}, sum {sum}"
                    );
                }
            }
        }
    }

    #[test]
    fn every_closed_loop_of_the_sweep_matches_nalgebra() {
        let p = Params::default();
        let mut worst: f64 = 0.0;
        for case in Case::ALL {
            for c in creep_grid(250) {
                let (a, _) = case.matrix(&p, c);
                let got = crate::modes::eigenvalues(&a).unwrap();
                let tol = 1e-10 * a.norm();
                let d = assert_same(
                    &got,
                    &oracle(&a),
                    tol,
                    &format!("case {}, {c} N", case.id()),
                );
                worst = worst.max(d / a.norm());
            }
        }
        assert!(worst < 1e-12, "largest difference {worst:e} ||A||");
    }
}
