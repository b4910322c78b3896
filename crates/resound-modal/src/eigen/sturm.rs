//! Sturm count: how many eigenvalues lie below a shift, from the inertia of K − σM.

use super::*;

/// Number of eigenvalues of K φ = λ M φ below `lambda`, from the inertia of K − λM.
///
/// # Errors
/// [`ModalError::Factorization`] when the LDLᵀ factorization breaks down (a pivot is zero,
/// i.e. `lambda` is an eigenvalue to working precision).
pub fn sturm_count(
    k: SparseColMatRef<'_, usize, f64>,
    m: SparseColMatRef<'_, usize, f64>,
    lambda: f64,
    symbolic: &SymbolicCholesky<usize>,
    par: Par,
) -> Result<usize, ModalError> {
    let a = shifted(k, m, lambda);
    let mut vals = vec![0.0; symbolic.len_val()];
    let req = symbolic.factorize_numeric_ldlt_scratch::<f64>(par, Default::default());
    let mut buf =
        MemBuffer::try_new(req).map_err(|e| ModalError::Factorization(format!("{e:?}")))?;
    symbolic
        .factorize_numeric_ldlt(
            &mut vals,
            a.as_ref(),
            Side::Lower,
            Default::default(),
            par,
            MemStack::new(&mut buf),
            Default::default(),
        )
        .map_err(|e| ModalError::Factorization(format!("LDLT at the cutoff: {e:?}")))?;
    let SymbolicCholeskyRaw::Supernodal(sym) = symbolic.raw() else {
        return Err(ModalError::Factorization(
            "expected a supernodal factorization".into(),
        ));
    };
    let ldlt = faer::sparse::linalg::cholesky::supernodal::SupernodalLdltRef::new(sym, &vals);
    let mut neg = 0;
    for s in 0..sym.n_supernodes() {
        let node = ldlt.supernode(s);
        let mat = node.val();
        for i in 0..mat.ncols() {
            if mat[(i, i)] < 0.0 {
                neg += 1;
            }
        }
    }
    Ok(neg)
}
