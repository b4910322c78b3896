//! Dense reference solver for small problems (tests, cross-checks).

use faer::prelude::*;
use faer::sparse::SparseColMatRef;
use faer::Side;

/// All eigenvalues (ascending, rad²/s²) of K φ = λ M φ by dense Cholesky of M and a dense
/// symmetric eigendecomposition of L⁻¹ K L⁻ᵀ. O(n³): only for a few thousand DOFs.
///
/// # Panics
/// If M is not positive definite or the dense eigen-solve fails.
pub fn dense_eigenvalues(
    k: SparseColMatRef<'_, usize, f64>,
    m: SparseColMatRef<'_, usize, f64>,
) -> Vec<f64> {
    let kd = k.to_dense();
    let md = m.to_dense();
    let l = md
        .llt(Side::Lower)
        .expect("M is positive definite")
        .L()
        .to_owned();
    // C = L⁻¹ K L⁻ᵀ
    let mut x = kd.clone();
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
    let mut ev: Vec<f64> = sym
        .self_adjoint_eigenvalues(Side::Lower)
        .expect("dense symmetric eigen-solve");
    ev.sort_by(f64::total_cmp);
    ev
}
