//! The modal model of one object: eigenvalues, mass-normalised mode shapes on the surface mesh,
//! and the reference material they were computed with.

use crate::geometry::{closest_surface_point, SurfacePoint};
use crate::material::{Material, MaterialError};
use crate::units;

/// Errors of modal-model operations.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ModalModelError {
    /// The new material is not physical.
    #[error(transparent)]
    Material(#[from] MaterialError),
    /// Rescaling keeps ν fixed (Ren 2013 eq. 10); a different ν needs a new solve.
    #[error("cannot rescale: Poisson's ratio {new} differs from the reference {reference}; eigenvalues do not scale with nu, recompute the modes")]
    PoissonMismatch {
        /// ν of the reference material.
        reference: f64,
        /// ν requested.
        new: f64,
    },
    /// Array sizes do not agree.
    #[error("inconsistent modal model: {0}")]
    Inconsistent(String),
    /// The hit point is not usable.
    #[error("hit point {point:?} is {distance:.4} m from the surface (more than {tolerance:.4} m); is it in the mesh's units?")]
    HitOffSurface {
        /// The query point (m).
        point: [f64; 3],
        /// Its distance to the surface (m).
        distance: f64,
        /// The accepted distance (m).
        tolerance: f64,
    },
}

/// Modal model of an object (free–free, elastic modes only; rigid-body modes removed).
///
/// # Conventions
/// `eigenvalues[j] = ω_j²` (rad²/s²), ascending. `shapes` holds, for each mode j and surface
/// vertex v, the three displacement components of the **mass-normalised** mode (φᵀMφ = 1, unit
/// 1/√kg) at index `(j * n_vertices + v) * 3 + c`.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalModel {
    /// Material the eigen-solve used.
    pub material: Material,
    /// λ_j = ω_j² in rad²/s², ascending.
    pub eigenvalues: Vec<f64>,
    /// Surface mesh vertices (m).
    pub vertices: Vec<[f64; 3]>,
    /// Surface triangles (outward, counter-clockwise).
    pub triangles: Vec<[u32; 3]>,
    /// Mode shapes at the surface vertices, see the type docs for layout.
    pub shapes: Vec<f32>,
    /// Number of FEM degrees of freedom the model was solved with.
    pub fem_dofs: u64,
    /// Number of finite elements.
    pub fem_elements: u64,
    /// Each mode's acoustic transfer (radiated pressure per modal velocity), when computed
    /// (`resound_modal::radiation`).
    pub transfer: Option<crate::radiation::AcousticTransfer>,
}

/// A hit snapped to a model's surface ([`ModalModel::hit`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Hit {
    /// The surface point (position, normal, distance from the query).
    pub at: SurfacePoint,
    /// Gain a⁰_j of each mode there, m per N·s.
    pub gains: Vec<f64>,
}

impl ModalModel {
    /// Number of modes.
    pub fn n_modes(&self) -> usize {
        self.eigenvalues.len()
    }

    /// Number of surface vertices.
    pub fn n_vertices(&self) -> usize {
        self.vertices.len()
    }

    /// Checks that array lengths agree and values are finite.
    ///
    /// # Errors
    /// [`ModalModelError::Inconsistent`] naming the mismatch.
    pub fn check(&self) -> Result<(), ModalModelError> {
        let want = self.n_modes() * self.n_vertices() * 3;
        if self.shapes.len() != want {
            return Err(ModalModelError::Inconsistent(format!(
                "{} shape values, expected {} modes x {} vertices x 3 = {want}",
                self.shapes.len(),
                self.n_modes(),
                self.n_vertices()
            )));
        }
        let nv = self.n_vertices() as u64;
        if let Some(t) = self
            .triangles
            .iter()
            .find(|t| t.iter().any(|&i| i as u64 >= nv))
        {
            return Err(ModalModelError::Inconsistent(format!(
                "triangle {t:?} refers past the {nv} vertices"
            )));
        }
        if self.eigenvalues.iter().any(|l| !l.is_finite())
            || self.shapes.iter().any(|s| !s.is_finite())
        {
            return Err(ModalModelError::Inconsistent(
                "non-finite eigenvalue or shape value".into(),
            ));
        }
        if self.eigenvalues.windows(2).any(|w| w[1] < w[0]) {
            return Err(ModalModelError::Inconsistent(
                "eigenvalues are not ascending".into(),
            ));
        }
        Ok(())
    }

    /// Natural frequency of mode `j` in Hz.
    pub fn freq_hz(&self, j: usize) -> f64 {
        units::lambda_to_freq_hz(self.eigenvalues[j])
    }

    /// All natural frequencies in Hz, ascending.
    pub fn freqs_hz(&self) -> Vec<f64> {
        (0..self.n_modes()).map(|j| self.freq_hz(j)).collect()
    }

    /// γ₀ = E/ρ of the reference material the eigenvalues belong to, m²/s² (Ren 2013 eq. 10:
    /// a material of stiffness ratio γ has eigenvalues γ/γ₀ · λ).
    pub fn gamma0(&self) -> f64 {
        self.material.stiffness_density_ratio()
    }

    /// The natural frequencies, Hz, of this object made of a material with E/ρ = `gamma`
    /// (m²/s²; same ν): the eigenvalues scaled by γ/γ₀.
    pub fn freqs_hz_at(&self, gamma: f64) -> Vec<f64> {
        let ratio = gamma / self.gamma0();
        self.eigenvalues
            .iter()
            .map(|&l| units::lambda_to_freq_hz((l * ratio).max(0.0)))
            .collect()
    }

    /// Displacement of mode `j` at surface vertex `v` (1/√kg).
    pub fn shape(&self, j: usize, v: usize) -> [f32; 3] {
        let i = (j * self.n_vertices() + v) * 3;
        [self.shapes[i], self.shapes[i + 1], self.shapes[i + 2]]
    }

    /// The same object in another material with the same ν, without a new solve.
    ///
    /// K scales with E and M with ρ, so λ' = λ·(E'/ρ')/(E/ρ) (Ren 2013 eq. 10) and the
    /// mass-normalised shapes scale by √(ρ/ρ').
    ///
    /// # Errors
    /// [`ModalModelError::PoissonMismatch`] when ν differs, or an invalid material.
    pub fn rescaled(&self, material: &Material) -> Result<ModalModel, ModalModelError> {
        material.validate()?;
        if (material.poisson_ratio - self.material.poisson_ratio).abs() > 1e-12 {
            return Err(ModalModelError::PoissonMismatch {
                reference: self.material.poisson_ratio,
                new: material.poisson_ratio,
            });
        }
        let s_lambda = material.stiffness_density_ratio() / self.material.stiffness_density_ratio();
        let s_shape = (self.material.density / material.density).sqrt() as f32;
        Ok(ModalModel {
            material: material.clone(),
            eigenvalues: self.eigenvalues.iter().map(|l| l * s_lambda).collect(),
            shapes: self.shapes.iter().map(|s| s * s_shape).collect(),
            transfer: self.transfer.as_ref().map(|t| t.scaled(s_shape)),
            ..self.clone()
        })
    }

    /// Checks `query` against a surface by the rule of [`ModalModel::hit`] before any model
    /// exists (a hit off the object is refused before a solve of seconds, not after).
    ///
    /// # Errors
    /// [`ModalModelError::HitOffSurface`] when the point is farther from the surface.
    pub fn check_hit_on(
        vertices: &[[f64; 3]],
        triangles: &[[u32; 3]],
        query: [f64; 3],
    ) -> Result<(), ModalModelError> {
        let tolerance = hit_tolerance_m(vertices);
        match closest_surface_point(vertices, triangles, query) {
            Some(sp) if !(sp.distance <= tolerance) => Err(ModalModelError::HitOffSurface {
                point: query,
                distance: sp.distance,
                tolerance,
            }),
            _ => Ok(()),
        }
    }

    /// The surface point nearest to `p` (m), accepted when it is within `tolerance_m`.
    ///
    /// # Errors
    /// [`ModalModelError::HitOffSurface`] when farther, [`ModalModelError::Inconsistent`] for a
    /// model without triangles.
    pub fn locate_hit(
        &self,
        p: [f64; 3],
        tolerance_m: f64,
    ) -> Result<SurfacePoint, ModalModelError> {
        let sp = closest_surface_point(&self.vertices, &self.triangles, p).ok_or_else(|| {
            ModalModelError::Inconsistent("model has no surface triangles".into())
        })?;
        if !(sp.distance <= tolerance_m) {
            return Err(ModalModelError::HitOffSurface {
                point: p,
                distance: sp.distance,
                tolerance: tolerance_m,
            });
        }
        Ok(sp)
    }

    /// Snaps a hit to the surface: the nearest surface point to `query` (m), accepted within
    /// 5 % of the bounding-box diagonal, with the gains a⁰ there ([`ModalModel::gains`]). The
    /// one place a hit point becomes gains (analysis, estimation, synthesis, `modal --hit`).
    ///
    /// # Errors
    /// [`ModalModelError::HitOffSurface`] when the point is farther from the surface.
    pub fn hit(&self, query: [f64; 3]) -> Result<Hit, ModalModelError> {
        let at = self.locate_hit(query, hit_tolerance_m(&self.vertices))?;
        Ok(Hit {
            gains: self.gains(&at),
            at,
        })
    }

    /// Mode shape of mode `j` interpolated at a surface point (1/√kg).
    pub fn shape_at(&self, j: usize, sp: &SurfacePoint) -> [f64; 3] {
        let tri = self.triangles[sp.triangle];
        let mut u = [0.0; 3];
        for (k, &v) in tri.iter().enumerate() {
            let s = self.shape(j, v as usize);
            for c in 0..3 {
                u[c] += sp.bary[k] * s[c] as f64;
            }
        }
        u
    }

    /// [`ModalModel::gains`] at every surface vertex along its area-weighted normal,
    /// vertex-major (`n_vertices × n_modes`).
    pub fn vertex_gains(&self) -> Vec<f64> {
        let nv = self.n_vertices();
        let mut normals = vec![[0.0f64; 3]; nv];
        for t in &self.triangles {
            let [a, b, c] = t.map(|i| self.vertices[i as usize]);
            let u = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let v = [c[0] - a[0], c[1] - a[1], c[2] - a[2]];
            let n = [
                u[1] * v[2] - u[2] * v[1],
                u[2] * v[0] - u[0] * v[2],
                u[0] * v[1] - u[1] * v[0],
            ];
            for &i in t {
                for k in 0..3 {
                    normals[i as usize][k] += n[k];
                }
            }
        }
        let m = self.n_modes();
        let mut out = vec![0.0; nv * m];
        for (v, n) in normals.iter().enumerate() {
            let len = crate::geometry::dot(*n, *n).sqrt();
            if !(len > 0.0) {
                continue;
            }
            let n = [n[0] / len, n[1] / len, n[2] / len];
            for j in 0..m {
                let w = self.eigenvalues[j].max(0.0).sqrt();
                if w > 0.0 {
                    let s = self.shape(j, v);
                    let u = [f64::from(s[0]), f64::from(s[1]), f64::from(s[2])];
                    out[v * m + j] = crate::geometry::dot(u, n) / w;
                }
            }
        }
        out
    }

    /// Impulse-response gains a⁰_j = (φ_j·n)/ω_j (Ren 2013 eq. 11) for a unit impulse (1 N·s)
    /// along the surface normal at `sp`: the displacement amplitude (m) of mode j per N·s.
    /// Modes with ω = 0 get gain 0.
    pub fn gains(&self, sp: &SurfacePoint) -> Vec<f64> {
        (0..self.n_modes())
            .map(|j| {
                let u = self.shape_at(j, sp);
                let w = self.eigenvalues[j].max(0.0).sqrt();
                if w > 0.0 {
                    crate::geometry::dot(u, sp.normal) / w
                } else {
                    0.0
                }
            })
            .collect()
    }
}

/// How far a hit may lie from the surface and still be snapped to it: 5 % of the bounding
/// box's diagonal.
fn hit_tolerance_m(vertices: &[[f64; 3]]) -> f64 {
    let (lo, hi) = crate::geometry::bbox(vertices);
    0.05 * (0..3).map(|c| (hi[c] - lo[c]).powi(2)).sum::<f64>().sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toy() -> ModalModel {
        ModalModel {
            material: Material::preset("steel").unwrap(),
            eigenvalues: vec![1e6, 4e6],
            vertices: vec![[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]],
            triangles: vec![[0, 1, 2]],
            shapes: (0..18).map(|i| i as f32 * 0.1).collect(),
            fem_dofs: 9,
            fem_elements: 1,
            transfer: None,
        }
    }

    #[test]
    fn vertex_gains_equal_gains_at_the_vertices() {
        let m = toy();
        let vg = m.vertex_gains();
        for v in 0..3 {
            let sp = m.locate_hit(m.vertices[v], 1e-9).unwrap();
            let g = m.gains(&sp);
            for j in 0..2 {
                assert!((vg[v * 2 + j] - g[j]).abs() < 1e-9, "{v} {j}");
            }
        }
    }

    #[test]
    fn rescaling_follows_e_over_rho() {
        let m = toy();
        m.check().unwrap();
        let mut mat = m.material.clone();
        mat.youngs_modulus *= 4.0;
        mat.density *= 2.0;
        let r = m.rescaled(&mat).unwrap();
        // f ∝ sqrt(E/ρ): sqrt(4/2)
        assert!((r.freq_hz(1) / m.freq_hz(1) - 2f64.sqrt()).abs() < 1e-12);
        assert!((r.shapes[5] / m.shapes[5] - (0.5f32).sqrt()).abs() < 1e-6);
        mat.poisson_ratio = 0.25;
        assert!(matches!(
            m.rescaled(&mat),
            Err(ModalModelError::PoissonMismatch { .. })
        ));
    }

    #[test]
    fn hit_location_and_gain() {
        let m = toy();
        let sp = m.locate_hit([0.2, 0.2, 0.001], 0.01).unwrap();
        assert_eq!(sp.normal, [0.0, 0.0, 1.0]);
        let g = m.gains(&sp);
        let u = m.shape_at(0, &sp);
        assert!((g[0] - u[2] / 1e3).abs() < 1e-12);
        assert!(matches!(
            m.locate_hit([0.2, 0.2, 5.0], 0.01),
            Err(ModalModelError::HitOffSurface { .. })
        ));
        let mut bad = toy();
        bad.shapes.pop();
        assert!(bad.check().is_err());
    }
}
