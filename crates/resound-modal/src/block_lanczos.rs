//! Block Lanczos with full reorthogonalization for the largest eigenvalues of a symmetric
//! operator given as a block product.
//!
//! Why not faer's single-vector thick-restart Lanczos: with shift-invert every operator
//! application is two sparse triangular solves, which are memory-bound for one right-hand side
//! (the whole factor streams through the cache for 4 flops per entry). With a block of b vectors
//! the supernodal solves become matrix–matrix products that reuse each block of L b times and
//! use both cores. `resound bench modal --method faer` measures the single-vector baseline.
//!
//! Algorithm (Golub & Underwood 1977; Grimes, Lewis & Simon 1994 for shift-invert use):
//! Q₀ random orthonormal; W = A Q_j; W ← W − Q Qᵀ W against the last two blocks (the
//! three-term recurrence), then against all previous blocks (full reorthogonalization, repeated
//! once when it removed more than 1 − 1/√2 of a column: Daniel, Gragg, Kaufman & Stewart 1976); the projections fill the block column of T = QᵀAQ; W = Q_{j+1} R_{j+1} (thin QR) gives the next block and the sub-diagonal block. A Ritz
//! pair (θ, Q s) of T has residual ‖A Q s − θ Q s‖ = ‖R_{j+1} s_last‖, where s_last is the last b
//! entries of s: no extra operator application is needed to test convergence. Columns whose
//! residual direction vanishes (an invariant subspace) are replaced by fresh random directions.

use faer::prelude::*;
use faer::Side;

/// Settings of [`block_lanczos`].
#[derive(Debug, Clone, PartialEq)]
pub struct BlockLanczosParams {
    /// Eigenpairs computed (largest eigenvalues).
    pub nev: usize,
    /// The leading pairs that must meet `tol` (the others are guards that speed convergence
    /// and are not waited for); `nev` when 0.
    pub converge: usize,
    /// Block size.
    pub block: usize,
    /// Largest Krylov dimension before giving up.
    pub max_dim: usize,
    /// Convergence: Ritz residual ≤ `tol` · |θ| for each wanted pair (relative to the pair's
    /// own θ: with shift-invert the wanted θ span 10⁴ or more, and a criterion relative to the
    /// largest one would accept the smallest far too early).
    pub tol: f64,
    /// Seed of the random start block.
    pub seed: u64,
}

/// Outcome of [`block_lanczos`].
#[derive(Debug, Clone, PartialEq)]
pub struct BlockLanczosInfo {
    /// Krylov dimension reached.
    pub dim: usize,
    /// Block operator applications.
    pub block_applications: usize,
    /// Wanted pairs that met the tolerance.
    pub converged: usize,
}

fn random_block(n: usize, b: usize, state: &mut u64) -> Mat<f64> {
    Mat::<f64>::from_fn(n, b, |_, _| {
        *state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*state >> 11) as f64 / (1u64 << 53) as f64) - 0.5
    })
}

/// W ← W − Q Qᵀ W for the first `k` columns of `q`, twice; returns the accumulated Qᵀ W.
fn orthogonalize(q: MatRef<'_, f64>, w: &mut Mat<f64>) -> Mat<f64> {
    let mut h = Mat::<f64>::zeros(q.ncols(), w.ncols());
    if q.ncols() == 0 {
        return h;
    }
    for _ in 0..2 {
        let c = q.transpose() * &*w;
        *w -= q * &c;
        h += &c;
    }
    h
}

/// Orthonormal basis of W (thin QR) with R; directions with |R_ii| below `tiny` are replaced by
/// random vectors orthogonal to `q` and to the other columns (and their R row is zeroed).
fn next_block(q: MatRef<'_, f64>, w: Mat<f64>, tiny: f64, state: &mut u64) -> (Mat<f64>, Mat<f64>) {
    let b = w.ncols();
    let qr = w.qr();
    let mut r = qr.R().to_owned();
    let mut qn = qr.compute_thin_Q();
    let mut bad = Vec::new();
    for i in 0..b {
        if !(r[(i, i)].abs() > tiny) {
            bad.push(i);
        }
    }
    if !bad.is_empty() {
        for &i in &bad {
            for c in 0..b {
                r[(i, c)] = 0.0;
            }
        }
        // Fresh directions for the deficient columns, orthogonal to everything so far.
        let mut fresh = random_block(w.nrows(), bad.len(), state);
        let _ = orthogonalize(q, &mut fresh);
        let keep: Vec<usize> = (0..b).filter(|i| !bad.contains(i)).collect();
        let kept = Mat::<f64>::from_fn(w.nrows(), keep.len(), |r_, c| qn[(r_, keep[c])]);
        let _ = orthogonalize(kept.as_ref(), &mut fresh);
        let fq = fresh.qr().compute_thin_Q();
        for (j, &i) in bad.iter().enumerate() {
            for r_ in 0..w.nrows() {
                qn[(r_, i)] = fq[(r_, j)];
            }
        }
    }
    (qn, r)
}

/// What `accept` of [`block_lanczos`] says of the pairs it was shown.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Not good enough yet: grow the space.
    Reject,
    /// Good: stop and return the Ritz vectors Q S.
    Accept,
    /// Good, and the caller has kept what it needs from Q S (e.g. its transform): stop
    /// without forming Q S, which would sit beside the basis at the peak of memory.
    Kept,
}

/// `accept(θ, S, Q)` of [`block_lanczos`]: the Ritz values, their coefficients and the basis.
pub type AcceptFn<'a> = dyn FnMut(&[f64], MatRef<'_, f64>, MatRef<'_, f64>) -> Verdict + 'a;

/// The `nev` largest eigenpairs of the symmetric operator `apply` (n × n): θ descending and the
/// orthonormal Ritz vectors Y = Q S (n × nev), where Q holds the block inputs passed to `apply`.
/// Returns the best available pairs after `max_dim` when fewer than `nev` converged.
///
/// `accept(θ, S, Q)` is asked, at each convergence check where every wanted Ritz estimate meets
/// `tol`, whether the pairs are good enough (e.g. by their true residuals, from Q S); a
/// [`Verdict`] other than `Reject` stops (after `Kept`, Y has no columns). Callers that need a
/// transform of the Ritz vectors (shift-invert's L⁻ᵀ) apply it to Q S: keeping the transform
/// of every input instead would double the memory of the basis.
pub fn block_lanczos(
    n: usize,
    apply: &mut dyn FnMut(MatRef<'_, f64>) -> Mat<f64>,
    accept: &mut AcceptFn<'_>,
    p: &BlockLanczosParams,
) -> (Vec<f64>, Mat<f64>, BlockLanczosInfo) {
    let b = p.block.clamp(1, n.max(1));
    let nev = p.nev.min(n);
    let max_dim = p.max_dim.clamp(nev + b, n.max(nev + b)).min(n);
    let mut state = p.seed ^ 0x9E37_79B9_7F4A_7C15;
    // The basis grows a block at a time inside memory reserved once: pages of columns never
    // reached (the space converges well short of `max_dim`) are never touched, so they cost
    // no resident memory and no copy.
    let mut q = Mat::<f64>::with_capacity(n, max_dim + b);
    q.resize_with(n, b, |_, _| 0.0);
    let mut t = Mat::<f64>::zeros(max_dim + b, max_dim + b);
    let x0 = random_block(n, b, &mut state);
    let q0 = x0.qr().compute_thin_Q();
    q.as_mut().subcols_mut(0, b).copy_from(&q0);
    let mut k = 0usize; // columns of Q whose block column of T is complete
    let mut info = BlockLanczosInfo {
        dim: 0,
        block_applications: 0,
        converged: 0,
    };
    let mut result: Option<(Vec<f64>, Mat<f64>, Verdict)> = None;
    while k + b <= max_dim {
        let qj = q.as_ref().subcols(k, b).to_owned();
        let mut w = apply(qj.as_ref());
        info.block_applications += 1;
        // The three-term part first (the last two blocks), then a full pass against every
        // block: after the local step the full pass only removes rounding-level components, so
        // a second full sweep (the expensive part of classical Gram–Schmidt twice) is rarely due.
        let lo = k.saturating_sub(b);
        let mut h = Mat::<f64>::zeros(k + b, b);
        {
            let ql = q.as_ref().subcols(lo, k + b - lo);
            let c = ql.transpose() * &w;
            w -= ql * &c;
            h.as_mut().subrows_mut(lo, k + b - lo).copy_from(&c);
        }
        // Full passes: a second one whenever the first removed much of a column (the
        // Daniel–Gragg–Kaufman–Stewart test), i.e. when orthogonality was being lost.
        for _ in 0..2 {
            let before: Vec<f64> = (0..b).map(|c| w.col(c).norm_l2()).collect();
            let qa = q.as_ref().subcols(0, k + b);
            let c = qa.transpose() * &w;
            w -= qa * &c;
            h += &c;
            let lost =
                (0..b).any(|c| w.col(c).norm_l2() < std::f64::consts::FRAC_1_SQRT_2 * before[c]);
            if !lost {
                break;
            }
        }
        t.as_mut().submatrix_mut(0, k, k + b, b).copy_from(&h);
        k += b;
        let scale = (0..k)
            .map(|i| t[(i, i)].abs())
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        let (qn, r) = next_block(q.as_ref().subcols(0, k), w, 1e-13 * scale, &mut state);
        t.as_mut().submatrix_mut(k, k - b, b, b).copy_from(&r);
        // Convergence test once the space can hold the wanted pairs, every other block.
        // Shift-invert Lanczos needs a space of about 2.5–3 nev before the highest wanted
        // pairs converge: checks (a dense k × k eigen-decomposition each) start at 2 nev.
        let check = k >= (2 * nev).max(nev + b) && ((k / b).is_multiple_of(2) || k + b > max_dim);
        if check {
            let tk = Mat::<f64>::from_fn(k, k, |i, j| 0.5 * (t[(i, j)] + t[(j, i)]));
            let Ok(evd) = tk.self_adjoint_eigen(Side::Lower) else {
                break;
            };
            let s = evd.U();
            let theta: Vec<f64> = (0..k).map(|i| evd.S()[i]).collect();
            let mut order: Vec<usize> = (0..k).collect();
            order.sort_by(|&a, &c| theta[c].total_cmp(&theta[a]));
            let mut conv = 0;
            let need = if p.converge == 0 {
                nev
            } else {
                p.converge.min(nev)
            };
            for &i in order.iter().take(need) {
                let mut res2 = 0.0;
                for rr in 0..b {
                    let mut acc = 0.0;
                    for c in 0..b {
                        acc += r[(rr, c)] * s[(k - b + c, i)];
                    }
                    res2 += acc * acc;
                }
                if res2.sqrt() <= p.tol * theta[i].abs() {
                    conv += 1;
                }
            }
            info.converged = conv;
            let last = k + b > max_dim;
            if conv >= need || last {
                let sel = Mat::<f64>::from_fn(k, nev, |i, c| s[(i, order[c])]);
                let th: Vec<f64> = order.iter().take(nev).map(|&i| theta[i]).collect();
                let verdict = if last {
                    Verdict::Accept
                } else {
                    accept(&th, sel.as_ref(), q.as_ref().subcols(0, k))
                };
                if verdict != Verdict::Reject {
                    result = Some((th, sel, verdict));
                    break;
                }
            }
        }
        q.resize_with(n, k + b, |_, _| 0.0);
        q.as_mut().subcols_mut(k, b).copy_from(&qn);
    }
    info.dim = k;
    let (theta, y) = match result {
        Some((th, _, Verdict::Kept)) => (th, Mat::<f64>::zeros(n, 0)),
        Some((th, sel, _)) => {
            let y = q.as_ref().subcols(0, sel.nrows()) * &sel;
            (th, y)
        }
        None => (vec![0.0; nev], Mat::<f64>::zeros(n, nev)),
    };
    (theta, y, info)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_largest_eigenvalues_of_a_diagonal_operator() {
        // A = diag(1/(1+i)) with a cluster; the top 12 must come out exactly.
        let n = 400;
        let d: Vec<f64> = (0..n)
            .map(|i| if i < 3 { 1.0 } else { 1.0 / (1.0 + i as f64) })
            .collect();
        let p = BlockLanczosParams {
            converge: 0,
            nev: 12,
            block: 4,
            max_dim: 200,
            tol: 1e-10,
            seed: 1,
        };
        let mut apply =
            |x: MatRef<'_, f64>| Mat::<f64>::from_fn(x.nrows(), x.ncols(), |i, c| d[i] * x[(i, c)]);
        // What `accept` is shown: an orthonormal basis Q whose Q S is the result returned.
        let mut seen: Option<Mat<f64>> = None;
        let mut accept = |_: &[f64], s: MatRef<'_, f64>, q: MatRef<'_, f64>| {
            assert_eq!(q.ncols(), s.nrows());
            let g = q.transpose() * q;
            for i in 0..q.ncols() {
                for j in 0..q.ncols() {
                    let e = if i == j { 1.0 } else { 0.0 };
                    assert!(
                        (g[(i, j)] - e).abs() < 1e-10,
                        "QᵀQ[{i},{j}] = {}",
                        g[(i, j)]
                    );
                }
            }
            seen = Some(q * s);
            Verdict::Accept
        };
        let (theta, y, info) = block_lanczos(n, &mut apply, &mut accept, &p);
        let seen = seen.expect("accept was asked");
        assert!((&seen - &y).norm_max() < 1e-14);
        // A caller that kept what it needs stops the run the same way, without Q S.
        let (kept_theta, kept_y, kept_info) =
            block_lanczos(n, &mut apply, &mut |_, _, _| Verdict::Kept, &p);
        assert_eq!(kept_y.ncols(), 0);
        assert_eq!(kept_theta, theta);
        assert_eq!(kept_info.dim, info.dim);
        assert_eq!(info.converged, 12, "{info:?}");
        let mut want: Vec<f64> = d.clone();
        want.sort_by(|a, b| b.total_cmp(a));
        for i in 0..12 {
            assert!(
                (theta[i] - want[i]).abs() < 1e-9,
                "{i}: {} vs {}",
                theta[i],
                want[i]
            );
            // Residual ‖A y − θ y‖.
            let r: f64 = (0..n)
                .map(|r| (d[r] * y[(r, i)] - theta[i] * y[(r, i)]).powi(2))
                .sum::<f64>()
                .sqrt();
            assert!(r < 1e-8, "{r}");
        }
        // Orthonormal vectors, including the triple eigenvalue 1.
        let g = y.transpose() * &y;
        for i in 0..12 {
            for j in 0..12 {
                let e = if i == j { 1.0 } else { 0.0 };
                assert!((g[(i, j)] - e).abs() < 1e-9);
            }
        }
    }
}
