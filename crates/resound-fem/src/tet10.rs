//! Straight-sided 10-node quadratic tetrahedra, integrated exactly.
//!
//! Shape functions in barycentric coordinates L: corners N_i = L_i(2L_i − 1), edge midpoints
//! N_e = 4 L_i L_j. For straight edges x ↦ L is affine, so every integral is a polynomial in L
//! integrated by ∫ L₀^a L₁^b L₂^c L₃^d dV = 6V·a!b!c!d!/(a+b+c+d+3)!. The element-independent
//! parts are computed once ([`Tet10Tables`]); per element only the four ∇L_k change.

/// Local edges (corner pairs) of the 6 midpoint nodes, in node order 4..10.
pub const EDGES: [[usize; 2]; 6] = [[0, 1], [1, 2], [0, 2], [0, 3], [1, 3], [2, 3]];

fn fact(n: usize) -> f64 {
    (1..=n).map(|k| k as f64).product()
}

/// Each shape function as a homogeneous quadratic Σ Q_ab L_a L_b (using ΣL = 1).
fn quadratic_forms() -> [[[f64; 4]; 4]; 10] {
    let mut q = [[[0.0; 4]; 4]; 10];
    for i in 0..4 {
        // L_i(2L_i − ΣL) = L_i² − Σ_{k≠i} L_i L_k
        q[i][i][i] = 1.0;
        for k in 0..4 {
            if k != i {
                q[i][i][k] -= 0.5;
                q[i][k][i] -= 0.5;
            }
        }
    }
    for (e, &[a, b]) in EDGES.iter().enumerate() {
        q[4 + e][a][b] = 2.0;
        q[4 + e][b][a] = 2.0;
    }
    q
}

/// ∂N_n/∂L_k as an affine function c₀ + Σ c_a L_a, coefficients `[c0, c_0..c_3]`.
fn derivative(n: usize, k: usize) -> [f64; 5] {
    let mut c = [0.0; 5];
    if n < 4 {
        if n == k {
            c[0] = -1.0;
            c[1 + n] = 4.0;
        }
    } else {
        let [i, j] = EDGES[n - 4];
        if k == i {
            c[1 + j] = 4.0;
        }
        if k == j {
            c[1 + i] = 4.0;
        }
    }
    c
}

/// Element-independent integrals, divided by the element volume.
#[derive(Debug, Clone)]
pub struct Tet10Tables {
    /// (1/V) ∫ N_i N_j dV, 10×10.
    pub mass: [[f64; 10]; 10],
    /// (1/V) ∫ ∂N_i/∂L_k ∂N_j/∂L_l dV at `[i][j][k][l]`.
    pub grad: Vec<f64>,
}

impl Default for Tet10Tables {
    fn default() -> Self {
        Self::new()
    }
}

impl Tet10Tables {
    /// Computes the tables.
    pub fn new() -> Self {
        let q = quadratic_forms();
        let mut mass = [[0.0; 10]; 10];
        for i in 0..10 {
            for j in 0..10 {
                let mut s = 0.0;
                for a in 0..4 {
                    for b in 0..4 {
                        if q[i][a][b] == 0.0 {
                            continue;
                        }
                        for c in 0..4 {
                            for d in 0..4 {
                                if q[j][c][d] == 0.0 {
                                    continue;
                                }
                                let mut e = [0usize; 4];
                                for x in [a, b, c, d] {
                                    e[x] += 1;
                                }
                                let mono =
                                    6.0 * e.iter().map(|&x| fact(x)).product::<f64>() / fact(7);
                                s += q[i][a][b] * q[j][c][d] * mono;
                            }
                        }
                    }
                }
                mass[i][j] = s;
            }
        }
        // ∫ over the unit-volume simplex: 1 → 1, L_a → 1/4, L_a L_b → (1 + δ_ab)/20.
        let mut grad = vec![0.0; 10 * 10 * 16];
        for i in 0..10 {
            for j in 0..10 {
                for k in 0..4 {
                    for l in 0..4 {
                        let c = derivative(i, k);
                        let d = derivative(j, l);
                        let sc: f64 = c[1..].iter().sum();
                        let sd: f64 = d[1..].iter().sum();
                        let mut s = c[0] * d[0] + 0.25 * (c[0] * sd + d[0] * sc);
                        for a in 0..4 {
                            for b in 0..4 {
                                s += c[1 + a] * d[1 + b] * if a == b { 0.1 } else { 0.05 };
                            }
                        }
                        grad[((i * 10 + j) * 4 + k) * 4 + l] = s;
                    }
                }
            }
        }
        Tet10Tables { mass, grad }
    }

    /// Element stiffness (30×30 row-major, N/m) and consistent mass (30×30, kg) of the tet with
    /// corners `x` (m), or `None` when its volume is not positive (inverted or flat).
    pub fn element(
        &self,
        x: [[f64; 3]; 4],
        lame: (f64, f64),
        density: f64,
    ) -> Option<(Vec<f64>, Vec<f64>, f64)> {
        let j = [0, 1, 2].map(|c| [x[1][c] - x[0][c], x[2][c] - x[0][c], x[3][c] - x[0][c]]);
        // j[r][c]: row r = coordinate, column c = edge.
        let det = j[0][0] * (j[1][1] * j[2][2] - j[1][2] * j[2][1])
            - j[0][1] * (j[1][0] * j[2][2] - j[1][2] * j[2][0])
            + j[0][2] * (j[1][0] * j[2][1] - j[1][1] * j[2][0]);
        let vol = det / 6.0;
        let scale = (0..3)
            .map(|c| j[0][c].abs() + j[1][c].abs() + j[2][c].abs())
            .fold(0.0, f64::max);
        if !(vol > 1e-12 * scale.powi(3)) {
            return None;
        }
        // Inverse of J: rows are ∇L_1..3.
        let inv = |r: usize, c: usize| {
            let (r1, r2) = ((c + 1) % 3, (c + 2) % 3);
            let (c1, c2) = ((r + 1) % 3, (r + 2) % 3);
            (j[r1][c1] * j[r2][c2] - j[r1][c2] * j[r2][c1]) / det
        };
        let mut g = [[0.0; 3]; 4];
        for k in 1..4 {
            for c in 0..3 {
                g[k][c] = inv(k - 1, c);
                g[0][c] -= g[k][c];
            }
        }
        let (lam, mu) = lame;
        // E_kl(a, b) = λ g_k,a g_l,b + μ g_k,b g_l,a + μ δ_ab g_k·g_l
        let mut ekl = [[[[0.0; 3]; 3]; 4]; 4];
        for k in 0..4 {
            for l in 0..4 {
                let dot = g[k][0] * g[l][0] + g[k][1] * g[l][1] + g[k][2] * g[l][2];
                for a in 0..3 {
                    for b in 0..3 {
                        let mut v = lam * g[k][a] * g[l][b] + mu * g[k][b] * g[l][a];
                        if a == b {
                            v += mu * dot;
                        }
                        ekl[k][l][a][b] = v;
                    }
                }
            }
        }
        let mut ke = vec![0.0; 900];
        let mut me = vec![0.0; 900];
        for i in 0..10 {
            for jn in 0..10 {
                let base = (i * 10 + jn) * 16;
                let mut blk = [[0.0; 3]; 3];
                for kl in 0..16 {
                    let c = self.grad[base + kl];
                    if c == 0.0 {
                        continue;
                    }
                    let e = &ekl[kl / 4][kl % 4];
                    for a in 0..3 {
                        for b in 0..3 {
                            blk[a][b] += c * e[a][b];
                        }
                    }
                }
                for a in 0..3 {
                    for b in 0..3 {
                        ke[(3 * i + a) * 30 + 3 * jn + b] = vol * blk[a][b];
                    }
                    me[(3 * i + a) * 30 + 3 * jn + a] = density * vol * self.mass[i][jn];
                }
            }
        }
        Some((ke, me, vol))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mass_sums_to_volume_and_rigid_modes_are_free() {
        let t = Tet10Tables::new();
        let total: f64 = t.mass.iter().flatten().sum();
        assert!((total - 1.0).abs() < 1e-12, "{total}");
        let x = [
            [0.0, 0.0, 0.0],
            [1.0, 0.1, 0.0],
            [0.2, 0.9, 0.1],
            [0.1, 0.2, 1.3],
        ];
        let (k, m, vol) = t.element(x, (1e9, 1e9), 1000.0).unwrap();
        let msum: f64 = (0..10)
            .flat_map(|i| (0..10).map(move |j| (i, j)))
            .map(|(i, j)| m[(3 * i) * 30 + 3 * j])
            .sum();
        assert!((msum - 1000.0 * vol).abs() < 1e-9);
        // Node positions: corners then edge midpoints; rigid rotation about z gives no force.
        let mut p = x.to_vec();
        for [a, b] in EDGES {
            p.push([0, 1, 2].map(|c| 0.5 * (x[a][c] + x[b][c])));
        }
        let u: Vec<f64> = p.iter().flat_map(|q| [-q[1], q[0], 0.0]).collect();
        let kmax = k.iter().fold(0.0f64, |a, b| a.max(b.abs()));
        for r in 0..30 {
            let f: f64 = (0..30).map(|c| k[r * 30 + c] * u[c]).sum();
            assert!(f.abs() < 1e-10 * kmax);
        }
        // Quadratic field u = (x², 0, 0) with ν = 0: strain energy ∫ E (2x)² / 2 ... checked
        // against the exact integral via the tables' own consistency is circular; instead check
        // a linear field gives the exact energy E·ε²·V/2.
        let lame = (0.0, 0.5e9); // E = 1e9, ν = 0
        let (k, _, vol) = t.element(x, lame, 1.0).unwrap();
        let eps = 1e-3;
        let u: Vec<f64> = p.iter().flat_map(|q| [eps * q[0], 0.0, 0.0]).collect();
        let energy: f64 = 0.5
            * (0..30)
                .map(|r| u[r] * (0..30).map(|c| k[r * 30 + c] * u[c]).sum::<f64>())
                .sum::<f64>();
        let exact = 0.5 * 1e9 * eps * eps * vol;
        assert!((energy - exact).abs() < 1e-9 * exact);
        // Inverted tet is refused.
        assert!(t.element([x[1], x[0], x[2], x[3]], lame, 1.0).is_none());
    }
}
