//! The matrix helpers, in one place: the pseudoinverse solve of the fundamental equation
//! (Cholesky of B Bᵀ, SVD fallback), least squares, null spaces, generalized
//! eigenvalues, the rank tolerance, and a Cholesky factorization of sparse Gram matrices
//! A W Aᵀ in envelope (skyline) storage.
//!
//! Every decomposition (SVD, symmetric eigen, Schur) goes through the guarded helpers
//! [`svd`], [`symmetric_eigen`] and [`complex_eigenvalues`]: finite input, capped
//! iterations, finite output, or a typed [`Failure`] (docs/reliability.md).
//!
//! nalgebra does the dense work. The envelope Cholesky is written by hand (about 80
//! lines): the constraint Gram matrix of a chain is banded, its structure is known when
//! the model is compiled and never changes, and it is factored on every right-hand side,
//! so it must not allocate; faer's sparse Cholesky needs its own matrix types, a symbolic
//! phase and ~60 s more of build for the same result on these sizes.

use nalgebra::Complex;
use nalgebra::{ComplexField, DMatrix, DVector, Dyn, SVD, SymmetricEigen};

use crate::failure::Failure;

// ---------------------------------------------------------------------------------------
// Guarded decompositions
// ---------------------------------------------------------------------------------------
//
// nalgebra's `svd`, `symmetric_eigen` and `Schur` iterate until convergence with no cap
// (`max_niter = 0`): on a NaN or an infinity they never return, and a NaN singular value
// panics in the sort. Every decomposition in detune goes through the helpers below: the
// input is checked finite first (a typed error naming the first bad entry), the iteration
// is capped (a typed error when the cap is reached), and the output is checked finite.

/// Iteration cap of the guarded decompositions: `ITER_PER_DIM` sweeps per row or column
/// (QR-type iterations need a few per eigenvalue; 100 is far above what a finite,
/// reasonably scaled matrix takes), at least 1000.
pub const ITER_PER_DIM: usize = 100;

fn max_iter(rows: usize, cols: usize) -> usize {
    (ITER_PER_DIM * rows.max(cols)).max(1000)
}

/// The first non-finite entry of `m` as a [`Failure::NonFiniteMatrix`], or `Ok`.
pub fn check_finite<T: ComplexField<RealField = f64>>(
    m: &DMatrix<T>,
    what: &str,
) -> Result<(), Failure> {
    // column-major: the first bad entry by column, then row
    for (k, col) in m.column_iter().enumerate() {
        for (i, v) in col.iter().enumerate() {
            if !v.is_finite() {
                return Err(Failure::NonFiniteMatrix {
                    what: what.to_string(),
                    row: i,
                    col: k,
                    value: format!("{v}"),
                });
            }
        }
    }
    Ok(())
}

/// SVD of a finite matrix, singular values sorted descending, iterations capped. `what`
/// names the matrix in errors ("constraint Jacobian").
pub fn svd<T: ComplexField<RealField = f64>>(
    m: DMatrix<T>,
    compute_u: bool,
    compute_v: bool,
    what: &str,
) -> Result<SVD<T, Dyn, Dyn>, Failure> {
    let mut svd = svd_unordered(m, compute_u, compute_v, what)?;
    svd.sort_by_singular_values();
    Ok(svd)
}

/// [`svd`] with the singular values in the order the iteration leaves them (nalgebra's
/// `SVD::new_unordered` at 5 ε, capped).
fn svd_unordered<T: ComplexField<RealField = f64>>(
    m: DMatrix<T>,
    compute_u: bool,
    compute_v: bool,
    what: &str,
) -> Result<SVD<T, Dyn, Dyn>, Failure> {
    check_finite(&m, what)?;
    let cap = max_iter(m.nrows(), m.ncols());
    let svd = SVD::try_new_unordered(m, compute_u, compute_v, 5.0 * f64::EPSILON, cap).ok_or_else(
        || Failure::NoConvergence {
            what: format!("SVD of the {what}"),
            iterations: cap,
        },
    )?;
    // finite input can still overflow inside (entries near 1e308)
    if let Some(s) = svd.singular_values.iter().find(|s| !s.is_finite()) {
        return Err(Failure::NonFiniteResult {
            quantity: format!("a singular value of the {what}"),
            value: *s,
        });
    }
    Ok(svd)
}

/// The pseudoinverse of a finite matrix (singular values below `eps` count as zero), the
/// SVD's iterations capped: the same numbers as nalgebra's `Matrix::pseudo_inverse` (its
/// unordered SVD at 5 ε), which iterates without a cap.
pub fn pseudo_inverse(m: DMatrix<f64>, eps: f64, what: &str) -> Result<DMatrix<f64>, Failure> {
    let svd = svd_unordered(m, true, true, what)?;
    svd.pseudo_inverse(eps)
        .map_err(|message| Failure::NonFiniteResult {
            quantity: format!("the pseudoinverse of the {what} ({message})"),
            value: f64::NAN,
        })
}

/// [`svd`] where the caller has no error path (a Jacobian's rank, a null vector): on
/// failure an SVD of NaNs of the right shapes, so that the NaN reaches the result and the
/// finiteness check of what is reported ([`crate::diag::check_finite_result`]).
pub fn svd_or_nan<T: ComplexField<RealField = f64>>(
    m: DMatrix<T>,
    compute_u: bool,
    compute_v: bool,
) -> SVD<T, Dyn, Dyn> {
    let (r, c) = m.shape();
    let k = r.min(c);
    svd(m, compute_u, compute_v, "matrix").unwrap_or_else(|_| {
        let nan = || T::from_real(f64::NAN);
        SVD {
            u: compute_u.then(|| DMatrix::from_fn(r, k, |_, _| nan())),
            v_t: compute_v.then(|| DMatrix::from_fn(k, c, |_, _| nan())),
            singular_values: DVector::from_element(k, f64::NAN),
        }
    })
}

/// Eigen-decomposition of a finite symmetric matrix, iterations capped.
pub fn symmetric_eigen(m: DMatrix<f64>, what: &str) -> Result<SymmetricEigen<f64, Dyn>, Failure> {
    check_finite(&m, what)?;
    let cap = max_iter(m.nrows(), m.ncols());
    let eig =
        SymmetricEigen::try_new(m, f64::EPSILON, cap).ok_or_else(|| Failure::NoConvergence {
            what: format!("eigenvalues of the {what}"),
            iterations: cap,
        })?;
    if let Some(v) = eig.eigenvalues.iter().find(|v| !v.is_finite()) {
        return Err(Failure::NonFiniteResult {
            quantity: format!("an eigenvalue of the {what}"),
            value: *v,
        });
    }
    Ok(eig)
}

/// [`symmetric_eigen`] where the caller has no error path: NaNs of the right shapes on
/// failure (see [`svd_or_nan`]).
pub fn symmetric_eigen_or_nan(m: DMatrix<f64>) -> SymmetricEigen<f64, Dyn> {
    let n = m.nrows();
    symmetric_eigen(m, "matrix").unwrap_or_else(|_| SymmetricEigen {
        eigenvectors: DMatrix::from_element(n, n, f64::NAN),
        eigenvalues: DVector::from_element(n, f64::NAN),
    })
}

/// Eigenvalues of a finite general real matrix (real Schur form, iterations capped).
pub fn complex_eigenvalues(m: DMatrix<f64>, what: &str) -> Result<Vec<Complex<f64>>, Failure> {
    check_finite(&m, what)?;
    let cap = max_iter(m.nrows(), m.ncols());
    let schur =
        nalgebra::Schur::try_new(m, f64::EPSILON, cap).ok_or_else(|| Failure::NoConvergence {
            what: format!("eigenvalues of the {what}"),
            iterations: cap,
        })?;
    let ev: Vec<Complex<f64>> = schur.complex_eigenvalues().iter().copied().collect();
    if let Some(v) = ev.iter().find(|v| !(v.re.is_finite() && v.im.is_finite())) {
        return Err(Failure::NonFiniteResult {
            quantity: format!("an eigenvalue of the {what}"),
            value: if v.re.is_finite() { v.im } else { v.re },
        });
    }
    Ok(ev)
}

/// Singular values below `RANK_TOL · σ_max` count as zero.
pub const RANK_TOL: f64 = 1e-10;

/// Cholesky pivots below `CHOL_TOL · max diag(B Bᵀ)` send the solve to the SVD.
pub const CHOL_TOL: f64 = 1e-10;

/// The largest |x_i|, NaN if any x_i is NaN (nalgebra's `amax` passes over a NaN).
pub fn amax(x: &[f64]) -> f64 {
    x.iter().fold(0.0f64, |a, v| {
        if v.is_nan() || a.is_nan() {
            f64::NAN
        } else {
            a.max(v.abs())
        }
    })
}

pub fn all_finite(x: &[f64]) -> bool {
    x.iter().all(|v| v.is_finite())
}

/// `x = B⁺ r` (minimum-norm least squares); returns the numerical rank of B.
pub fn pinv_solve(
    bm: &DMatrix<f64>,
    r: &DVector<f64>,
    gram: &mut DMatrix<f64>,
    svd_count: &mut usize,
) -> (DVector<f64>, usize) {
    let m = bm.nrows();
    if m == 0 {
        return (DVector::zeros(bm.ncols()), 0);
    }
    // NaN or inf (a force like sqrt(-1 - t), a diverging run): nalgebra's SVD never
    // returns on them. Pass the NaN on; the integrator's guard reports it with its time.
    if !all_finite(bm.as_slice()) || !all_finite(r.as_slice()) {
        return (DVector::from_element(bm.ncols(), f64::NAN), 0);
    }
    bm.mul_to(&bm.transpose(), gram);
    let scale = gram.diagonal().max();
    if let Some(ch) = gram.clone().cholesky() {
        let l = ch.l_dirty();
        let min_pivot = (0..m)
            .map(|i| l[(i, i)] * l[(i, i)])
            .fold(f64::INFINITY, f64::min);
        if min_pivot > CHOL_TOL * scale {
            let y = ch.solve(r);
            return (bm.transpose() * y, m);
        }
    }
    *svd_count += 1;
    let svd = svd_or_nan(bm.clone(), true, true);
    let smax = svd.singular_values.max();
    let eps = RANK_TOL * smax;
    let rank = svd.rank(eps);
    let x = svd
        .solve(r, eps)
        .unwrap_or_else(|_| DVector::zeros(bm.ncols()));
    (x, rank)
}

/// Minimum-norm least-squares solution of J x = r (SVD, relative rank tolerance).
pub fn solve_least_squares(j: DMatrix<f64>, r: &DVector<f64>) -> DVector<f64> {
    let cols = j.ncols();
    if cols == 0 || j.nrows() == 0 {
        // nothing to solve for, or no equation (nalgebra's SVD panics on an empty matrix)
        return DVector::zeros(cols);
    }
    if !all_finite(j.as_slice()) || !all_finite(r.as_slice()) {
        // undefined (nalgebra's SVD panics or never returns on NaN): pass the NaN on
        return DVector::from_element(cols, f64::NAN);
    }
    let svd = svd_or_nan(j, true, true);
    let eps = RANK_TOL * svd.singular_values.max().max(f64::MIN_POSITIVE);
    svd.solve(r, eps).unwrap_or_else(|_| DVector::zeros(cols))
}

/// [`solve_least_squares`] of J x = r with J's rows and columns equilibrated first (each
/// scaled by the inverse of its largest magnitude), and x scaled back: for systems whose
/// columns differ by many orders of magnitude (a solved stiffness against unit constraint
/// rows), which the rank-revealing solve would otherwise truncate.
pub fn solve_equilibrated(mut j: DMatrix<f64>, r: &DVector<f64>) -> DVector<f64> {
    let (nr, nc) = j.shape();
    let rs: Vec<f64> = (0..nr)
        .map(|i| 1.0 / j.row(i).amax().max(f64::MIN_POSITIVE))
        .collect();
    for (i, w) in rs.iter().enumerate() {
        j.row_mut(i).scale_mut(*w);
    }
    let cs: Vec<f64> = (0..nc)
        .map(|k| 1.0 / j.column(k).amax().max(f64::MIN_POSITIVE))
        .collect();
    for (k, w) in cs.iter().enumerate() {
        j.column_mut(k).scale_mut(*w);
    }
    let rr = DVector::from_fn(nr, |i, _| r[i] * rs[i]);
    let mut dx = solve_least_squares(j, &rr);
    for (k, w) in cs.iter().enumerate() {
        dx[k] *= w;
    }
    dx
}

/// Orthonormal basis of the null space of a matrix A (n × (n − rank)), from the SVD.
pub fn null_space_of(a: &DMatrix<f64>) -> DMatrix<f64> {
    let n = a.ncols();
    if a.nrows() == 0 {
        return DMatrix::identity(n, n);
    }
    // SVD of Aᵀ A (n × n) gives the full right singular basis even when m < n.
    let ata = a.transpose() * a;
    let Ok(eig) = symmetric_eigen(ata, "matrix AᵀA") else {
        return DMatrix::from_element(n, 1, f64::NAN);
    };
    let max = eig.eigenvalues.iter().fold(0.0f64, |a, v| a.max(v.abs()));
    let cols: Vec<usize> = (0..n)
        .filter(|&i| eig.eigenvalues[i].abs() <= RANK_TOL * max.max(f64::MIN_POSITIVE))
        .collect();
    let mut nb = eig.eigenvectors.select_columns(cols.iter());
    // a deterministic sign: largest entry of each column positive
    for mut c in nb.column_iter_mut() {
        let imax = c.iamax();
        if c[imax] < 0.0 {
            c.neg_mut();
        }
    }
    nb
}

/// Eigenvalues of M⁻¹ K for symmetric positive definite M (ascending). K is symmetrized;
/// a nonsymmetric K (follower loads) gives the real parts of the general eigenvalues.
pub fn generalized_eigenvalues(k: &DMatrix<f64>, m: &DMatrix<f64>) -> Vec<f64> {
    if k.nrows() == 0 {
        return Vec::new(); // no degree of freedom
    }
    if !all_finite(k.as_slice()) || !all_finite(m.as_slice()) {
        return vec![f64::NAN; k.nrows()];
    }
    let asym = (k - k.transpose()).amax();
    let mut w: Vec<f64> = if asym <= 1e-9 * k.amax().max(f64::MIN_POSITIVE) {
        let l = m
            .clone()
            .cholesky()
            .expect("mass matrix is positive definite")
            .l();
        let linv = l.clone().try_inverse().expect("invertible");
        let s = &linv * (k + k.transpose()) * 0.5 * linv.transpose();
        match symmetric_eigen(s, "matrix M⁻¹K") {
            Ok(e) => e.eigenvalues.iter().copied().collect(),
            Err(_) => vec![f64::NAN; k.nrows()],
        }
    } else {
        let minv = m.clone().try_inverse().expect("invertible");
        match complex_eigenvalues(minv * k, "matrix M⁻¹K") {
            Ok(e) => e.iter().map(|c| c.re).collect(),
            Err(_) => vec![f64::NAN; k.nrows()],
        }
    };
    w.sort_by(f64::total_cmp);
    w
}

/// A symmetric matrix in envelope (skyline) storage, factored in place as L Lᵀ: row i
/// holds columns `first[i]..=i`. A banded Gram matrix (a chain's constraints) costs
/// O(m · bandwidth²) to factor and O(m · bandwidth) to solve, without allocating.
#[derive(Debug, Clone)]
pub struct Envelope {
    first: Vec<usize>,
    start: Vec<usize>,
    /// The entries, row by row.
    vals: Vec<f64>,
}

impl Envelope {
    /// An envelope whose row i starts at column `first[i]` (≤ i).
    pub fn new(first: Vec<usize>) -> Envelope {
        let mut start = Vec::with_capacity(first.len());
        let mut len = 0;
        for (i, &f) in first.iter().enumerate() {
            debug_assert!(f <= i);
            start.push(len);
            len += i + 1 - f;
        }
        Envelope {
            first,
            start,
            vals: vec![0.0; len],
        }
    }

    pub fn dim(&self) -> usize {
        self.first.len()
    }

    #[inline(always)]
    fn idx(&self, i: usize, j: usize) -> usize {
        self.start[i] + j - self.first[i]
    }

    pub fn clear(&mut self) {
        self.vals.fill(0.0);
    }

    /// How many entries the envelope stores.
    pub fn len(&self) -> usize {
        self.vals.len()
    }

    pub fn is_empty(&self) -> bool {
        self.vals.is_empty()
    }

    /// The stored entries, row by row (entry (i, j) at [`Envelope::index`]), to be
    /// written before [`Envelope::factor`].
    pub fn values_mut(&mut self) -> &mut [f64] {
        &mut self.vals
    }

    /// Where entry (i, j), j ≤ i, inside the envelope is stored (in
    /// [`Envelope::values_mut`]).
    pub fn index(&self, i: usize, j: usize) -> usize {
        self.idx(i, j)
    }

    /// Add v to entry (i, j), j ≤ i, inside the envelope.
    #[inline(always)]
    pub fn add(&mut self, i: usize, j: usize, v: f64) {
        let k = self.idx(i, j);
        self.vals[k] += v;
    }

    /// Factor in place. Fails (returns false, the contents then undefined) when a pivot
    /// L_ii² falls below `tol` times the largest diagonal entry, or on non-finite input:
    /// the matrix is then singular or ill-conditioned for this purpose.
    pub fn factor(&mut self, tol: f64) -> bool {
        let m = self.dim();
        let scale = (0..m)
            .map(|i| self.vals[self.idx(i, i)])
            .fold(0.0f64, f64::max);
        if !(scale > 0.0) || !scale.is_finite() {
            return false;
        }
        // row by row on slices (no index arithmetic or bounds checks in the inner
        // products); the same operations in the same order as entry by entry
        for i in 0..m {
            let fi = self.first[i];
            let (done, rest) = self.vals.split_at_mut(self.start[i]);
            let row = &mut rest[..i + 1 - fi];
            for j in fi..i {
                let fj = self.first[j];
                let k0 = fi.max(fj);
                let rj = &done[self.start[j]..self.start[j] + j + 1 - fj];
                let mut s = row[j - fi];
                for (a, b) in row[k0 - fi..j - fi].iter().zip(&rj[k0 - fj..j - fj]) {
                    s -= a * b;
                }
                row[j - fi] = s / rj[j - fj];
            }
            let (off, diag) = row.split_at_mut(i - fi);
            let mut s = diag[0];
            for a in off.iter() {
                s -= a * a;
            }
            if !(s > tol * scale) {
                return false;
            }
            diag[0] = s.sqrt();
        }
        true
    }

    /// Solve L Lᵀ x = r in place (after [`Envelope::factor`]).
    pub fn solve(&self, r: &mut [f64]) {
        let m = self.dim();
        for i in 0..m {
            let fi = self.first[i];
            let row = &self.vals[self.start[i]..self.start[i] + i + 1 - fi];
            let (head, tail) = r.split_at_mut(i);
            let mut s = tail[0];
            for (a, x) in row[..i - fi].iter().zip(&head[fi..]) {
                s -= a * x;
            }
            tail[0] = s / row[i - fi];
        }
        for i in (0..m).rev() {
            let fi = self.first[i];
            let row = &self.vals[self.start[i]..self.start[i] + i + 1 - fi];
            let (head, tail) = r.split_at_mut(i);
            tail[0] /= row[i - fi];
            let ri = tail[0];
            for (x, a) in head[fi..].iter_mut().zip(&row[..i - fi]) {
                *x -= a * ri;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Issue 13 audit A1: the capped pseudoinverse gives nalgebra's uncapped numbers to the
    /// bit on a finite rank-deficient matrix, and a typed error (not an endless iteration)
    /// on a NaN; the monodromy's multipliers of a NaN matrix are NaN, returned.
    #[test]
    fn capped_pseudo_inverse_and_multipliers_match_nalgebra_and_refuse_nan() {
        let a = DMatrix::from_row_slice(2, 3, &[1.0, 2.0, 3.0, 2.0, 4.0, 6.000001]);
        let ours = pseudo_inverse(a.clone(), 1e-14, "test matrix").unwrap();
        let theirs = a.clone().pseudo_inverse(1e-14).unwrap();
        assert_eq!(ours.as_slice(), theirs.as_slice());
        // A A⁺ A = A (a second property, independent of nalgebra's numbers)
        assert!((&a * &ours * &a - &a).amax() < 1e-6);
        let mut bad = a.clone();
        bad[(1, 2)] = f64::NAN;
        assert!(matches!(
            pseudo_inverse(bad, 1e-14, "test matrix"),
            Err(Failure::NonFiniteMatrix { row: 1, col: 2, .. })
        ));
        let m = DMatrix::from_row_slice(2, 2, &[0.0, 1.0, -2.0, -0.1]);
        let mut mu = crate::periodic::multipliers(&m);
        let mut theirs: Vec<Complex<f64>> = m.complex_eigenvalues().iter().copied().collect();
        let key = |a: &Complex<f64>, b: &Complex<f64>| {
            b.norm().total_cmp(&a.norm()).then(b.im.total_cmp(&a.im))
        };
        mu.sort_by(key);
        theirs.sort_by(key);
        assert_eq!(mu, theirs);
        let nan = DMatrix::from_element(2, 2, f64::NAN);
        assert!(
            crate::periodic::multipliers(&nan)
                .iter()
                .all(|z| z.re.is_nan())
        );
    }

    #[test]
    fn envelope_cholesky_solves_a_banded_system_like_nalgebra() {
        // a random-ish banded SPD matrix with an irregular profile
        let m = 9;
        let first: Vec<usize> = (0..m).map(|i: usize| i.saturating_sub(1 + i % 3)).collect();
        let mut dense = DMatrix::zeros(m, m);
        for i in 0..m {
            for j in first[i]..i {
                let v = ((i * 7 + j * 3) % 5) as f64 * 0.1 - 0.2;
                dense[(i, j)] = v;
                dense[(j, i)] = v;
            }
            dense[(i, i)] = 2.0 + i as f64 * 0.1;
        }
        let mut env = Envelope::new(first.clone());
        for i in 0..m {
            for j in first[i]..=i {
                env.add(i, j, dense[(i, j)]);
            }
        }
        assert!(env.factor(1e-12));
        let r: Vec<f64> = (0..m).map(|i| (i as f64).sin()).collect();
        let mut x = r.clone();
        env.solve(&mut x);
        let want = dense
            .clone()
            .cholesky()
            .unwrap()
            .solve(&DVector::from_vec(r));
        for i in 0..m {
            assert!(
                (x[i] - want[i]).abs() <= 1e-14,
                "{i}: {} vs {}",
                x[i],
                want[i]
            );
        }
        // singular: refused
        let mut sing = Envelope::new(vec![0, 0]);
        sing.add(0, 0, 1.0);
        sing.add(1, 0, 1.0);
        sing.add(1, 1, 1.0);
        assert!(!sing.factor(1e-10));
    }

    #[test]
    fn guarded_decompositions_refuse_non_finite_input() {
        let mut m = DMatrix::from_row_slice(2, 2, &[3.0, 1.0, 1.0, 2.0]);
        // a finite matrix: the closed-form eigenvalues (5 ± √5)/2 and singular values
        let e = symmetric_eigen(m.clone(), "test").unwrap();
        let mut ev: Vec<f64> = e.eigenvalues.iter().copied().collect();
        ev.sort_by(f64::total_cmp);
        assert!((ev[0] - (5.0 - 5f64.sqrt()) / 2.0).abs() < 1e-14);
        assert!((ev[1] - (5.0 + 5f64.sqrt()) / 2.0).abs() < 1e-14);
        let sv = svd(m.clone(), true, true, "test").unwrap().singular_values;
        assert!((sv[0] - (5.0 + 5f64.sqrt()) / 2.0).abs() < 1e-14); // descending
        let ce = complex_eigenvalues(m.clone(), "test").unwrap();
        assert!(ce.iter().all(|z| z.im == 0.0));
        // the first non-finite entry is named, by column then row
        m[(1, 0)] = f64::INFINITY;
        m[(0, 1)] = f64::NAN;
        let err = svd(m.clone(), false, false, "test matrix").unwrap_err();
        assert_eq!(
            err,
            Failure::NonFiniteMatrix {
                what: "test matrix".into(),
                row: 1,
                col: 0,
                value: "inf".into()
            }
        );
        assert!(symmetric_eigen(m.clone(), "t").is_err());
        assert!(complex_eigenvalues(m.clone(), "t").is_err());
        // the fallbacks pass NaN on, shaped
        let nan = svd_or_nan(m.clone(), true, true);
        assert_eq!(nan.singular_values.len(), 2);
        assert!(nan.singular_values[0].is_nan());
        assert_eq!(nan.v_t.unwrap().shape(), (2, 2));
        assert!(symmetric_eigen_or_nan(m).eigenvalues[0].is_nan());
    }
}
