//! Resound material estimation (Ren 2013 §5) — in progress.
//!
//! Present so far: the forward model that maps a modal model and Rayleigh parameters
//! {α, β, γ, σ} to damped sinusoids ([`forward`], Ren eqs. 6–12), and the psychoacoustic scales
//! the image-domain metric is built on ([`psycho`]: ISO 226:2003 equal loudness, phon ↔ sone,
//! critical-band rate). The metrics, the optimizer and the material library follow.
#![warn(missing_docs)]

pub mod estimate;
pub mod features;
pub mod forward;
pub mod image;
pub mod psycho;

pub use estimate::{estimate, Estimate, EstimateError, EstimateParams, ModalSide};
pub use forward::{forward_modes, RayleighParams};
