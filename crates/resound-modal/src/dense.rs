//! Dense reference solver for small problems (tests, cross-checks).

use faer::prelude::*;
use faer::sparse::SparseColMatRef;
use faer::Side;

/// The Cholesky factor L of M and C = L⁻¹ K L⁻ᵀ (symmetrized), the standard form both dense
/// solves diagonalize; `None` when M is not positive definite.
fn reduced(
    k: SparseColMatRef<'_, usize, f64>,
    m: SparseColMatRef<'_, usize, f64>,
) -> Option<(Mat<f64>, Mat<f64>)> {
    let l = m.to_dense().llt(Side::Lower).ok()?.L().to_owned();
    let mut x = k.to_dense();
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(
        l.as_ref(),
        x.as_mut(),
        Par::Seq,
    );
    let mut c = x.transpose().to_owned();
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(
        l.as_ref(),
        c.as_mut(),
        Par::Seq,
    );
    let sym = Mat::<f64>::from_fn(c.nrows(), c.ncols(), |i, j| 0.5 * (c[(i, j)] + c[(j, i)]));
    Some((l, sym))
}

/// All eigenvalues (ascending, rad²/s²) of K φ = λ M φ by dense Cholesky of M and a dense
/// symmetric eigendecomposition of L⁻¹ K L⁻ᵀ. O(n³): only for a few thousand DOFs.
///
/// # Panics
/// If M is not positive definite or the dense eigen-solve fails.
pub fn dense_eigenvalues(
    k: SparseColMatRef<'_, usize, f64>,
    m: SparseColMatRef<'_, usize, f64>,
) -> Vec<f64> {
    let (_, sym) = reduced(k, m).expect("M is positive definite");
    let mut ev: Vec<f64> = sym
        .self_adjoint_eigenvalues(Side::Lower)
        .expect("dense symmetric eigen-solve");
    ev.sort_by(f64::total_cmp);
    ev
}

/// Every eigenpair of K φ = λ M φ, λ ascending, φ M-normalized (φᵀMφ = 1), by the same
/// reduction as [`dense_eigenvalues`]; `None` when M is not positive definite or the dense
/// solve fails. O(n³): for models of a few hundred DOFs, where a Krylov space cannot grow
/// past the problem (a 24-DOF cube asked for 10 modes "converged 0/44").
pub fn dense_eigenpairs(
    k: SparseColMatRef<'_, usize, f64>,
    m: SparseColMatRef<'_, usize, f64>,
) -> Option<(Vec<f64>, Mat<f64>)> {
    let (l, sym) = reduced(k, m)?;
    let eig = sym.self_adjoint_eigen(Side::Lower).ok()?;
    let n = sym.nrows();
    let s = eig.S();
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| s[a].total_cmp(&s[b]));
    let lambdas: Vec<f64> = order.iter().map(|&i| s[i]).collect();
    // φ = L⁻ᵀ y (y orthonormal, so φᵀMφ = yᵀy = 1).
    let mut phi = Mat::<f64>::from_fn(n, n, |r, c| eig.U()[(r, order[c])]);
    faer::linalg::triangular_solve::solve_upper_triangular_in_place(
        l.transpose(),
        phi.as_mut(),
        Par::Seq,
    );
    Some((lambdas, phi))
}
