//! Resound: physically based contact sound. The facade: the pipeline crates re-exported, and
//! the pipeline itself as typed functions — what every front end (the `resound` CLI, a game
//! plugin, Python bindings) calls, so none of them re-implements a stage.
//!
//! From a recording of one strike to the same material on another shape:
//!
//! ```
//! use resound::prelude::*;
//! // The recorded object: a 100 × 30 × 5 mm bar, struck at (0.02, 0.01, 0.0025).
//! let bar = primitive::bar([0.1, 0.03, 0.005]);
//! let aluminium = Material::preset("aluminium")?;
//! let recorded = ModalBuilder::surface(&bar, &aluminium).modes(30).solve()?.model;
//! let hit = recorded.hit([0.02, 0.01, 0.0025])?;
//! # // Stands in for a recording: the built-in "metal" on that bar.
//! # let dir = tempfile::tempdir().unwrap();
//! # let wav = dir.path().join("strike.wav");
//! # let metal = SoundMaterial::builtin_named("metal").unwrap();
//! # let struck = Struck::Object { material: &metal, model: &recorded, hit: &hit, same_object: true };
//! # let sp = StrikeParams { duration_s: 1.0, ..Default::default() };
//! # let take = render_strike(struck, &sp)?.samples;
//! # let peak = take.iter().fold(0.0f32, |m, v| m.max(v.abs()));
//! # let lead: Vec<f32> = std::iter::repeat(0.0).take(2400).chain(take.iter().map(|v| 0.5 * v / peak)).collect();
//! # resound::io::write_wav(&wav, &lead, sp.sample_rate_hz, resound::io::WavFormat::Float32).unwrap();
//! // Its modes, and the material behind them (α, β, γ, σ and the residual).
//! let (_, analysis) = analyze_file(&wav, &Default::default(), &Default::default())?;
//! let params = EstimateMaterialParams { name: "bar".into(), ..Default::default() };
//! let (material, report) = estimate_material(&analysis, &recorded, &hit, &params, &|_| {})?;
//! assert!(report.fit.paired_modes >= 3, "{report}");
//! // The same material on a plate, struck by a 5 mm steel ball at 2 m/s.
//! let plate = primitive::bar([0.2, 0.15, 0.004]);
//! let other = ModalBuilder::surface(&plate, &aluminium).modes(30).solve()?.model;
//! let at = other.hit([0.05, 0.04, 0.002])?;
//! let struck = Struck::Object { material: &material, model: &other, hit: &at, same_object: false };
//! let strike = render_strike(struck, &StrikeParams { speed_m_s: 2.0, ..Default::default() })?;
//! assert!(strike.samples.iter().any(|v| v.abs() > 1e-6));
//! # Ok::<(), resound::Error>(())
//! ```
#![warn(missing_docs)]

pub use resound_core as core;
pub use resound_estimate as estimate;
pub use resound_fem as fem;
pub use resound_grains as grains;
pub use resound_io as io;
pub use resound_modal as modal;
pub use resound_physics as physics;
#[cfg(feature = "plot")]
pub use resound_plot as plot;
pub use resound_signal as signal;
pub use resound_stats as stats;
pub use resound_synth as synth;

pub mod batch;
#[cfg(feature = "plot")]
pub mod demo;
mod error;
pub mod files;
pub mod grain_files;
pub mod joint;
pub mod live;
pub mod material;
pub mod mesh;
pub mod model_cache;
pub mod object;
pub mod radiation;
pub mod recording;
pub mod scene;
pub mod scrape;
pub mod strike;

pub use error::{Error, Result};
pub use resound_core::progress::{self, Progress, ProgressFn, Stage, Warning, WarningKind};

/// The types and pipeline functions most programs need.
pub mod prelude {
    pub use crate::material::{estimate_material, resolve_material, EstimateMaterialParams};
    pub use crate::object::{load_object, ObjectParams};
    pub use crate::recording::{analyze_file, load_recording, RecordingParams};
    pub use crate::scene::{render_scene, SceneRenderParams};
    pub use crate::strike::{render_strike, StrikeParams, Struck};
    pub use resound_core::progress::{Progress, ProgressFn, Warning};
    pub use resound_core::{DampedMode, Hit, Material, ModalModel, SoundMaterial};
    pub use resound_fem::{primitive, SurfaceMesh, TetMesh};
    pub use resound_modal::{ModalBuilder, ModalParams, ModalSolveInfo};
    pub use resound_signal::{Analysis, AnalyzeParams};
}
