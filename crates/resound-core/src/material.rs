//! Linear isotropic elastic materials and presets.

use serde::{Deserialize, Serialize};

/// A linear isotropic elastic material.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Material {
    /// Name (a preset name or `custom`).
    pub name: String,
    /// Young's modulus E in Pa.
    pub youngs_modulus: f64,
    /// Poisson's ratio ν (dimensionless, −1 < ν < 0.5).
    pub poisson_ratio: f64,
    /// Density ρ in kg/m³.
    pub density: f64,
}

/// Errors for material values.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum MaterialError {
    /// A value is outside its physical range.
    #[error("{what} = {value} is outside the physical range {range}")]
    OutOfRange {
        /// Which parameter.
        what: &'static str,
        /// Its value.
        value: f64,
        /// The accepted range, in words.
        range: &'static str,
    },
    /// The preset name is unknown.
    #[error("unknown material preset '{0}' (known: {known})", known = Material::PRESET_NAMES.join(", "))]
    UnknownPreset(String),
    /// A `E,nu,rho` triple could not be parsed.
    #[error("cannot parse material '{0}': expected a preset name or E,nu,rho in Pa,-,kg/m^3 (e.g. 200e9,0.3,7850)")]
    Parse(String),
}

/// Preset table: (name, E in Pa, ν, ρ in kg/m³).
///
/// Handbook values (room temperature): structural steel, 6061 aluminium, soda-lime glass,
/// hard porcelain, oak along the grain treated as isotropic, ABS plastic.
const PRESETS: &[(&str, f64, f64, f64)] = &[
    ("steel", 200e9, 0.30, 7850.0),
    ("aluminium", 69e9, 0.33, 2700.0),
    ("glass", 72e9, 0.23, 2500.0),
    ("ceramic", 70e9, 0.22, 2400.0),
    ("wood", 11e9, 0.35, 750.0),
    ("plastic", 2.3e9, 0.35, 1050.0),
];

impl Material {
    /// Names accepted by [`Material::preset`]: the six presets and the built-in sound
    /// materials' names (`metal` is steel, `porcelain` ceramic; `aluminum` spells aluminium),
    /// so one vocabulary names a material everywhere.
    pub const PRESET_NAMES: &'static [&'static str] = &[
        "steel",
        "aluminium",
        "glass",
        "ceramic",
        "wood",
        "plastic",
        "metal",
        "porcelain",
    ];

    /// A custom material, validated.
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] for E ∉ (1e3, 1e13) Pa, ν ∉ (−1, 0.5), ρ ∉ (1, 1e5) kg/m³
    /// or non-finite values.
    pub fn new(
        name: &str,
        youngs_modulus: f64,
        poisson_ratio: f64,
        density: f64,
    ) -> Result<Self, MaterialError> {
        let m = Material {
            name: name.to_string(),
            youngs_modulus,
            poisson_ratio,
            density,
        };
        m.validate()?;
        Ok(m)
    }

    /// Checks that the values are physical (and not absurd).
    ///
    /// # Errors
    /// [`MaterialError::OutOfRange`] naming the first bad value.
    pub fn validate(&self) -> Result<(), MaterialError> {
        let check = |what, value: f64, lo: f64, hi: f64, range| {
            if value.is_finite() && value > lo && value < hi {
                Ok(())
            } else {
                Err(MaterialError::OutOfRange { what, value, range })
            }
        };
        check(
            "Young's modulus E (Pa)",
            self.youngs_modulus,
            1e3,
            1e13,
            "(1e3, 1e13)",
        )?;
        check(
            "Poisson's ratio nu",
            self.poisson_ratio,
            -1.0,
            0.4999,
            "(-1, 0.4999)",
        )?;
        check("density rho (kg/m^3)", self.density, 1.0, 1e5, "(1, 1e5)")
    }

    /// A preset by name (case-insensitive).
    ///
    /// # Errors
    /// [`MaterialError::UnknownPreset`].
    pub fn preset(name: &str) -> Result<Self, MaterialError> {
        let lower = name.to_ascii_lowercase();
        let key = match lower.as_str() {
            "porcelain" => "ceramic",
            "metal" => "steel",
            "aluminum" => "aluminium",
            k => k,
        };
        PRESETS
            .iter()
            .find(|p| p.0 == key)
            .map(|&(n, e, nu, rho)| Material {
                name: n.to_string(),
                youngs_modulus: e,
                poisson_ratio: nu,
                density: rho,
            })
            .ok_or(MaterialError::UnknownPreset(name.to_string()))
    }

    /// Parses a preset name or `E,nu,rho` (Pa, –, kg/m³).
    ///
    /// # Errors
    /// [`MaterialError`] when the text is neither, or the values are not physical.
    pub fn parse(text: &str) -> Result<Self, MaterialError> {
        let parts: Vec<&str> = text.split(',').map(str::trim).collect();
        if parts.len() == 3 {
            let v: Result<Vec<f64>, _> = parts.iter().map(|p| p.parse::<f64>()).collect();
            let v = v.map_err(|_| MaterialError::Parse(text.to_string()))?;
            return Material::new("custom", v[0], v[1], v[2]);
        }
        if parts.len() != 1 {
            return Err(MaterialError::Parse(text.to_string()));
        }
        Material::preset(text)
    }

    /// E/ρ in m²/s² (Ren 2013 eq. 10: eigenvalues scale linearly with it at fixed ν).
    pub fn stiffness_density_ratio(&self) -> f64 {
        self.youngs_modulus / self.density
    }

    /// Longitudinal bar wave speed √(E/ρ) in m/s.
    pub fn bar_wave_speed(&self) -> f64 {
        self.stiffness_density_ratio().sqrt()
    }

    /// Lamé parameters (λ, μ) in Pa.
    pub fn lame(&self) -> (f64, f64) {
        let (e, nu) = (self.youngs_modulus, self.poisson_ratio);
        let lambda = e * nu / ((1.0 + nu) * (1.0 - 2.0 * nu));
        let mu = e / (2.0 * (1.0 + nu));
        (lambda, mu)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn presets_are_valid_and_parse() {
        for n in Material::PRESET_NAMES {
            let m = Material::preset(n).unwrap();
            m.validate().unwrap();
            assert_eq!(Material::parse(n).unwrap(), m);
        }
        assert_eq!(Material::preset("Porcelain").unwrap().name, "ceramic");
        let c = Material::parse("200e9, 0.3, 7850").unwrap();
        assert_eq!(c.youngs_modulus, 200e9);
        assert_eq!(c.density, 7850.0);
    }

    #[test]
    fn absurd_values_are_rejected() {
        assert!(Material::new("x", -1.0, 0.3, 1000.0).is_err());
        assert!(Material::new("x", 1e9, 0.5, 1000.0).is_err());
        assert!(Material::new("x", 1e9, 0.3, f64::NAN).is_err());
        assert!(Material::new("x", 1e20, 0.3, 1000.0).is_err());
        assert!(matches!(
            Material::parse("unobtainium"),
            Err(MaterialError::UnknownPreset(_))
        ));
        assert!(matches!(
            Material::parse("1,2"),
            Err(MaterialError::Parse(_))
        ));
    }

    #[test]
    fn lame_parameters_recover_e_and_nu() {
        let m = Material::preset("steel").unwrap();
        let (l, mu) = m.lame();
        let e = mu * (3.0 * l + 2.0 * mu) / (l + mu);
        let nu = l / (2.0 * (l + mu));
        assert!((e - m.youngs_modulus).abs() < 1e-6 * e);
        assert!((nu - m.poisson_ratio).abs() < 1e-12);
    }
}
