//! Shift-invert Lanczos for K φ = λ M φ.
//!
//! With K − σM = Pᵀ L Lᵀ P (σ < 0 so the matrix is positive definite even with the rigid-body
//! modes at λ = 0; fill-reducing P by nested dissection on voxel grids, AMD otherwise), the
//! operator A = L⁻¹ P M Pᵀ L⁻ᵀ is symmetric and A y = θ y ⇔ K φ = λ M φ with φ = Pᵀ L⁻ᵀ y,
//! λ = σ + 1/θ. The lowest λ are the largest θ, the ones Lanczos finds first. Either our block
//! Lanczos ([`crate::block_lanczos`], default) or faer's single-vector thick-restart Lanczos
//! (`partial_self_adjoint_eigen`, [`EigenMethod::Lanczos`]) runs on A; only one factorization is
//! needed. Every returned pair is checked by its true residual ‖Kφ − λMφ‖ / (λ‖Mφ‖), and the
//! count below the cutoff (or the last pair) is certified by Sylvester's inertia of K − λ_cut M
//! (the number of negative pivots of its LDLᵀ factorization).

use faer::dyn_stack::{MemBuffer, MemStack, StackReq};
use faer::linalg::cholesky::llt::factor::LltRegularization;
use faer::matrix_free::LinOp;
use faer::prelude::*;
use faer::sparse::linalg::cholesky::{
    factorize_symbolic_cholesky, supernodal::SupernodalLltRef, CholeskySymbolicParams,
    SymbolicCholesky, SymbolicCholeskyRaw, SymmetricOrdering,
};
use faer::sparse::linalg::SupernodalThreshold;
use faer::sparse::{SparseColMat, SparseColMatRef};
use faer::{Conj, Par, Side};
use resound_core::progress::{Progress, ProgressFn, Stage};
use resound_core::units;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Errors of the eigen-solve.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ModalError {
    /// K − σM could not be factorized.
    #[error("K - sigma*M is not positive definite (sigma = {shift:.3e} rad^2/s^2): {detail}. Are there inverted elements or a negative material value?")]
    NotPositiveDefinite {
        /// The shift σ.
        shift: f64,
        /// faer's message.
        detail: String,
    },
    /// Lanczos did not converge for all requested pairs.
    #[error("eigen-solve converged {converged}/{requested} modes; max relative residual {max_residual:.2e} (tolerance {tolerance:.1e})")]
    NoConvergence {
        /// Pairs that converged.
        converged: usize,
        /// Pairs requested.
        requested: usize,
        /// Largest relative residual among the returned pairs.
        max_residual: f64,
        /// The tolerance.
        tolerance: f64,
    },
    /// The inertia count disagrees with the modes found.
    #[error("Sturm count: K - lambda*M has {sturm} eigenvalues below {freq_hz:.1} Hz but the solver returned {found}")]
    CountMismatch {
        /// Count from inertia.
        sturm: usize,
        /// Count found by Lanczos.
        found: usize,
        /// The frequency checked (Hz).
        freq_hz: f64,
    },
    /// More eigenvalues below the cutoff than the cap allows (counted by inertia before the
    /// solve, so the refusal costs one factorization).
    #[error("K - lambda*M has {count} eigenvalues below {freq_hz:.0} Hz, more than the {max} allowed: solving them would need about {basis_gb:.1} GB for the Krylov basis alone and a long time")]
    TooManyModes {
        /// Count from inertia (rigid-body modes included).
        count: usize,
        /// The cap (`max_eigen`).
        max: usize,
        /// The cutoff (Hz).
        freq_hz: f64,
        /// Memory of a Krylov basis for that many pairs, GB.
        basis_gb: f64,
    },
    /// Nothing to solve.
    #[error("empty problem: {0}")]
    Empty(String),
    /// An internal faer failure (allocation, symbolic analysis).
    #[error("sparse factorization failed: {0}")]
    Factorization(String),
}

/// Which Krylov method runs on the shift-inverted operator.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum EigenMethod {
    /// Block Lanczos with full reorthogonalization ([`crate::block_lanczos`]): blocks of
    /// triangular solves, several times faster per vector.
    #[default]
    BlockLanczos,
    /// faer's single-vector thick-restart Lanczos (`partial_self_adjoint_eigen`): the baseline.
    Lanczos,
}

/// Parameters of [`solve_generalized`].
#[derive(Debug, Clone, PartialEq)]
pub struct EigenParams {
    /// Number of lowest eigenpairs wanted (including rigid-body modes).
    pub n_eigen: usize,
    /// Shift σ < 0 (rad²/s²).
    pub shift: f64,
    /// Relative residual ‖Kφ − λMφ‖/‖λMφ‖ above which a pair counts as not converged.
    /// It bounds the relative eigenvalue error; the actual error is of its square (Rayleigh
    /// quotient), so the default 1e-3 means frequencies good to ~1e-6 or better, well below
    /// the discretization error. Lanczos in θ-space reaches ~1e-4 at 200 modes (its floor is
    /// ε·λ_max/|σ| in θ), so much tighter values cannot be met.
    pub tolerance: f64,
    /// Maximum thick restarts.
    pub max_restarts: usize,
    /// Keep doubling the number of pairs until one exceeds this λ (rad²/s²) or `max_eigen`
    /// is reached; then certify the count below it by inertia when `sturm_check` is set.
    pub until_lambda: Option<f64>,
    /// Cap on pairs when `until_lambda` is set.
    pub max_eigen: usize,
    /// When more than `max_eigen` pairs lie below `until_lambda`: solve the lowest
    /// `max_eigen` (and set [`EigenInfo::capped`]) instead of failing with
    /// [`ModalError::TooManyModes`]. "Every mode below the cutoff, at most N".
    pub cap_at_max: bool,
    /// Certify the count below `until_lambda` (or just above the last pair) by inertia.
    pub sturm_check: bool,
    /// Threads for factorization and solves.
    pub par: Par,
    /// Krylov method.
    pub method: EigenMethod,
    /// Block size of block Lanczos.
    pub block: usize,
    /// Fill-reducing order (new position → DOF); minimum degree (AMD) when `None`.
    pub dof_order: Option<Vec<usize>>,
}

impl Default for EigenParams {
    fn default() -> Self {
        EigenParams {
            n_eigen: 26,
            shift: -1.0,
            tolerance: 1e-3,
            max_restarts: 200,
            until_lambda: None,
            max_eigen: 4000,
            cap_at_max: false,
            sturm_check: true,
            par: Par::rayon(0),
            method: EigenMethod::BlockLanczos,
            block: 16,
            dof_order: None,
        }
    }
}

/// What the solve did.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct EigenInfo {
    /// DOFs.
    pub dofs: usize,
    /// Stored entries of K (both triangles).
    pub nnz_k: usize,
    /// Entries of the Cholesky factor L.
    pub nnz_l: usize,
    /// Factorization wall time (s).
    pub factor_s: f64,
    /// Lanczos wall time (s), including residual checks.
    pub eigen_s: f64,
    /// Sturm check wall time (s).
    pub sturm_s: f64,
    /// Operator applications (each: two triangular solves and one M product).
    pub applications: usize,
    /// Pairs Lanczos reported converged.
    pub converged: usize,
    /// Largest relative residual ‖Kφ − λMφ‖/(|λ|‖Mφ‖) over pairs with λ > 0.
    pub max_rel_residual: f64,
    /// Eigenvalue count below `sturm_lambda` from inertia, when checked.
    pub sturm_count: Option<usize>,
    /// λ (rad²/s²) at which the Sturm count was taken.
    pub sturm_lambda: Option<f64>,
    /// Lanczos rounds (more than one when the cutoff needed more pairs).
    pub rounds: usize,
    /// True when `max_eigen` stopped the search below the cutoff.
    pub capped: bool,
    /// The shift used.
    pub shift: f64,
    /// True when block Lanczos ran a second time with stricter settings because the final
    /// residual check of the first run failed.
    pub retried: bool,
    /// The pairs wanted when only the lowest of them met the tolerance and were kept (at
    /// least three quarters of them; without a cutoff only).
    pub truncated_from: Option<usize>,
    /// Pairs kept after the retries whose residual lies between the tolerance and
    /// [`LOOSE_FACTOR`] times it (without a cutoff only; `max_rel_residual` says how far).
    pub loose_pairs: usize,
}

/// How far above the tolerance a pair's residual may stay after every retry and still be
/// kept (with a warning), without a cutoff.
pub const LOOSE_FACTOR: f64 = 10.0;

/// Models this small are solved densely: every pair at once and exactly (a Krylov space of a
/// few blocks already spans them, and block Lanczos stalls there).
pub const DENSE_MAX_DOFS: usize = 300;

/// [`solve_generalized`] for a model of at most [`DENSE_MAX_DOFS`] DOFs: all pairs by a dense
/// solve, the wanted ones kept (the lowest `n_eigen`, or those below the cutoff).
fn solve_dense(
    k: SparseColMatRef<'_, usize, f64>,
    m: SparseColMatRef<'_, usize, f64>,
    params: &EigenParams,
    mut info: EigenInfo,
) -> Result<(Vec<f64>, Mat<f64>, EigenInfo), ModalError> {
    let t0 = Instant::now();
    let n = k.nrows();
    let (mut lambdas, phi) =
        crate::dense::dense_eigenpairs(k, m).ok_or_else(|| ModalError::NotPositiveDefinite {
            shift: 0.0,
            detail: "the mass matrix of a small model is not positive definite".into(),
        })?;
    let wanted = match params.until_lambda {
        Some(lc) => {
            let below = lambdas.iter().filter(|&&l| l < lc).count();
            if below > params.max_eigen {
                info.capped = true;
            }
            below.min(params.max_eigen).max(1)
        }
        None => params.n_eigen.min(n),
    };
    lambdas.truncate(wanted);
    let phi = phi.subcols(0, wanted).to_owned();
    let mphi = sym_matmul(m, phi.as_ref());
    info.max_rel_residual = residuals_with_m(
        k,
        &lambdas,
        phi.as_ref(),
        mphi.as_ref(),
        rigid_below(&lambdas),
    );
    info.converged = wanted;
    info.rounds = 1;
    info.eigen_s = t0.elapsed().as_secs_f64();
    Ok((lambdas, phi, info))
}

/// Scales every column of `phi` to φᵀMφ = 1 and returns Mφ (scaled alike); `None` when a column
/// has no positive finite M-norm.
fn m_normalize(m: SparseColMatRef<'_, usize, f64>, phi: &mut Mat<f64>) -> Option<Mat<f64>> {
    let mut mphi = sym_matmul(m, phi.as_ref());
    for c in 0..phi.ncols() {
        let mnorm = (0..phi.nrows())
            .map(|i| phi[(i, c)] * mphi[(i, c)])
            .sum::<f64>()
            .sqrt();
        if !(mnorm > 0.0 && mnorm.is_finite()) {
            return None;
        }
        for i in 0..phi.nrows() {
            phi[(i, c)] /= mnorm;
            mphi[(i, c)] /= mnorm;
        }
    }
    Some(mphi)
}

/// Pairs that passed the final residual check: λ, M-normalized φ, largest relative residual.
type Checked = (Vec<f64>, Mat<f64>, f64);

mod shift_invert;
mod sparse;
mod sturm;
use shift_invert::ShiftInvert;
use sparse::{shifted, symbolic_supernodal};
pub use sparse::{sym_matmul, sym_matvec};
pub use sturm::sturm_count;

fn lanczos(
    op: &ShiftInvert<'_>,
    nev: usize,
    sigma: f64,
    par: Par,
    max_restarts: usize,
) -> Result<(Mat<f64>, Vec<f64>, usize), ModalError> {
    let n = op.fwd.len();
    let lparams = faer::matrix_free::eigen::PartialEigenParams {
        max_restarts,
        ..Default::default()
    };
    let req = faer::matrix_free::eigen::partial_self_adjoint_eigen_scratch(op, nev, par, lparams);
    let mut buf = MemBuffer::try_new(req)
        .map_err(|e| ModalError::Factorization(format!("Lanczos workspace: {e:?}")))?;
    let mut y = Mat::<f64>::zeros(n, nev);
    let mut theta = vec![0.0; nev];
    // Deterministic, dense start vector (a fixed-seed LCG): reproducible runs.
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    let v0 = Col::<f64>::from_fn(n, |_| {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    });
    // Lock tolerance in θ units, relative to θ_max = 1/|σ|. Much tighter than 1e-10 sits at
    // the round-off floor (ε·θ_max) for the top of a 200-mode block and never locks; the true
    // residual check afterwards decides acceptance.
    let tol = 1e-10 / sigma.abs();
    let out = faer::matrix_free::eigen::partial_self_adjoint_eigen(
        y.as_mut(),
        &mut theta,
        op,
        v0.as_ref(),
        tol,
        par,
        MemStack::new(&mut buf),
        lparams,
    );
    Ok((y, theta, out.n_converged_eigen))
}

/// Largest relative residual ‖Kφ − λMφ‖/‖λMφ‖ of the (non-rigid) pairs, given Mφ.
fn residuals_with_m(
    k: SparseColMatRef<'_, usize, f64>,
    lambdas: &[f64],
    phi: MatRef<'_, f64>,
    mphi: MatRef<'_, f64>,
    rigid_below: f64,
) -> f64 {
    residuals_each(k, lambdas, phi, mphi, rigid_below)
        .into_iter()
        .fold(0.0, |a, r| if r.is_nan() { f64::NAN } else { a.max(r) })
}

/// Columns of φ multiplied by K at once in [`residuals_each`].
const RESIDUAL_CHUNK: usize = 32;

/// λ under which a pair of the set `lambdas` counts as rigid: 10⁻⁶ of the largest, or 1 Hz (a
/// set of rigid pairs alone, as a stiff object below a cutoff gives, has no elastic λ to
/// compare with).
fn rigid_below(lambdas: &[f64]) -> f64 {
    let lam_max = lambdas.iter().cloned().fold(0.0, f64::max);
    (1e-6 * lam_max).max(units::freq_hz_to_lambda(1.0))
}

/// Columns of the wanted eigenvectors formed and checked at once in block Lanczos' final
/// check.
const CHECK_CHUNK: usize = 64;

/// The relative residual ‖Kφ − λMφ‖/‖λMφ‖ of each pair, given Mφ; 0 for rigid pairs (λ at or
/// below `rigid_below`, see [`rigid_below`]), NaN for a pair that is not finite.
fn residuals_each(
    k: SparseColMatRef<'_, usize, f64>,
    lambdas: &[f64],
    phi: MatRef<'_, f64>,
    mphi: MatRef<'_, f64>,
    rigid_below: f64,
) -> Vec<f64> {
    let sel: Vec<usize> = (0..lambdas.len())
        .filter(|&c| lambdas[c] > rigid_below)
        .collect();
    let mut each = vec![0.0; lambdas.len()];
    if sel.is_empty() {
        return each;
    }
    // Kφ a few columns at a time: the whole set would hold two more n × pairs matrices at
    // the solve's peak of memory.
    for chunk in sel.chunks(RESIDUAL_CHUNK) {
        let sub = Mat::<f64>::from_fn(phi.nrows(), chunk.len(), |i, c| phi[(i, chunk[c])]);
        let kp = sym_matmul(k, sub.as_ref());
        for (c, &j) in chunk.iter().enumerate() {
            let lam = lambdas[j];
            let (mut r2, mut m2) = (0.0, 0.0);
            for i in 0..phi.nrows() {
                let r = kp[(i, c)] - lam * mphi[(i, j)];
                r2 += r * r;
                m2 += (lam * mphi[(i, j)]).powi(2);
            }
            each[j] = (r2 / m2).sqrt();
        }
    }
    each
}

/// Solves for the `params.n_eigen` lowest eigenpairs of K φ = λ M φ (K, M full symmetric CSC,
/// M positive definite, K positive semi-definite). Returns λ ascending and M-orthonormal φ as
/// columns.
///
/// # Errors
/// [`ModalError`] when the factorization fails, pairs do not converge, or the Sturm count
/// disagrees.
pub fn solve_generalized(
    k: SparseColMatRef<'_, usize, f64>,
    m: SparseColMatRef<'_, usize, f64>,
    params: &EigenParams,
    progress: ProgressFn<'_>,
) -> Result<(Vec<f64>, Mat<f64>, EigenInfo), ModalError> {
    let n = k.nrows();
    if n == 0 || params.n_eigen == 0 {
        return Err(ModalError::Empty(format!(
            "{n} DOFs, {} eigenpairs requested",
            params.n_eigen
        )));
    }
    let par = params.par;
    let sigma = params.shift;
    let mut info = EigenInfo {
        dofs: n,
        nnz_k: k.compute_nnz(),
        shift: sigma,
        ..Default::default()
    };
    if n <= DENSE_MAX_DOFS {
        return solve_dense(k, m, params, info);
    }
    progress(Progress::begin(Stage::Factorizing));
    let t0 = Instant::now();
    let a = shifted(k, m, sigma);
    let symbolic = symbolic_supernodal(a.as_ref(), params.dof_order.as_deref())?;
    let mut l_values = Vec::new();
    l_values
        .try_reserve_exact(symbolic.len_val())
        .map_err(|_| {
            ModalError::Factorization(format!(
                "cannot allocate the factor ({} entries)",
                symbolic.len_val()
            ))
        })?;
    l_values.resize(symbolic.len_val(), 0.0);
    let req = symbolic.factorize_numeric_llt_scratch::<f64>(par, Default::default());
    let mut buf =
        MemBuffer::try_new(req).map_err(|e| ModalError::Factorization(format!("{e:?}")))?;
    symbolic
        .factorize_numeric_llt(
            &mut l_values,
            a.as_ref(),
            Side::Lower,
            LltRegularization {
                dynamic_regularization_delta: 0.0,
                dynamic_regularization_epsilon: 0.0,
            },
            par,
            MemStack::new(&mut buf),
            Default::default(),
        )
        .map_err(|e| ModalError::NotPositiveDefinite {
            shift: sigma,
            detail: format!("{e:?}"),
        })?;
    drop(buf);
    drop(a);
    info.nnz_l = symbolic.len_val();
    info.factor_s = t0.elapsed().as_secs_f64();
    // With a cutoff, count the pairs below it first (inertia of K − λ_c M): a cutoff far above
    // what the mesh's scale suggests is refused at once instead of after minutes, and the
    // Krylov run is sized to the count instead of doubling towards it.
    let counted = match params.until_lambda {
        Some(lc) => {
            progress(Progress::begin(Stage::SturmCheck));
            let t2 = Instant::now();
            let c = sturm_count(k, m, lc, &symbolic, par)?;
            info.sturm_s = t2.elapsed().as_secs_f64();
            if c > params.max_eigen && params.cap_at_max {
                // More below the cutoff than wanted: the lowest `max_eigen`, as a count.
                let count = EigenParams {
                    n_eigen: params.max_eigen,
                    until_lambda: None,
                    cap_at_max: false,
                    ..params.clone()
                };
                drop(symbolic);
                let (l, phi, mut more) = solve_generalized(k, m, &count, progress)?;
                more.capped = true;
                more.factor_s += info.factor_s;
                more.sturm_s += info.sturm_s;
                return Ok((l, phi, more));
            }
            if c > params.max_eigen {
                let dim = 3 * (c + c / 5).max(c + 10) + 4 * params.block;
                return Err(ModalError::TooManyModes {
                    count: c,
                    max: params.max_eigen,
                    freq_hz: units::lambda_to_freq_hz(lc),
                    basis_gb: (n * dim * 8) as f64 / 1e9,
                });
            }
            Some(c)
        }
        None => None,
    };

    let SymbolicCholeskyRaw::Supernodal(sym) = symbolic.raw() else {
        return Err(ModalError::Factorization(
            "expected a supernodal factorization".into(),
        ));
    };
    let fwd: Vec<usize> = match symbolic.perm() {
        Some(p) => p.arrays().0.to_vec(),
        None => (0..n).collect(),
    };
    let op = ShiftInvert {
        symbolic: sym,
        l_values: &l_values,
        fwd,
        m,
        count: AtomicUsize::new(0),
        progress,
    };
    let t1 = Instant::now();
    // Guard vectors: Lanczos converges slowest at the top
    // of the block, so compute ~20 % more pairs than wanted and check only the wanted ones.
    let guard = |w: usize| (w / 5).max(10);
    // Block Lanczos stops on the true residuals of a sample of the wanted pairs; should the final
    // check of all of them fail, it runs once more with a 100× stricter Ritz tolerance and twice
    // the margin instead of giving up.
    let mut strict = false;
    // A third and last attempt widens the guard band: highly symmetric objects (a cube) have
    // clusters of equal eigenvalues that a narrow band leaves just short of the tolerance.
    let mut wide = false;
    let mut accepted = params.tolerance;
    let checked: std::cell::RefCell<Option<Checked>> = Default::default();
    let (lambdas, phi, wanted, nev, max_res) = 'attempt: loop {
        let mut wanted = counted.unwrap_or(params.n_eigen).max(1).min(n);
        let mut nev = (wanted
            + if wide {
                2 * guard(wanted) + wanted / 2
            } else {
                guard(wanted)
            })
        .min(n);
        // The Ritz estimates only open the door to the true-residual checks, which decide.
        let (ritz_tol, margin) = if strict { (1e-6, 0.35) } else { (3e-4, 0.7) };
        let (y, theta, order) = loop {
            info.rounds += 1;
            let (y, theta, converged) = match params.method {
                EigenMethod::Lanczos => lanczos(&op, nev, sigma, par, params.max_restarts)?,
                EigenMethod::BlockLanczos => {
                    let bp = crate::block_lanczos::BlockLanczosParams {
                        nev,
                        converge: if params.until_lambda.is_some() {
                            nev
                        } else {
                            wanted
                        },
                        block: params.block,
                        max_dim: (3 * nev + 4 * params.block).min(n),
                        tol: ritz_tol,
                        seed: 0x5EED,
                    };
                    let mut apply = |x: MatRef<'_, f64>| op.apply_block(x, par);
                    // Stop as soon as the highest wanted pairs (the slowest to converge) pass the
                    // true residual test with a margin; the final check covers all of them.
                    // Then (without a cutoff) every wanted pair is checked, and the checked,
                    // M-normalized pairs are the result: the check is the final one.
                    // Eigenvectors are formed as L⁻ᵀ(QS), a few columns at a time, so the
                    // check holds no second basis-sized matrix at the solve's peak of memory.
                    let want = wanted;
                    let full_check = params.until_lambda.is_none();
                    let next_full = std::cell::Cell::new(0usize);
                    let mut accept = |theta: &[f64], s: MatRef<'_, f64>, q: MatRef<'_, f64>| {
                        use crate::block_lanczos::Verdict;
                        // The 32 highest wanted pairs first (the slowest to converge).
                        if s.nrows() < next_full.get() {
                            return Verdict::Reject;
                        }
                        let lam: Vec<f64> = (0..want).map(|c| sigma + 1.0 / theta[c]).collect();
                        let rigid = rigid_below(&lam);
                        let lo = want.saturating_sub(32);
                        let phi = op.to_phi(q * s.subcols(lo, want - lo), par);
                        let mphi = sym_matmul(m, phi.as_ref());
                        let res =
                            residuals_with_m(k, &lam[lo..], phi.as_ref(), mphi.as_ref(), rigid);
                        if !(res <= margin * params.tolerance) {
                            return Verdict::Reject;
                        }
                        if !full_check {
                            return Verdict::Accept;
                        }
                        // After a failed full check, checks wait for 15 % more dimension
                        // (each costs a solve, a K and an M product of every wanted vector).
                        next_full.set(s.nrows() + s.nrows().div_ceil(7));
                        let mut phi = Mat::<f64>::with_capacity(n, want);
                        let mut worst = 0.0f64;
                        for lo in (0..want).step_by(CHECK_CHUNK) {
                            let cols = CHECK_CHUNK.min(want - lo);
                            let mut part = op.to_phi(q * s.subcols(lo, cols), par);
                            let Some(mpart) = m_normalize(m, &mut part) else {
                                return Verdict::Reject;
                            };
                            let lam = &lam[lo..lo + cols];
                            let r = residuals_with_m(k, lam, part.as_ref(), mpart.as_ref(), rigid);
                            // Not `max`: a NaN residual must fail the check.
                            if !(r <= params.tolerance) {
                                return Verdict::Reject;
                            }
                            worst = worst.max(r);
                            phi.resize_with(n, lo + cols, |_, _| 0.0);
                            phi.as_mut().subcols_mut(lo, cols).copy_from(&part);
                        }
                        *checked.borrow_mut() = Some((lam, phi, worst));
                        // The checked eigenvectors are the result: no Q S beside the basis.
                        Verdict::Kept
                    };
                    let (theta, y, bi) =
                        crate::block_lanczos::block_lanczos(n, &mut apply, &mut accept, &bp);
                    if let Some((lam, phi, res)) = checked.borrow_mut().take() {
                        info.converged = bi.converged;
                        break 'attempt (lam, phi, want, nev, res);
                    }
                    (y, theta, bi.converged)
                }
            };
            info.converged = converged;
            let mut order: Vec<usize> = (0..nev).collect();
            // Largest θ first = lowest λ first.
            order.sort_by(|&i, &j| theta[j].total_cmp(&theta[i]));
            let lam = |c: usize| sigma + 1.0 / theta[order[c]];
            match params.until_lambda {
                Some(lc) => {
                    let below = (0..nev).filter(|&c| lam(c) < lc).count();
                    wanted = below;
                    if nev - below >= guard(below).min(n - below) || nev >= n {
                        break (y, theta, order);
                    }
                    if nev >= params.max_eigen {
                        info.capped = true;
                        wanted = nev.saturating_sub(guard(nev)).max(1);
                        break (y, theta, order);
                    }
                    nev = (2 * nev)
                        .min(n)
                        .min(params.max_eigen + guard(params.max_eigen));
                }
                None => break (y, theta, order),
            }
        };
        let lambdas: Vec<f64> = order.iter().map(|&i| sigma + 1.0 / theta[i]).collect();
        // Block Lanczos returns its pairs sorted already: no reordered copy then.
        let ysorted = if order.iter().enumerate().all(|(i, &o)| i == o) {
            y
        } else {
            Mat::<f64>::from_fn(n, nev, |r, c| y[(r, order[c])])
        };
        let mut phi = op.to_phi(ysorted, par);
        let Some(mphi) = m_normalize(m, &mut phi) else {
            return Err(ModalError::NoConvergence {
                converged: info.converged,
                requested: nev,
                max_residual: f64::INFINITY,
                tolerance: params.tolerance,
            });
        };
        let rigid = rigid_below(&lambdas[..wanted]);
        let mut max_res =
            residuals_with_m(k, &lambdas[..wanted], phi.as_ref(), mphi.as_ref(), rigid);
        let last_try = wide || params.method != EigenMethod::BlockLanczos;
        if !(max_res <= params.tolerance) && params.until_lambda.is_none() && last_try {
            // A count of modes (no cutoff) whose lowest three quarters or more passed after
            // the retries: keep those (the caller warns). Far above the shift, the
            // shift-invert operator's rounding can hold the highest pairs' residuals near the
            // tolerance however large the Krylov space grows (a 100 × 30 × 5 mm bar's modes
            // 165–205, at 230 kHz). The Sturm check below still certifies that no pair under
            // the last one kept is missing.
            // Pairs within ten times the tolerance are kept too, counted: a relative residual
            // ρ moves λ by about ρ²λ/gap, far below what anyone hears (the same bar's pairs
            // stall at 1.0–2.3e-3 scattered over 230–270 kHz).
            let each = residuals_each(k, &lambdas[..wanted], phi.as_ref(), mphi.as_ref(), rigid);
            let loose = LOOSE_FACTOR * params.tolerance;
            let prefix = each.iter().position(|r| !(*r <= loose)).unwrap_or(wanted);
            if prefix >= 3 * wanted / 4 && prefix > 0 {
                if prefix < wanted {
                    info.truncated_from = Some(wanted);
                }
                info.loose_pairs = each[..prefix]
                    .iter()
                    .filter(|&&r| r > params.tolerance)
                    .count();
                accepted = loose;
                max_res = each[..prefix].iter().copied().fold(0.0, f64::max);
                break 'attempt (lambdas, phi, prefix, nev, max_res);
            }
        }
        if !(max_res <= params.tolerance) && !wide && params.method == EigenMethod::BlockLanczos {
            if strict {
                wide = true;
            }
            strict = true;
            info.retried = true;
            continue 'attempt;
        }
        break 'attempt (lambdas, phi, wanted, nev, max_res);
    };
    info.applications = op.count.load(Ordering::Relaxed);
    info.max_rel_residual = max_res;
    let mut lambdas = lambdas;
    lambdas.truncate(wanted);
    let phi = phi.subcols(0, wanted).to_owned();
    info.eigen_s = t1.elapsed().as_secs_f64();
    if !(max_res <= accepted) {
        return Err(ModalError::NoConvergence {
            converged: info.converged,
            requested: nev,
            max_residual: max_res,
            tolerance: params.tolerance,
        });
    }
    // Certify: at the cutoff, or halfway between the last pair and the next one's lower bound.
    let check_at = match params.until_lambda {
        Some(lc) if !info.capped => Some(lc),
        // Just above the last pair by its own error bound: a Ritz value with relative
        // residual ρ lies within ρ·λ of an eigenvalue, so with a 10⁻⁶ margin the last pair's
        // true twin (a cylinder's degenerate pairs) fell outside the count at ρ ≈ 10⁻⁴ and a
        // complete result was refused. Above it, more eigenvalues only raise the count.
        _ => lambdas
            .last()
            .map(|&l| l * (1.0 + (2.0 * max_res).clamp(1e-6, 1e-2)) + 1e-9),
    };
    if let (true, Some(lc)) = (params.sturm_check, check_at) {
        let count = match (counted, params.until_lambda) {
            (Some(c), Some(l)) if l == lc => c,
            _ => {
                progress(Progress::begin(Stage::SturmCheck));
                let t2 = Instant::now();
                let c = sturm_count(k, m, lc, &symbolic, par)?;
                info.sturm_s += t2.elapsed().as_secs_f64();
                c
            }
        };
        info.sturm_lambda = Some(lc);
        info.sturm_count = Some(count);
        let found = lambdas.iter().filter(|&&l| l < lc).count();
        // Without a cutoff the last pair only bounds the count from below: more pairs may
        // cluster just above it (within 1e-6), so only a shortfall is an error there.
        let bad = if params.until_lambda.is_some() && !info.capped {
            count != found
        } else {
            count < found
        };
        if bad {
            return Err(ModalError::CountMismatch {
                sturm: count,
                found,
                freq_hz: units::lambda_to_freq_hz(lc),
            });
        }
    }
    Ok((lambdas, phi, info))
}
