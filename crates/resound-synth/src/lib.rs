//! Resound sound out: the resonator engine, contact forces and Ren's residual (§6).
//!
//! Numeric only, no file I/O. Audio is `f32` at the engine's sample rate; analysis-side inputs
//! (modes, materials) are `f64`.
//!
//! - [`bank`]: one object's modes as an f32 SIMD resonator bank, exact (impulse-invariant) and
//!   drift-corrected.
//! - [`engine`]: voices, force scheduling, culling and voice stealing; allocation-free
//!   `process`.
//! - [`excitation`]: impact force pulses (spring, Hertz, impulse).
//! - [`render`]: offline rendering of one strike.
//! - [`residual`]: the residual's transfer (§6.2) and reconstruction.
//! - [`contact`]: continuous contact forces (sliding, rolling, textured scraping) step by step.
//! - [`spatial`]: placing sources at a listener (distance, delay, pan).
//! - [`radiation`]: a moving body's per-mode radiation factors at the listener.
//! - [`scene_audio`]: the audio side of a scene (offline and live): voices, grains and the
//!   spatializer fed by lock-free queues of cues.
//! - [`live`]: a single-object live frontend/backend and the simulated audio clock.
#![warn(missing_docs)]

pub mod air;
pub mod bank;
pub mod contact;
pub mod engine;
pub mod excitation;
pub mod live;
pub mod radiation;
pub mod render;
pub mod residual;
pub mod scene_audio;
pub mod scrape;
pub mod spatial;

pub use bank::{BankMode, ModalBank};
pub use engine::{Engine, EngineParams, VoiceId};
pub use excitation::{ContactModel, Elastic, Impact};

/// Largest block [`Engine::process`] renders at once, samples.
pub const MAX_BLOCK: usize = 1024;

/// Why synthesis cannot run.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SynthError {
    /// Unusable sample rate.
    #[error("sample rate {0} Hz is out of range (1 kHz – 768 kHz)")]
    SampleRate(f64),
    /// More modes than the bank was prepared for.
    #[error("{wanted} modes do not fit a bank prepared for {capacity}")]
    Capacity {
        /// Modes asked for.
        wanted: usize,
        /// Modes prepared.
        capacity: usize,
    },
    /// A parameter out of range.
    #[error("{0}")]
    Parameter(String),
}
