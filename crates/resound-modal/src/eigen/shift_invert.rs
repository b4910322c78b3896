//! The shift-invert operator L⁻¹ P M Pᵀ L⁻ᵀ of K − σM = Pᵀ L Lᵀ P that Lanczos iterates.

use super::*;

pub(super) struct ShiftInvert<'a> {
    pub(super) symbolic:
        &'a faer::sparse::linalg::cholesky::supernodal::SymbolicSupernodalCholesky<usize>,
    pub(super) l_values: &'a [f64],
    pub(super) fwd: Vec<usize>,
    pub(super) m: SparseColMatRef<'a, usize, f64>,
    pub(super) count: AtomicUsize,
    pub(super) progress: ProgressFn<'a>,
}

impl std::fmt::Debug for ShiftInvert<'_> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("ShiftInvert")
            .field("n", &self.fwd.len())
            .finish()
    }
}

impl ShiftInvert<'_> {
    pub(super) fn llt(&self) -> SupernodalLltRef<'_, usize, f64> {
        SupernodalLltRef::new(self.symbolic, self.l_values)
    }

    pub(super) fn scratch(&self, k: usize, par: Par) -> StackReq {
        self.symbolic.solve_in_place_scratch::<f64>(k, par)
    }

    /// φ (original ordering) = Pᵀ L⁻ᵀ y, in place: eigenvectors from Ritz vectors y of the
    /// operator without a second n × k matrix.
    pub(super) fn to_phi(&self, mut y: Mat<f64>, par: Par) -> Mat<f64> {
        self.solve_split(y.as_mut(), false, par);
        self.unpermute(y)
    }

    /// L⁻¹W (`lower`) or L⁻ᵀW in place, the columns split into one part per thread, each solved
    /// sequentially: faer's parallel solve splits every small supernode across threads, and
    /// the wake-ups cost more than they save.
    fn solve_split(&self, w: MatMut<'_, f64>, lower: bool, par: Par) {
        let threads = match par {
            Par::Seq => 1,
            _ => rayon::current_num_threads().max(1),
        };
        let chunk = w.ncols().div_ceil(threads).max(1);
        let mut parts: Vec<MatMut<'_, f64>> = Vec::new();
        let mut rest = w;
        while rest.ncols() > 0 {
            let take = chunk.min(rest.ncols());
            let (a, b) = rest.split_at_col_mut(take);
            parts.push(a);
            rest = b;
        }
        use rayon::prelude::*;
        parts.into_par_iter().for_each(|mut p| {
            let mut buf = MemBuffer::new(self.scratch(p.ncols(), Par::Seq));
            let stack = MemStack::new(&mut buf);
            if lower {
                self.llt()
                    .l_solve_with_conj(Conj::No, p.rb_mut(), Par::Seq, stack);
            } else {
                self.llt()
                    .l_transpose_solve_with_conj(Conj::No, p.rb_mut(), Par::Seq, stack);
            }
        });
    }
}

impl ShiftInvert<'_> {
    /// L⁻¹ P M Pᵀ L⁻ᵀ X for a block X (permuted ordering).
    pub(super) fn apply_block(&self, x: MatRef<'_, f64>, par: Par) -> Mat<f64> {
        let n = self.fwd.len();
        let mut w = x.to_owned();
        self.solve_split(w.as_mut(), false, par);
        let mut u = Mat::<f64>::zeros(n, w.ncols());
        for c in 0..w.ncols() {
            for i in 0..n {
                u[(self.fwd[i], c)] = w[(i, c)];
            }
        }
        let v = sym_matmul(self.m, u.as_ref());
        for c in 0..w.ncols() {
            for i in 0..n {
                w[(i, c)] = v[(self.fwd[i], c)];
            }
        }
        self.solve_split(w.as_mut(), true, par);
        let a = self.count.fetch_add(x.ncols(), Ordering::Relaxed) + x.ncols();
        (self.progress)(Progress::count(Stage::Lanczos, a as u64));
        w
    }

    /// Permuted ordering → original ordering, in place: a column at a time through one column
    /// of scratch, so no second n × k matrix is held.
    fn unpermute(&self, mut w: Mat<f64>) -> Mat<f64> {
        let mut column = vec![0.0; w.nrows()];
        for c in 0..w.ncols() {
            for (i, v) in column.iter_mut().enumerate() {
                *v = w[(i, c)];
            }
            for (i, &v) in column.iter().enumerate() {
                w[(self.fwd[i], c)] = v;
            }
        }
        w
    }
}

impl LinOp<f64> for ShiftInvert<'_> {
    fn apply_scratch(&self, rhs_ncols: usize, par: Par) -> StackReq {
        self.scratch(rhs_ncols, par)
    }
    fn nrows(&self) -> usize {
        self.fwd.len()
    }
    fn ncols(&self) -> usize {
        self.fwd.len()
    }
    fn apply(&self, out: MatMut<'_, f64>, rhs: MatRef<'_, f64>, par: Par, stack: &mut MemStack) {
        let n = self.fwd.len();
        let mut out = out;
        out.copy_from(rhs);
        self.llt()
            .l_transpose_solve_with_conj(Conj::No, out.rb_mut(), par, stack);
        let mut u = vec![0.0; n];
        let mut v = vec![0.0; n];
        for c in 0..out.ncols() {
            for i in 0..n {
                u[self.fwd[i]] = out[(i, c)];
            }
            sym_matvec(self.m, &u, &mut v);
            for i in 0..n {
                out[(i, c)] = v[self.fwd[i]];
            }
        }
        self.llt()
            .l_solve_with_conj(Conj::No, out.rb_mut(), par, stack);
        let a = self.count.fetch_add(1, Ordering::Relaxed) + 1;
        if a.is_multiple_of(8) {
            (self.progress)(Progress::count(Stage::Lanczos, a as u64));
        }
    }
    fn conj_apply(
        &self,
        out: MatMut<'_, f64>,
        rhs: MatRef<'_, f64>,
        par: Par,
        stack: &mut MemStack,
    ) {
        self.apply(out, rhs, par, stack)
    }
}
