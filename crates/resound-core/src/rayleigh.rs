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
    /// Damping model; "rayleigh" (C = αM + βK) for now.
    pub damping_model: String,
    /// How it was obtained; `None` for presets.
    pub provenance: Option<Provenance>,
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
            damping_model: "rayleigh".to_string(),
            provenance: None,
        }
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
        if self.damping_model != "rayleigh" {
            return Err(format!(
                "unknown damping model {:?} (known: rayleigh)",
                self.damping_model
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

    /// The five materials of Ren 2013 Table I (wood, plastic, metal, glass, porcelain).
    pub fn ren_table_1() -> Vec<SoundMaterial> {
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
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn table_1_is_valid_and_bad_values_are_named() {
        let t = SoundMaterial::ren_table_1();
        assert_eq!(t.len(), 5);
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
