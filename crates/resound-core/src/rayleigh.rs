//! Materials as the estimator finds them: Rayleigh damping (α, β), γ = E/ρ and the amplitude
//! scale σ (Ren 2013 §5), with where they came from.

use crate::DampedMode;
use serde::{Deserialize, Serialize};

/// Where an estimated material came from.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Provenance {
    /// The recording analysed.
    pub recording: String,
    /// The mesh or modal model of the recorded object.
    pub mesh: String,
    /// Hit point used (m), on the surface.
    pub hit: [f64; 3],
    /// Hybrid metric value at the estimate.
    pub metric: f64,
    /// The recording's modes (the reference features).
    pub features: Vec<DampedMode>,
}

/// A material for modal sound: Rayleigh damping, stiffness-to-density ratio, amplitude scale.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SoundMaterial {
    /// Name (the library key).
    pub name: String,
    /// Mass-proportional damping α (1/s).
    pub alpha: f64,
    /// Stiffness-proportional damping β (s).
    pub beta: f64,
    /// γ = E/ρ (m²/s²).
    pub gamma: f64,
    /// Amplitude scale σ.
    pub sigma: f64,
    /// Damping model: "rayleigh" (C = αM + βK, from `alpha` and `beta`) or "caughey"
    /// (C = M Σ_j c_j (M⁻¹K)^j, from `caughey`).
    pub damping_model: DampingModel,
    /// Caughey series coefficients c_0, c_1, … (units 1/s, s, s³, …) when `damping_model` is
    /// "caughey": mode i decays at d_i = ½ Σ_j c_j ω_i^(2j) (dissertation eq. 1.12).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub caughey: Vec<f64>,
    /// Per-mode damping overrides (mode index of the object it was measured on → d in 1/s).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub mode_damping: Vec<ModeDamping>,
    /// How it was obtained; `None` for presets.
    pub provenance: Option<Provenance>,
    /// The residual of Ren §6, when computed from the recording.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub residual: Option<Residual>,
}

/// One per-mode damping override.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ModeDamping {
    /// Mode index (ascending frequency, elastic modes only).
    pub mode: usize,
    /// Decay rate d, 1/s.
    pub damping_per_s: f64,
}

/// The residual of Ren 2013 §6.1 — what the recording holds beyond what the estimated modes
/// represent — as audio (the input of Ren's Algorithm 1), with the modes it was computed
/// against (needed to transfer it to other objects and hit points, §6.2). Its level is for a
/// unit impulse, like the modes' amplitudes.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Residual {
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// The residual signal from the onset, full scale = 1.
    pub samples: Vec<f32>,
    /// The estimated modes of the recorded object at the recorded hit (the source modes).
    pub source_modes: Vec<DampedMode>,
}

/// The forward model shared by synthesis and estimation (Ren eqs. 6–11): λ = scale·λ⁰,
/// d = `decay(i, λ)`, f = √(λ − d²)/2π, a = σ·|a⁰| with a negative a⁰ as phase π. Over-damped
/// modes and modes at or above `max_freq_hz` are left out; sorted by frequency.
pub fn damped_modes(
    eigenvalues0: &[f64],
    gains0: &[f64],
    scale: f64,
    sigma: f64,
    decay: &dyn Fn(usize, f64) -> f64,
    max_freq_hz: f64,
) -> Vec<DampedMode> {
    damped_modes_indexed(eigenvalues0, gains0, scale, sigma, decay, max_freq_hz)
        .into_iter()
        .map(|(_, m)| m)
        .collect()
}

/// [`damped_modes`] with each kept mode's index into `eigenvalues0` (to look up its gains
/// elsewhere, e.g. at every surface vertex).
pub fn damped_modes_indexed(
    eigenvalues0: &[f64],
    gains0: &[f64],
    scale: f64,
    sigma: f64,
    decay: &dyn Fn(usize, f64) -> f64,
    max_freq_hz: f64,
) -> Vec<(usize, DampedMode)> {
    let mut out: Vec<(usize, DampedMode)> = eigenvalues0
        .iter()
        .zip(gains0)
        .enumerate()
        .filter_map(|(i, (&l0, &a0))| {
            let lambda = scale * l0;
            let d = decay(i, lambda);
            let w2 = lambda - d * d;
            if !(w2 > 0.0) {
                return None;
            }
            let f = w2.sqrt() / std::f64::consts::TAU;
            (f < max_freq_hz).then(|| {
                (
                    i,
                    DampedMode {
                        freq_hz: f,
                        damping_per_s: d,
                        amplitude: sigma * a0.abs(),
                        phase_rad: if a0 < 0.0 { std::f64::consts::PI } else { 0.0 },
                    },
                )
            })
        })
        .collect();
    out.sort_by(|a, b| a.1.freq_hz.total_cmp(&b.1.freq_hz));
    out
}

/// Which damping a material file describes (`"damping_model"` in its JSON): the
/// serialized name of a [`Damping`] variant, whose values sit beside it in the file.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DampingModel {
    /// C = αM + βK, from `alpha` and `beta`.
    #[default]
    Rayleigh,
    /// The Caughey series, from `caughey`.
    Caughey,
}

/// How modes lose energy: d_i as a function of the undamped ω_i.
#[derive(Clone, Debug, PartialEq)]
pub enum Damping {
    /// C = αM + βK: d = (α + βω²)/2 (dissertation eq. 1.11).
    Rayleigh {
        /// Mass-proportional α, 1/s.
        alpha: f64,
        /// Stiffness-proportional β, s.
        beta: f64,
    },
    /// Caughey series: d = ½ Σ_j c_j ω^(2j) (eq. 1.12).
    Caughey(Vec<f64>),
}

impl Damping {
    /// Decay rate (1/s) of a mode with undamped eigenvalue λ = ω² (rad²/s²).
    pub fn damping_per_s(&self, lambda: f64) -> f64 {
        match self {
            Damping::Rayleigh { alpha, beta } => 0.5 * (alpha + beta * lambda),
            Damping::Caughey(c) => {
                let mut power = 1.0;
                let mut sum = 0.0;
                for cj in c {
                    sum += cj * power;
                    power *= lambda;
                }
                0.5 * sum
            }
        }
    }
}

impl SoundMaterial {
    /// A Rayleigh material without provenance.
    pub fn rayleigh(name: &str, alpha: f64, beta: f64, gamma: f64, sigma: f64) -> Self {
        Self {
            name: name.to_string(),
            alpha,
            beta,
            gamma,
            sigma,
            damping_model: DampingModel::Rayleigh,
            caughey: Vec::new(),
            mode_damping: Vec::new(),
            provenance: None,
            residual: None,
        }
    }

    /// Whether this material was estimated on the object `mesh` (as named in its provenance)
    /// struck at `point` (within 1 µm): then its residual transfers by natural pairing.
    pub fn was_estimated_on(&self, mesh: &str, point: [f64; 3]) -> bool {
        self.provenance
            .as_ref()
            .is_some_and(|p| p.mesh == mesh && (0..3).all(|i| (p.hit[i] - point[i]).abs() < 1e-6))
    }

    /// The damping model this material describes.
    pub fn damping(&self) -> Damping {
        if self.damping_model == DampingModel::Caughey {
            Damping::Caughey(self.caughey.clone())
        } else {
            Damping::Rayleigh {
                alpha: self.alpha,
                beta: self.beta,
            }
        }
    }

    /// The damped sinusoids of an object made of this material: `eigenvalues0` (rad²/s²) and
    /// unit-impulse amplitudes `gains0` of a modal model computed with `gamma0 = E₀/ρ₀`.
    /// λ = (γ/γ₀)λ⁰, d from the damping model (then per-mode overrides), f = √(λ − d²)/2π,
    /// a = σ·a⁰ (Ren eqs. 6–11). Over-damped modes and modes at or above `max_freq_hz` are left
    /// out; a negative a⁰ becomes phase π. Sorted by frequency.
    pub fn modes(
        &self,
        eigenvalues0: &[f64],
        gains0: &[f64],
        gamma0: f64,
        max_freq_hz: f64,
    ) -> Vec<DampedMode> {
        self.modes_indexed(eigenvalues0, gains0, gamma0, max_freq_hz)
            .into_iter()
            .map(|(_, m)| m)
            .collect()
    }

    /// [`SoundMaterial::modes`] with each kept mode's index into `eigenvalues0`.
    pub fn modes_indexed(
        &self,
        eigenvalues0: &[f64],
        gains0: &[f64],
        gamma0: f64,
        max_freq_hz: f64,
    ) -> Vec<(usize, DampedMode)> {
        let damping = self.damping();
        let decay = |i: usize, lambda: f64| {
            self.mode_damping
                .iter()
                .find(|o| o.mode == i)
                .map_or_else(|| damping.damping_per_s(lambda), |o| o.damping_per_s)
        };
        damped_modes_indexed(
            eigenvalues0,
            gains0,
            self.gamma / gamma0,
            self.sigma,
            &decay,
            max_freq_hz,
        )
    }

    /// Checks the values: finite, α, β ≥ 0, γ, σ > 0, a known damping model, a usable name.
    pub fn validate(&self) -> Result<(), String> {
        let name_ok = !self.name.trim().is_empty()
            && self.name.len() <= 128
            && !self.name.chars().any(char::is_control);
        if !name_ok {
            return Err(format!(
                "material name {:?} must be 1–128 printable characters",
                self.name
            ));
        }
        if self.damping_model == DampingModel::Caughey
            && (self.caughey.is_empty() || self.caughey.iter().any(|c| !c.is_finite()))
        {
            return Err(format!(
                "a Caughey material needs finite coefficients, got {:?}",
                self.caughey
            ));
        }
        if let Some(o) = self
            .mode_damping
            .iter()
            .find(|o| !(o.damping_per_s.is_finite() && o.damping_per_s >= 0.0))
        {
            return Err(format!(
                "mode {} damping override {} must be finite and ≥ 0",
                o.mode, o.damping_per_s
            ));
        }
        let ok = |v: f64| v.is_finite();
        if !(ok(self.alpha) && self.alpha >= 0.0 && ok(self.beta) && self.beta >= 0.0) {
            return Err(format!(
                "alpha ({}) and beta ({}) must be finite and ≥ 0",
                self.alpha, self.beta
            ));
        }
        if !(ok(self.gamma) && self.gamma > 0.0 && ok(self.sigma) && self.sigma > 0.0) {
            return Err(format!(
                "gamma ({}) and sigma ({}) must be finite and > 0",
                self.gamma, self.sigma
            ));
        }
        Ok(())
    }

    /// The five built-in materials, named after Ren 2013 Table I (wood, plastic, metal,
    /// glass, porcelain), in SI units.
    ///
    /// Table I's Rayleigh α (1/s) and β (s) carry over unchanged: a mode's decay
    /// d = ½(α + βω²) involves only time, so it does not depend on the mesh's length unit.
    /// Its γ and σ do not: for a given pitch γ scales as L² (f ∝ √γ / L), and σ maps mesh-unit
    /// gains to Ren's recording level. The paper gives neither the mesh unit nor the recording
    /// gain, and the unit implied by γ_phys / γ_Ren differs per object (√ of 22 for wood to
    /// 142 for glass), so no single conversion exists. γ is therefore the handbook E/ρ of each
    /// class (the elastic presets: wood 11 GPa / 750 kg/m³, ABS-like plastic 2.3 GPa /
    /// 1050 kg/m³, steel 200 GPa / 7850 kg/m³, soda-lime glass 72 GPa / 2500 kg/m³,
    /// porcelain 70 GPa / 2400 kg/m³), and σ is [`DEFAULT_SIGMA`]. On a 300 × 20 × 10 mm bar
    /// "metal" then rings at 577 Hz, the Euler–Bernoulli value for steel.
    pub fn builtin() -> Vec<SoundMaterial> {
        [
            ("wood", 2.1364e0, 3.0828e-6, 11e9 / 750.0),
            ("plastic", 5.2627e1, 8.7753e-7, 2.3e9 / 1050.0),
            ("metal", 6.3035e0, 2.1160e-8, 200e9 / 7850.0),
            ("glass", 1.8301e1, 1.4342e-7, 72e9 / 2500.0),
            ("porcelain", 3.7388e-2, 8.4142e-8, 70e9 / 2400.0),
        ]
        .iter()
        .map(|&(n, a, b, g)| SoundMaterial::rayleigh(n, a, b, g, DEFAULT_SIGMA))
        .collect()
    }

    /// The built-in material `name`, if there is one.
    pub fn builtin_named(name: &str) -> Option<SoundMaterial> {
        Self::builtin().into_iter().find(|m| m.name == name)
    }

    /// Ren 2013 Table I exactly as printed (γ and σ in the paper's mesh units, not SI). Kept to
    /// recognise library entries seeded with it by earlier versions; use [`Self::builtin`].
    pub fn ren_table_1_mesh_units() -> Vec<SoundMaterial> {
        [
            ("wood", 2.1364e0, 3.0828e-6, 6.6625e5, 3.3276e-6),
            ("plastic", 5.2627e1, 8.7753e-7, 8.9008e4, 2.2050e-6),
            ("metal", 6.3035e0, 2.1160e-8, 4.5935e5, 9.2624e-6),
            ("glass", 1.8301e1, 1.4342e-7, 2.0282e5, 1.1336e-6),
            ("porcelain", 3.7388e-2, 8.4142e-8, 3.7068e5, 4.3800e-7),
        ]
        .iter()
        .map(|&(n, a, b, g, s)| SoundMaterial::rayleigh(n, a, b, g, s))
        .collect()
    }

    /// Whether this is a Table I row in mesh units as earlier versions seeded libraries with
    /// (same name, no provenance, γ and σ as printed): it renders far too low in pitch and
    /// level on a mesh in metres.
    pub fn is_legacy_table_1(&self) -> bool {
        self.provenance.is_none()
            && Self::ren_table_1_mesh_units()
                .iter()
                .any(|t| t.name == self.name && t.gamma == self.gamma && t.sigma == self.sigma)
    }
}

/// The amplitude scale σ of materials not estimated from a recording (the built-ins and the
/// `preset:` materials): 100 full-scale units per metre of impulse-response displacement at
/// the reference impact. It is a calibration, like a microphone gain, not physics (σ of an
/// estimated material is the recording's own): with it the reference impactor (a 5 mm steel
/// ball at 1 m/s) on a hand-sized object (the 300 × 20 × 10 mm bar of each built-in, struck
/// 50 mm from its centre) peaks at −15 to −12 dBFS, so physical differences in level
/// between objects and materials are kept and nothing is inaudible or clipped by default.
pub const DEFAULT_SIGMA: f64 = 100.0;

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{PI, TAU};

    #[test]
    fn caughey_with_one_term_is_rayleighs_mass_part_and_two_terms_are_rayleigh() {
        for lambda in [1.0, 4e6, 3.9e9] {
            let c1 = Damping::Caughey(vec![7.5]).damping_per_s(lambda);
            let r = Damping::Rayleigh {
                alpha: 7.5,
                beta: 0.0,
            }
            .damping_per_s(lambda);
            assert_eq!(c1, r);
            let c2 = Damping::Caughey(vec![7.5, 2e-7]).damping_per_s(lambda);
            let r2 = Damping::Rayleigh {
                alpha: 7.5,
                beta: 2e-7,
            }
            .damping_per_s(lambda);
            assert!((c2 / r2 - 1.0).abs() < 1e-15);
        }
        // A third term adds c_2 ω⁴ / 2.
        let c3 = Damping::Caughey(vec![0.0, 0.0, 1e-15]).damping_per_s(1e8);
        assert!((c3 - 0.5 * 1e-15 * 1e16).abs() < 1e-9);
    }

    #[test]
    fn modes_follow_the_damping_model_and_overrides() {
        let mut m = SoundMaterial::rayleigh("x", 2.0, 1e-7, 2.0e7, 3.0);
        let l0 = [(TAU * 1000.0f64).powi(2), (TAU * 3000.0f64).powi(2)];
        let a = m.modes(&l0, &[1e-3, -2e-3], 1.0e7, 1e5);
        assert_eq!(a.len(), 2);
        let lambda = 2.0 * l0[0];
        assert!((a[0].damping_per_s - 0.5 * (2.0 + 1e-7 * lambda)).abs() < 1e-9);
        assert!((a[0].freq_hz - (lambda - a[0].damping_per_s.powi(2)).sqrt() / TAU).abs() < 1e-9);
        assert!((a[1].amplitude - 6e-3).abs() < 1e-15 && a[1].phase_rad == PI);
        m.mode_damping.push(ModeDamping {
            mode: 1,
            damping_per_s: 42.0,
        });
        assert_eq!(
            m.modes(&l0, &[1e-3, -2e-3], 1.0e7, 1e5)[1].damping_per_s,
            42.0
        );
        m.damping_model = DampingModel::Caughey;
        assert!(m.validate().is_err());
        m.caughey = vec![2.0, 1e-7];
        assert!(m.validate().is_ok());
        let c = m.modes(&l0, &[1e-3, -2e-3], 1.0e7, 1e5);
        assert!((c[0].damping_per_s - a[0].damping_per_s).abs() < 1e-12);
    }

    #[test]
    fn table_1_is_valid_and_bad_values_are_named() {
        let t = SoundMaterial::builtin();
        assert_eq!(t.len(), 5);
        // α, β as printed; γ physical (1e6–1e8 m²/s²); the printed rows are recognised.
        for (b, r) in t.iter().zip(SoundMaterial::ren_table_1_mesh_units()) {
            assert_eq!((b.alpha, b.beta), (r.alpha, r.beta));
            assert!(
                b.gamma > 1e6 && b.gamma < 1e8 && r.gamma < 1e6,
                "{}",
                b.name
            );
            assert!(r.is_legacy_table_1() && !b.is_legacy_table_1());
        }
        assert!(t.iter().all(|m| m.validate().is_ok()));
        let bad = SoundMaterial {
            alpha: -1.0,
            ..t[0].clone()
        };
        assert!(bad.validate().unwrap_err().contains("alpha"));
        let bad = SoundMaterial {
            gamma: f64::NAN,
            ..t[0].clone()
        };
        assert!(bad.validate().unwrap_err().contains("gamma"));
        let bad = SoundMaterial {
            name: " ".into(),
            ..t[0].clone()
        };
        assert!(bad.validate().is_err());
    }
}
