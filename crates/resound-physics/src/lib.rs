//! Sound for physics-driven scenes: rapier3d moves rigid bodies, and their contacts excite each
//! body's modal resonator bank (Ren 2013 Fig. 14; Picard 2009 §4.2 on telling contacts apart).
//!
//! Numeric only, no file I/O: bodies come in with their collider shape and sound model
//! ([`BodySound`]: modes and per-vertex gains), audio and events go out.
//!
//! **Contacts**, per physics step (1/240 s by default):
//! - *Impact*: a contact pair that was not touching at the previous step and approaches faster
//!   than 2 cm/s. The pulse carries rapier's solver impulse (restitution included) with the Hertz
//!   duration of the two bodies' materials, reduced mass and curvature, and starts at the
//!   interpolated instant of contact — the gap at the previous step's poses over the approach
//!   speed — not at the step boundary.
//! - *Sliding* and *rolling*: a persistent contact. The relative velocity of the two material
//!   points at the contact tells them apart: slip (tangential relative velocity) above 10 % of the
//!   bodies' own speed is sliding, a moving contact without slip is rolling, neither is resting
//!   (silent: no droning). Sliding drives both bodies with a fractal (1/f) surface profile read
//!   along the path, `F = μ_r F_n (v/1 m/s) n(s)`; rolling with the same profile low-passed at a
//!   speed-dependent cut-off and modulated by the rolling body's rotation (van den Doel et al.
//!   2001 style), at a third of the level. A body with a `surface` texture slides by Traer's
//!   scraping force instead (eq. 8: probe mass 0.1 g, shear coefficient μ F_n per m/s, γ = 1).
//! - Both bodies of a contact sound; the excitation follows the nearest surface vertex of each.
//! - A body with recorded *grains* ([`GrainSound`], Picard 2009 §4.2) also plays them: an impulsive
//!   phrase at each impact's force peak, scaled by the impulse; while it slides or rolls,
//!   continuous grains from a sliding or rolling recording, scaled by the contact power (normal
//!   force × speed) and pitched by the speed. Grains follow each other at their own pace between
//!   physics steps.
//!
//! **Event flow**, per step: the contact tracker classifies rapier's contact pairs and emits
//! typed [`Excitation`]s (the two bodies, contact point, normal, kind, force profile with its scale and
//! start within the step); the force models are `resound_synth::contact` (sliding, rolling,
//! scraping) and `resound_synth::excitation` (Hertz impacts). Each sounding body is a pinned
//! voice of the same allocation-free `resound_synth::Engine` that live playback uses: an
//! excitation sets the voice's gains at the surface vertex nearest the contact and schedules
//! its force; `Engine::process_voices` renders every body, and `resound_synth::spatial`
//! places it at the listener with 1/r distance attenuation (1 at 1 m, capped at 10 cm), the
//! propagation delay r/343 m/s (at most 1 s) and an equal-power pan (stereo). The offline
//! output is sample-identical to the earlier per-body renderer for the same bodies (the box and demo scenes, 24-bit
//! WAV compared byte for byte).

#![warn(missing_docs)]

pub mod contact;
pub mod live;
mod scene;

pub use contact::ContactKind;
pub use scene::{
    body_containing, check_start_overlaps, simulate, Event, Excitation, SceneOutput, ScenePhysics,
    SceneSources, SceneStats,
};

use resound_synth::excitation::Elastic;

/// A collider shape in the body's frame (metres).
#[derive(Clone, Debug, PartialEq)]
pub enum Shape {
    /// Sphere of this radius.
    Ball(f64),
    /// Box with these half extents.
    Cuboid([f64; 3]),
    /// Cylinder along z with this half height and radius.
    Cylinder {
        /// Half height.
        half_height: f64,
        /// Radius.
        radius: f64,
    },
    /// Convex hull of these points (dynamic bodies of arbitrary meshes).
    ConvexHull(Vec<[f64; 3]>),
    /// Triangle mesh (fixed bodies only).
    TriMesh {
        /// Vertices.
        vertices: Vec<[f64; 3]>,
        /// Triangles.
        triangles: Vec<[u32; 3]>,
    },
}

/// How a body sounds: modes and their gains at the surface vertices.
#[derive(Clone, Debug, PartialEq)]
pub struct BodySound {
    /// Damped frequency (Hz) and decay rate (1/s) of each mode.
    pub modes: Vec<(f64, f64)>,
    /// Surface vertices in the body frame.
    pub vertices: Vec<[f64; 3]>,
    /// Gain (output amplitude per N·s) of each mode at each vertex, vertex-major.
    pub gains: Vec<f32>,
    /// Elastic constants for Hertz contact.
    pub elastic: Elastic,
    /// Contact damping: the loss factor η this body takes on (and gives) across a contact that
    /// carries its whole weight; a pair of bodies shares the mean of theirs. See
    /// [`DEFAULT_CONTACT_LOSS`] and the scene module's docs.
    pub contact_loss: f64,
    /// How the modes radiate: the body's acoustic transfer (body frame) and, per mode of
    /// `modes`, its mode in the transfer. `None`: every mode radiates alike (1/r).
    pub radiation: Option<BodyRadiation>,
}

/// A body's acoustic transfer, shared by bodies of one model.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyRadiation {
    /// The transfer (body frame).
    pub transfer: std::sync::Arc<resound_core::AcousticTransfer>,
    /// Per mode of [`BodySound::modes`], its index in `transfer.modes`.
    pub modes: Vec<usize>,
}

/// The contact loss factor of a body that names none: each mode of a body resting with its
/// whole weight on another decays `π f η` 1/s faster (η = 0.02: a mode at 1 kHz loses
/// 40 dB in about 0.07 s more than on its own) — the order of the loss factors measured for
/// plates and beams on supports and in bolted joints (10⁻³–10⁻¹).
pub const DEFAULT_CONTACT_LOSS: f64 = 0.02;

/// One body of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct BodySpec {
    /// Name (for the event log).
    pub name: String,
    /// Collider shape.
    pub shape: Shape,
    /// Immovable (floor, table).
    pub fixed: bool,
    /// Density, kg/m³.
    pub density: f64,
    /// Position of the body origin, m.
    pub position: [f64; 3],
    /// Orientation as a rotation vector (axis × angle, rad).
    pub rotation: [f64; 3],
    /// Initial linear velocity, m/s.
    pub linvel: [f64; 3],
    /// Initial angular velocity, rad/s.
    pub angvel: [f64; 3],
    /// Restitution coefficient.
    pub restitution: f64,
    /// Friction coefficient.
    pub friction: f64,
    /// Sound model (`None`: silent body).
    pub sound: Option<BodySound>,
    /// A measured or procedural surface texture: sliding on (or with) this body excites by
    /// Traer's scraping force (eq. 8) along this profile instead of the generic fractal noise.
    pub surface: Option<std::sync::Arc<resound_synth::scrape::Surface>>,
    /// Recorded grains retargeted to this body's contacts (Picard 2009 §4.2), besides or instead
    /// of its modal sound.
    pub grains: Option<GrainSound>,
}

/// A body that sounds from recorded grains.
#[derive(Clone, Debug, PartialEq)]
pub struct GrainSound {
    /// The grain dictionary.
    pub dictionary: std::sync::Arc<resound_grains::Dictionary>,
    /// Levels, pitch scaling, variation and seed.
    pub params: resound_grains::player::PlayerParams,
}

/// Scene-wide settings.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneParams {
    /// Length, s.
    pub duration_s: f64,
    /// Output sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Listener position, m.
    pub listener: [f64; 3],
    /// Two channels (left/right along x) instead of one.
    pub stereo: bool,
    /// Seed of the surface textures.
    pub seed: u64,
    /// Physics steps per second.
    pub steps_per_s: f64,
    /// Gravity, m/s².
    pub gravity: [f64; 3],
    /// The air between bodies and listener (ISO 9613-1 absorption per mode); `None`: none.
    pub air: Option<resound_synth::air::Air>,
    /// A floor that reflects (an image source per body); `None`: free field.
    pub reflection: Option<resound_synth::spatial::FloorReflection>,
    /// Four channels of first-order ambisonics (AmbiX: W Y Z X, SN3D) instead of stereo.
    pub ambisonics: bool,
}

impl Default for SceneParams {
    fn default() -> Self {
        Self {
            duration_s: 3.0,
            sample_rate_hz: 48_000.0,
            listener: [0.0, 0.5, 1.0],
            stereo: true,
            seed: 1,
            steps_per_s: 240.0,
            gravity: [0.0, -9.81, 0.0],
            air: Some(resound_synth::air::Air::default()),
            reflection: None,
            ambisonics: false,
        }
    }
}

/// Why a scene cannot run.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SceneError {
    /// A body is unusable.
    #[error("body {name:?}: {message}")]
    Body {
        /// Body name.
        name: String,
        /// What is wrong.
        message: String,
    },
    /// A scene setting is unusable.
    #[error("{0}")]
    Setting(String),
    /// The synthesizer refused something.
    #[error(transparent)]
    Synth(#[from] resound_synth::SynthError),
}
