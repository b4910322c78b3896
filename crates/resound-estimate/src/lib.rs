//! Resound material estimation (Ren 2013 §5) — in progress.
//!
//! - [`forward`]: modal model + Rayleigh parameters {α, β, γ, σ} → damped sinusoids (eqs. 6–12).
//! - [`psycho`]: ISO 226:2003 equal loudness, phon ↔ sone, critical-band rate (from `resound-signal`).
//! - [`residual`]: the residual of a recording against the estimated modes (§6.1).
//! - [`image`]: the loudness image (eq. 19), by STFT or in closed form from modes.
//! - [`features`]: the Match Ratio Product (eqs. 20–26).
//! - [`joint`]: one material from several recordings (strikes, microphones, objects).
//! - [`report`]: how sure an estimate is (paired modes, loudness share, α/β/γ uncertainty).
//! - [`mod@estimate`]: the hybrid metric (eq. 27), §5.3 starting points, multi-start Nelder–Mead.
#![warn(missing_docs)]

pub mod estimate;
pub mod features;
pub mod forward;
pub mod image;
pub mod joint;
pub mod report;
pub mod residual;
/// Psychoacoustic scales (in `resound-signal`; re-exported where the metric uses them).
pub use resound_signal::psycho;

pub use estimate::{estimate, Estimate, EstimateError, EstimateParams, ImageRoute, ModalSide};
pub use forward::{forward_modes, RayleighParams};
pub use joint::{estimate_joint, JointEstimate, Take};
