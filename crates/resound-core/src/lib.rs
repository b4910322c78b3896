//! Resound's shared vocabulary: [`Material`], [`ModalModel`], Rayleigh damping and unit conversions.
//!
//! ```
//! use resound_core::{Material, units};
//! let steel = Material::preset("steel").unwrap();
//! assert_eq!(steel.youngs_modulus, 200e9);
//! let omega = units::omega(1000.0);
//! assert!((units::freq_hz(omega) - 1000.0).abs() < 1e-9);
//! ```
//!
//! # Conventions
//! - SI units everywhere; names carry the unit (`freq_hz`, `density` in kg/m³, `youngs_modulus` in Pa).
//! - Eigenvalues are `lambda = omega²` in rad²/s²; modes are sorted by ascending frequency.
//! - Mode shapes are mass-normalised: φᵀ M φ = 1, so their unit is 1/√kg.
//! - Damping: amplitude ∝ e^(−decay·t); Rayleigh C = αM + βK, α in 1/s, β in s.
#![warn(missing_docs)]

pub mod damped;
pub mod geometry;
pub mod limits;
pub mod material;
pub mod modal_model;
pub mod progress;
pub mod radiation;
pub mod rayleigh;
pub mod units;

pub use damped::DampedMode;
pub use material::{Material, MaterialError};
pub use modal_model::{Hit, ModalModel, ModalModelError};
pub use progress::{Progress, ProgressFn, Stage, Warning, WarningKind};
pub use radiation::AcousticTransfer;
pub use rayleigh::{
    Damping, DampingModel, ModeDamping, Provenance, Residual, SoundMaterial, DEFAULT_SIGMA,
};
