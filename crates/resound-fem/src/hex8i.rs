//! 8-node rectangular hexahedron with Wilson–Taylor incompatible modes.
//!
//! Displacements are trilinear plus the nine bubble terms (1 − ξ²), (1 − η²), (1 − ζ²) for each
//! component (Wilson, Taylor, Doherty & Ghaboussi 1973), condensed out element by element:
//! K = K_cc − K_ci K_ii⁻¹ K_ic. On rectangular elements the bubbles let the element bend without
//! the parasitic shear that locks plain trilinear hexes and linear tets, and the element passes
//! the patch test (its Jacobian is constant, so Taylor's correction is zero).
//!
//! Node `n` (0..8) sits at corner (±1, ±1, ±1) with bit 0 → x, bit 1 → y, bit 2 → z,
//! matching the voxel grid's node order. DOF `3n + c`.

use faer::linalg::solvers::Solve;
use faer::Mat;

/// 2-point Gauss abscissa 1/√3.
const G: f64 = 0.577_350_269_189_625_8;

fn corner(n: usize) -> [f64; 3] {
    [
        if n & 1 == 0 { -1.0 } else { 1.0 },
        if n & 2 == 0 { -1.0 } else { 1.0 },
        if n & 4 == 0 { -1.0 } else { 1.0 },
    ]
}

/// Gradients (w.r.t. x, y, z) of the 8 trilinear and 3 bubble functions at (ξ, η, ζ)
/// for an element of edge lengths `h` (m).
fn gradients(xi: [f64; 3], h: [f64; 3]) -> [[f64; 3]; 11] {
    let mut g = [[0.0; 3]; 11];
    let s = h.map(|l| 2.0 / l); // dξ/dx
    for n in 0..8 {
        let c = corner(n);
        let f = [0, 1, 2].map(|d| 1.0 + c[d] * xi[d]);
        for d in 0..3 {
            let mut v = c[d] / 8.0;
            for e in 0..3 {
                if e != d {
                    v *= f[e];
                }
            }
            g[n][d] = v * s[d];
        }
    }
    for d in 0..3 {
        g[8 + d][d] = -2.0 * xi[d] * s[d];
    }
    g
}

/// Element stiffness (24×24, N/m) of a box with edge lengths `h` (m) and Lamé parameters
/// (λ, μ) in Pa, incompatible modes condensed. Row-major `k[24 * r + c]`.
pub fn stiffness(h: [f64; 3], lame: (f64, f64)) -> Vec<f64> {
    let (lam, mu) = lame;
    let det = h[0] * h[1] * h[2] / 8.0;
    let nf = 11 * 3;
    let mut kf = vec![0.0; nf * nf];
    for &a in &[-G, G] {
        for &b in &[-G, G] {
            for &c in &[-G, G] {
                let g = gradients([a, b, c], h);
                for i in 0..11 {
                    for j in 0..11 {
                        let gi = g[i];
                        let gj = g[j];
                        let dot = gi[0] * gj[0] + gi[1] * gj[1] + gi[2] * gj[2];
                        for p in 0..3 {
                            for q in 0..3 {
                                // λ ∂_p N_i ∂_q N_j + μ ∂_q N_i ∂_p N_j + μ δ_pq ∇N_i·∇N_j
                                let mut v = lam * gi[p] * gj[q] + mu * gi[q] * gj[p];
                                if p == q {
                                    v += mu * dot;
                                }
                                kf[(3 * i + p) * nf + 3 * j + q] += v * det;
                            }
                        }
                    }
                }
            }
        }
    }
    // Static condensation of the 9 bubble DOFs (indices 24..33).
    let kii = Mat::<f64>::from_fn(9, 9, |r, c| kf[(24 + r) * nf + 24 + c]);
    let kic = Mat::<f64>::from_fn(9, 24, |r, c| kf[(24 + r) * nf + c]);
    let llt = kii
        .llt(faer::Side::Lower)
        .expect("bubble stiffness of a valid box is positive definite");
    let x = llt.solve(&kic); // K_ii⁻¹ K_ic
    let mut k = vec![0.0; 24 * 24];
    for r in 0..24 {
        for c in 0..24 {
            let mut v = kf[r * nf + c];
            for m in 0..9 {
                v -= kf[r * nf + 24 + m] * x[(m, c)];
            }
            k[r * 24 + c] = v;
        }
    }
    // Symmetrize round-off.
    for r in 0..24 {
        for c in 0..r {
            let v = 0.5 * (k[r * 24 + c] + k[c * 24 + r]);
            k[r * 24 + c] = v;
            k[c * 24 + r] = v;
        }
    }
    k
}

/// Consistent element mass (24×24, kg) of a box of edge lengths `h` (m) and density ρ
/// (kg/m³), from the trilinear functions: the tensor product of 1-D (l/6)·[[2, 1], [1, 2]].
pub fn mass_consistent(h: [f64; 3], density: f64) -> Vec<f64> {
    let mut m = vec![0.0; 24 * 24];
    for a in 0..8 {
        for b in 0..8 {
            let mut v = density;
            for d in 0..3 {
                let same = (a >> d) & 1 == (b >> d) & 1;
                v *= h[d] / 6.0 * if same { 2.0 } else { 1.0 };
            }
            for c in 0..3 {
                m[(3 * a + c) * 24 + 3 * b + c] = v;
            }
        }
    }
    m
}

/// Lumped element mass (24×24 diagonal, kg): ρV/8 on every DOF.
pub fn mass_lumped(h: [f64; 3], density: f64) -> Vec<f64> {
    let v = density * h[0] * h[1] * h[2] / 8.0;
    let mut m = vec![0.0; 24 * 24];
    for i in 0..24 {
        m[i * 24 + i] = v;
    }
    m
}

#[cfg(test)]
mod tests {
    use super::*;

    fn apply(k: &[f64], u: &[f64]) -> Vec<f64> {
        (0..24)
            .map(|r| (0..24).map(|c| k[r * 24 + c] * u[c]).sum())
            .collect()
    }

    #[test]
    fn rigid_motions_have_no_energy_and_mass_is_total() {
        let h = [0.3, 0.1, 0.05];
        let k = stiffness(h, (1e9, 2e9));
        let scale = k.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        // Translations and rotations (about the centre) give zero forces.
        for mode in 0..6 {
            let mut u = vec![0.0; 24];
            for n in 0..8 {
                let x = corner(n).map(|s| s * 0.5);
                let x = [x[0] * h[0], x[1] * h[1], x[2] * h[2]];
                let d = match mode {
                    0..=2 => {
                        let mut d = [0.0; 3];
                        d[mode] = 1.0;
                        d
                    }
                    3 => [0.0, -x[2], x[1]],
                    4 => [x[2], 0.0, -x[0]],
                    _ => [-x[1], x[0], 0.0],
                };
                u[3 * n..3 * n + 3].copy_from_slice(&d);
            }
            let f = apply(&k, &u);
            assert!(
                f.iter().all(|v| v.abs() < 1e-9 * scale),
                "mode {mode}: {f:?}"
            );
        }
        let m = mass_consistent(h, 1000.0);
        let total: f64 = (0..24)
            .flat_map(|r| (0..24).map(move |c| (r, c)))
            .filter(|(r, c)| r % 3 == 0 && c % 3 == 0)
            .map(|(r, c)| m[r * 24 + c])
            .sum();
        assert!((total - 1000.0 * h[0] * h[1] * h[2]).abs() < 1e-12);
    }

    #[test]
    fn pure_bending_energy_is_exact() {
        // u = κ x z, w = −κ x²/2 (pure bending about y) with ν = 0 has energy E I κ² L / 2.
        let h = [0.2, 0.1, 0.05];
        let e = 7.0e9;
        let lame = (0.0, e / 2.0); // ν = 0
        let k = stiffness(h, lame);
        let kappa = 0.01;
        let mut u = vec![0.0; 24];
        for n in 0..8 {
            let s = corner(n);
            let (x, z) = (0.5 * s[0] * h[0], 0.5 * s[2] * h[2]);
            u[3 * n] = kappa * x * z;
            u[3 * n + 2] = -0.5 * kappa * x * x;
        }
        let f = apply(&k, &u);
        let energy: f64 = 0.5 * u.iter().zip(&f).map(|(a, b)| a * b).sum::<f64>();
        let i = h[1] * h[2].powi(3) / 12.0;
        let exact = 0.5 * e * i * kappa * kappa * h[0];
        assert!((energy - exact).abs() < 1e-9 * exact, "{energy} vs {exact}");
    }
}
