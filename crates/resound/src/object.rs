//! The struck object: a modal model from a saved `.rmodal` or from a mesh solved on the spot.

use crate::error::{Error, Result};
use resound_core::{Material, ModalModel};
use resound_io::{load_mesh, model_file, LoadedMesh};
use resound_modal::{Geometry, ModalBuilder, ModalParams, ModalSolution, Stage};
use std::path::Path;

/// How to turn a mesh file into a modal model.
#[derive(Clone, Debug, PartialEq)]
pub struct ObjectParams {
    /// Scale applied to the mesh coordinates (0.001 for a file in millimetres).
    pub scale: f64,
    /// The modal solve's settings (mode count or cutoff, resolution, …).
    pub modal: ModalParams,
    /// Material of the modal solve. For estimation and synthesis only its ν and E/ρ's ratio to
    /// the material's γ matter (λ rescales exactly); its density sets E = γρ for Hertz contact.
    pub reference_material: Material,
}

impl Default for ObjectParams {
    fn default() -> Self {
        Self {
            scale: 1.0,
            modal: ModalParams {
                n_modes: Some(200),
                ..Default::default()
            },
            reference_material: Material::preset("ceramic").unwrap_or_else(|_| unreachable!()),
        }
    }
}

/// Whether `path` names a saved modal model.
pub fn is_model_file(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("rmodal"))
}

/// Solves a mesh file (surface or tets) with `material`: the model, the solve's report and the
/// FE model (for exporting K and M).
///
/// # Errors
/// Unreadable meshes and failed solves, naming the file.
pub fn solve_mesh_file(
    path: &Path,
    scale: f64,
    material: &Material,
    params: &ModalParams,
    progress: &(dyn Fn(Stage) + Sync),
) -> Result<ModalSolution> {
    let mesh = load_mesh(path, scale)?;
    let geometry = match &mesh {
        LoadedMesh::Surface(s) => Geometry::Surface(s),
        LoadedMesh::Tets(t) => Geometry::Tets(t),
    };
    ModalBuilder::new(geometry, material)
        .params(params.clone())
        .progress(progress)
        .solve()
        .map_err(|e| Error::from(e).at(path))
}

/// The modal model of the object in `path`: loaded from a `.rmodal`, or solved from a mesh.
///
/// # Errors
/// Unreadable files, failed solves, and a model without modes.
pub fn load_object(
    path: &Path,
    params: &ObjectParams,
    progress: &(dyn Fn(Stage) + Sync),
) -> Result<ModalModel> {
    let model = if is_model_file(path) {
        model_file::load(path)?
    } else {
        solve_mesh_file(
            path,
            params.scale,
            &params.reference_material,
            &params.modal,
            progress,
        )?
        .model
    };
    if model.eigenvalues.is_empty() {
        return Err(crate::error::invalid(format!(
            "{}: the modal model has no modes",
            path.display()
        )));
    }
    Ok(model)
}
