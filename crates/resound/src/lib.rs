//! Resound: physically based contact sound. This facade re-exports the pipeline crates.
//!
//! ```
//! use resound::prelude::*;
//! let steel = Material::preset("steel").unwrap();
//! let bar = primitive::bar([0.3, 0.02, 0.01]);
//! assert_eq!(bar.triangles.len(), 12);
//! # let _ = steel;
//! ```
#![warn(missing_docs)]

pub use resound_core as core;
pub use resound_estimate as estimate;
pub use resound_fem as fem;
pub use resound_grains as grains;
pub use resound_io as io;
pub use resound_modal as modal;
pub use resound_physics as physics;
pub use resound_signal as signal;
pub use resound_stats as stats;
pub use resound_synth as synth;

pub mod scene;

/// The types most programs need.
pub mod prelude {
    pub use resound_core::{DampedMode, Material, ModalModel};
    pub use resound_fem::{primitive, SurfaceMesh, TetMesh};
    pub use resound_modal::{ModalParams, ModalSolveInfo};
}
