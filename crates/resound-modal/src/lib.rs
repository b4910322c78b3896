//! Modal analysis: the generalized symmetric eigenproblem K φ = λ M φ of a free object, solved by
//! shift-invert Lanczos with faer, and [`ModalModel`] construction.
//!
//! ```
//! use resound_core::Material;
//! use resound_fem::primitive;
//! use resound_modal::ModalBuilder;
//! let bar = primitive::bar([0.3, 0.02, 0.01]);
//! let steel = Material::preset("steel").unwrap();
//! let solved = ModalBuilder::surface(&bar, &steel).modes(3).resolution(30).solve().unwrap();
//! assert_eq!(solved.model.n_modes(), 3);
//! ```
//!
//! # Conventions
//! Eigenvalues λ = ω² (rad²/s²) ascending; eigenvectors M-orthonormal (φᵀMφ = 1, 1/√kg).
//! The six rigid-body modes of a free object are computed and then dropped.
#![warn(missing_docs)]

pub mod block_lanczos;
pub mod dense;
pub mod eigen;
pub mod model;
pub mod radiation;

pub use eigen::{solve_generalized, EigenInfo, EigenMethod, EigenParams, ModalError};
pub use model::{Geometry, ModalBuilder, ModalParams, ModalSolution, ModalSolveInfo, ModelError};
pub use radiation::{fit_transfer, model_transfer, TransferError, TransferInfo, TransferParams};
pub use resound_core::progress::{Progress, Stage};
pub use resound_core::ModalModel;
