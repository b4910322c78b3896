//! Sparse kernels: symmetric products from one stored triangle, the shifted matrix K − σM and
//! its supernodal symbolic factorization.

use super::*;

/// y = M x for a full symmetric CSC M (x and y of length n).
pub fn sym_matvec(m: SparseColMatRef<'_, usize, f64>, x: &[f64], y: &mut [f64]) {
    y.iter_mut().for_each(|v| *v = 0.0);
    for j in 0..m.ncols() {
        let xj = x[j];
        if xj == 0.0 {
            continue;
        }
        for (i, v) in m.row_idx_of_col(j).zip(m.val_of_col(j)) {
            y[i] += v * xj;
        }
    }
}

/// Y = A X for a symmetric A stored full (CSC) and dense X. Column j of A is row j of A, so
/// each output row is a sparse combination of rows of X: with X copied row-major every update
/// is a contiguous axpy of length `x.ncols()`, and rows are independent (parallel over rows).
/// Several times faster than a column-major sparse × dense product for 16–250 columns.
pub fn sym_matmul(a: SparseColMatRef<'_, usize, f64>, x: MatRef<'_, f64>) -> Mat<f64> {
    // Wide blocks go 32 columns at a time: the row-major copy then stays in cache.
    const CHUNK: usize = 32;
    if x.ncols() > CHUNK + CHUNK / 2 {
        let mut out = Mat::<f64>::zeros(x.nrows(), x.ncols());
        let mut c = 0;
        while c < x.ncols() {
            let w = CHUNK.min(x.ncols() - c);
            let part = sym_matmul(a, x.subcols(c, w));
            out.as_mut().subcols_mut(c, w).copy_from(&part);
            c += w;
        }
        return out;
    }
    use rayon::prelude::*;
    let (n, m) = (x.nrows(), x.ncols());
    let mut xt = vec![0.0; n * m];
    for c in 0..m {
        for i in 0..n {
            xt[i * m + c] = x[(i, c)];
        }
    }
    let mut yt = vec![0.0; n * m];
    yt.par_chunks_mut(m).enumerate().for_each(|(j, row)| {
        for (i, v) in a.row_idx_of_col(j).zip(a.val_of_col(j)) {
            let src = &xt[i * m..i * m + m];
            for (r, s) in row.iter_mut().zip(src) {
                *r += v * s;
            }
        }
    });
    Mat::<f64>::from_fn(n, m, |i, c| yt[i * m + c])
}

/// Values of K − s·M (same pattern).
pub(super) fn shifted(
    k: SparseColMatRef<'_, usize, f64>,
    m: SparseColMatRef<'_, usize, f64>,
    s: f64,
) -> SparseColMat<usize, f64> {
    let vals: Vec<f64> = k
        .val()
        .iter()
        .zip(m.val())
        .map(|(a, b)| a - s * b)
        .collect();
    SparseColMat::new(
        k.symbolic().to_owned().expect("copy of a valid pattern"),
        vals,
    )
}

pub(super) fn symbolic_supernodal(
    a: SparseColMatRef<'_, usize, f64>,
    order: Option<&[usize]>,
) -> Result<SymbolicCholesky<usize>, ModalError> {
    let inv: Option<Vec<usize>> = order.map(|f| {
        let mut inv = vec![0; f.len()];
        for (i, &o) in f.iter().enumerate() {
            inv[o] = i;
        }
        inv
    });
    let ord = match (order, inv.as_deref()) {
        (Some(f), Some(i)) if f.len() == a.nrows() => {
            SymmetricOrdering::Custom(faer::perm::PermRef::new_checked(f, i, a.nrows()))
        }
        _ => SymmetricOrdering::Amd,
    };
    factorize_symbolic_cholesky(
        a.symbolic(),
        Side::Lower,
        ord,
        CholeskySymbolicParams {
            supernodal_flop_ratio_threshold: SupernodalThreshold::FORCE_SUPERNODAL,
            ..Default::default()
        },
    )
    .map_err(|e| ModalError::Factorization(format!("{e:?}")))
}
