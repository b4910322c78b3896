//! Modal analysis: the generalized symmetric eigenproblem K φ = λ M φ of a free object, solved by
//! shift-invert Lanczos with faer, and [`ModalModel`] construction.
//!
//! ```
//! use resound_core::Material;
//! use resound_fem::primitive;
//! use resound_modal::{compute_modal_model, ModalParams};
//! let bar = primitive::bar([0.3, 0.02, 0.01]);
//! let params = ModalParams { n_modes: Some(3), resolution: 30, ..Default::default() };
//! let (model, info) = compute_modal_model(&bar, &Material::preset("steel").unwrap(), &params, &|_| {}).unwrap();
//! assert_eq!(model.n_modes(), 3);
//! assert!(info.eigen.max_rel_residual <= 1e-3); // the default tolerance
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

pub use eigen::{solve_generalized, EigenInfo, EigenMethod, EigenParams, ModalError, Stage};
pub use model::{
    compute_modal_model, compute_modal_model_from_fem, compute_modal_model_from_tets,
    compute_modal_model_keep_fem, ModalParams, ModalSolveInfo, ModelError,
};
pub use resound_core::ModalModel;
