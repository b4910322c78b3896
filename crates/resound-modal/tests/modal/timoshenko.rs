//! Reference: free–free Timoshenko beam frequencies by shooting, independent of our FEM.
//!
//! State y = (w, ψ, M, V) along x with M = EIψ', V = κGA(w' − ψ):
//! w' = ψ + V/(κGA), ψ' = M/(EI), M' = −V − ρIω²ψ, V' = −ρAω²w.
//! Free ends: M = V = 0 at both ends. Integrating from x = 0 with (w, ψ) = (1, 0) and (0, 1)
//! gives (M, V)(L) as a 2×2 matrix whose determinant vanishes at natural frequencies.

pub struct Beam {
    pub length: f64,
    pub e: f64,
    pub nu: f64,
    pub rho: f64,
    /// Cross-section b (in the bending plane's normal) × h (bending direction).
    pub b: f64,
    pub h: f64,
}

impl Beam {
    fn det(&self, omega: f64) -> f64 {
        let a = self.b * self.h;
        let i = self.b * self.h.powi(3) / 12.0;
        let g = self.e / (2.0 * (1.0 + self.nu));
        // Shear coefficient of a rectangle (Cowper 1966).
        let kappa = 10.0 * (1.0 + self.nu) / (12.0 + 11.0 * self.nu);
        let (ei, kga, ria, rha) = (self.e * i, kappa * g * a, self.rho * i, self.rho * a);
        let w2 = omega * omega;
        let f = |y: [f64; 4]| {
            [
                y[1] + y[3] / kga,
                y[2] / ei,
                -y[3] - ria * w2 * y[1],
                -rha * w2 * y[0],
            ]
        };
        let steps = 4000;
        let dx = self.length / steps as f64;
        let mut out = [[0.0; 2]; 2];
        for (k, y0) in [[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]]
            .iter()
            .enumerate()
        {
            let mut y = *y0;
            for _ in 0..steps {
                let k1 = f(y);
                let k2 = f([0, 1, 2, 3].map(|j| y[j] + 0.5 * dx * k1[j]));
                let k3 = f([0, 1, 2, 3].map(|j| y[j] + 0.5 * dx * k2[j]));
                let k4 = f([0, 1, 2, 3].map(|j| y[j] + dx * k3[j]));
                for j in 0..4 {
                    y[j] += dx / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j]);
                }
            }
            out[k] = [y[2], y[3]];
        }
        out[0][0] * out[1][1] - out[0][1] * out[1][0]
    }

    /// The first `n` bending frequencies (Hz) above `f_min`.
    pub fn bending_hz(&self, n: usize, f_min: f64, f_max: f64) -> Vec<f64> {
        let mut roots = Vec::new();
        let df = 2.0;
        let mut f = f_min;
        let mut d0 = self.det(2.0 * std::f64::consts::PI * f);
        while roots.len() < n && f < f_max {
            let f1 = f + df;
            let d1 = self.det(2.0 * std::f64::consts::PI * f1);
            if d0.signum() != d1.signum() {
                let (mut lo, mut hi, mut dlo) = (f, f1, d0);
                for _ in 0..60 {
                    let mid = 0.5 * (lo + hi);
                    let dm = self.det(2.0 * std::f64::consts::PI * mid);
                    if dm.signum() == dlo.signum() {
                        lo = mid;
                        dlo = dm;
                    } else {
                        hi = mid;
                    }
                }
                roots.push(0.5 * (lo + hi));
            }
            f = f1;
            d0 = d1;
        }
        roots
    }
}

#[test]
fn shooting_matches_euler_bernoulli_for_a_slender_beam() {
    // Very slender beam: Timoshenko → Euler–Bernoulli, f1 = (4.7300)² /(2π L²) √(EI/ρA).
    let b = Beam {
        length: 2.0,
        e: 200e9,
        nu: 0.3,
        rho: 7850.0,
        b: 0.01,
        h: 0.005,
    };
    let f = b.bending_hz(2, 1.0, 500.0);
    let c = (b.e * b.h * b.h / 12.0 / b.rho).sqrt();
    for (k, beta) in [4.730_040_7, 7.853_204_6].iter().enumerate() {
        let eb = beta * beta / (2.0 * std::f64::consts::PI * b.length * b.length) * c;
        assert!((f[k] / eb - 1.0).abs() < 1e-3, "mode {k}: {} vs {eb}", f[k]);
    }
}
