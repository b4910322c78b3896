//! From a mesh and a material to a [`ModalModel`].

use crate::eigen::{solve_generalized, EigenInfo, EigenParams, ModalError};
use faer::Par;
use resound_core::progress::{ProgressFn, Warning, WarningKind};
use resound_core::{units, Material, ModalModel};
use resound_fem::discretize::{
    discretize_surface, discretize_tets, DiscretizeReport, FemError, VoxelParams,
};
use resound_fem::{FemModel, SurfaceMesh, TetMesh};
use std::time::Instant;

/// Settings of a modal analysis.
#[derive(Debug, Clone, PartialEq)]
pub struct ModalParams {
    /// Number of elastic modes wanted; `None` means all up to `max_freq_hz`. With both set:
    /// every mode below `max_freq_hz`, at most this many (none above the cutoff is solved).
    pub n_modes: Option<usize>,
    /// Frequency cutoff (Hz) for the given material; 20 kHz when neither is set.
    pub max_freq_hz: Option<f64>,
    /// Voxels along the longest side (0: automatic from `target_voxels`).
    pub resolution: usize,
    /// Inside voxels aimed at when `resolution` is 0.
    pub target_voxels: usize,
    /// Lumped instead of consistent mass.
    pub lumped_mass: bool,
    /// Fill surface holes up to this many boundary edges.
    pub max_hole_edges: usize,
    /// Certify the mode count by inertia (one extra factorization).
    pub sturm_check: bool,
    /// Relative residual tolerance ‖Kφ − λMφ‖/(λ‖Mφ‖).
    pub tolerance: f64,
    /// Cap on modes with a cutoff.
    pub max_modes: usize,
    /// Threads (0: all cores).
    pub threads: usize,
    /// Krylov method (block Lanczos by default; faer's Lanczos as a baseline).
    pub method: crate::EigenMethod,
}

impl Default for ModalParams {
    fn default() -> Self {
        let v = VoxelParams::default();
        ModalParams {
            n_modes: None,
            max_freq_hz: None,
            resolution: 0,
            target_voxels: v.target_voxels,
            lumped_mass: false,
            max_hole_edges: 0,
            sturm_check: true,
            tolerance: 1e-3,
            max_modes: 2000,
            threads: 0,
            method: crate::EigenMethod::BlockLanczos,
        }
    }
}

/// Errors of [`ModalBuilder::solve`].
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum ModelError {
    /// Discretization failed.
    #[error(transparent)]
    Fem(#[from] FemError),
    /// The eigen-solve failed.
    #[error(transparent)]
    Eigen(#[from] ModalError),
    /// Parameters make no sense.
    #[error("invalid parameters: {0}")]
    Params(String),
    /// No elastic mode in the band asked for.
    #[error("{0}")]
    NoModes(String),
}

/// What a modal analysis did, for reports and benchmarks.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct ModalSolveInfo {
    /// Discretization report (surface input only).
    pub discretize: Option<DiscretizeReport>,
    /// Eigen-solve report.
    pub eigen: EigenInfo,
    /// Element type.
    pub element: &'static str,
    /// Elements.
    pub elements: usize,
    /// DOFs.
    pub dofs: usize,
    /// Discretization + assembly wall time (s).
    pub assemble_s: f64,
    /// Everything (s).
    pub total_s: f64,
    /// Rigid-body modes dropped.
    pub rigid_modes: usize,
    /// Largest |frequency| among them (Hz): ≈ 0 for a free object.
    pub rigid_max_hz: f64,
    /// Things the user should know.
    pub warnings: Vec<Warning>,
}

/// What a modal model is computed from.
#[derive(Clone, Copy, Debug)]
pub enum Geometry<'a> {
    /// A closed surface: repaired, voxelized into hex8i elements.
    Surface(&'a SurfaceMesh),
    /// A tet mesh used as is (quadratic tets).
    Tets(&'a TetMesh),
    /// An assembled model with `components` free parts (6 rigid modes each).
    Fem {
        /// The assembled K, M and surface.
        fem: &'a FemModel,
        /// Free parts.
        components: usize,
    },
}

/// The one way to build a [`ModalModel`] (rapier-style builder over [`ModalParams`]).
///
/// ```
/// use resound_core::Material;
/// use resound_fem::primitive;
/// use resound_modal::ModalBuilder;
/// let bar = primitive::bar([0.3, 0.02, 0.01]);
/// let steel = Material::preset("steel").unwrap();
/// let solved = ModalBuilder::surface(&bar, &steel).modes(3).resolution(30).solve().unwrap();
/// assert_eq!(solved.model.n_modes(), 3);
/// assert!(solved.info.eigen.max_rel_residual <= 1e-3); // the default tolerance
/// ```
pub struct ModalBuilder<'a> {
    geometry: Geometry<'a>,
    material: &'a Material,
    params: ModalParams,
    progress: ProgressFn<'a>,
}

/// A solved modal analysis.
#[derive(Debug)]
pub struct ModalSolution {
    /// Frequencies and surface shapes.
    pub model: ModalModel,
    /// What the solve did.
    pub info: ModalSolveInfo,
    /// The assembled FE model (to export K and M); `None` when the builder was given one.
    pub fem: Option<FemModel>,
}

impl<'a> ModalBuilder<'a> {
    /// From any [`Geometry`], with default [`ModalParams`] (all modes up to 20 kHz).
    pub fn new(geometry: Geometry<'a>, material: &'a Material) -> Self {
        Self {
            geometry,
            material,
            params: ModalParams::default(),
            progress: &resound_core::progress::ignore,
        }
    }
    /// From a closed surface mesh.
    pub fn surface(mesh: &'a SurfaceMesh, material: &'a Material) -> Self {
        Self::new(Geometry::Surface(mesh), material)
    }
    /// From a tet mesh.
    pub fn tets(mesh: &'a TetMesh, material: &'a Material) -> Self {
        Self::new(Geometry::Tets(mesh), material)
    }
    /// All settings at once.
    pub fn params(mut self, params: ModalParams) -> Self {
        self.params = params;
        self
    }
    /// The lowest `n` elastic modes (instead of a cutoff).
    pub fn modes(mut self, n: usize) -> Self {
        self.params.n_modes = Some(n);
        self
    }
    /// Every mode up to `f` Hz.
    pub fn max_freq_hz(mut self, f: f64) -> Self {
        self.params.max_freq_hz = Some(f);
        self
    }
    /// Voxels along the longest side (0: automatic).
    pub fn resolution(mut self, n: usize) -> Self {
        self.params.resolution = n;
        self
    }
    /// Skip or do the Sturm count check.
    pub fn sturm_check(mut self, on: bool) -> Self {
        self.params.sturm_check = on;
        self
    }
    /// Solver stages are reported here.
    pub fn progress(mut self, progress: ProgressFn<'a>) -> Self {
        self.progress = progress;
        self
    }
    /// Discretizes (unless given an FE model), solves, and interpolates the shapes on the
    /// surface.
    ///
    /// # Errors
    /// [`ModelError`] for unusable meshes, materials, parameters or a failed solve.
    pub fn solve(self) -> Result<ModalSolution, ModelError> {
        let (p, m, f) = (&self.params, self.material, self.progress);
        match self.geometry {
            Geometry::Surface(s) => {
                solve_surface(s, m, p, f).map(|(model, info, fem)| ModalSolution {
                    model,
                    info,
                    fem: Some(fem),
                })
            }
            Geometry::Tets(t) => solve_tets(t, m, p, f).map(|(model, info, fem)| ModalSolution {
                model,
                info,
                fem: Some(fem),
            }),
            Geometry::Fem { fem, components } => {
                check_params(p)?;
                solve_fem(fem, m, p, components, f).map(|(model, info)| ModalSolution {
                    model,
                    info,
                    fem: None,
                })
            }
        }
    }
}

fn solve_surface(
    mesh: &SurfaceMesh,
    material: &Material,
    params: &ModalParams,
    progress: ProgressFn<'_>,
) -> Result<(ModalModel, ModalSolveInfo, FemModel), ModelError> {
    check_params(params)?;
    let t0 = Instant::now();
    let vp = VoxelParams {
        resolution: params.resolution,
        target_voxels: params.target_voxels,
        lumped_mass: params.lumped_mass,
        max_hole_edges: params.max_hole_edges,
        ..Default::default()
    };
    let (fem, report) = discretize_surface(mesh, material, &vp)?;
    let assemble_s = t0.elapsed().as_secs_f64();
    let (model, mut info) = solve_fem(&fem, material, params, 1, progress)?;
    if report.dropped_voxels > 0 {
        info.warnings.push(Warning::new(
            WarningKind::Model,
            format!(
                "{} voxels not face-connected to the main body were dropped (thin parts; raise the voxel resolution)",
                report.dropped_voxels
            ),
        ));
    }
    info.discretize = Some(report);
    info.assemble_s = assemble_s;
    info.total_s = t0.elapsed().as_secs_f64();
    Ok((model, info, fem))
}

fn solve_tets(
    tets: &TetMesh,
    material: &Material,
    params: &ModalParams,
    progress: ProgressFn<'_>,
) -> Result<(ModalModel, ModalSolveInfo, FemModel), ModelError> {
    check_params(params)?;
    let t0 = Instant::now();
    let fem = discretize_tets(tets, material, params.lumped_mass)?;
    let components = tet_components(tets);
    let assemble_s = t0.elapsed().as_secs_f64();
    let (model, mut info) = solve_fem(&fem, material, params, components, progress)?;
    info.warnings.extend(
        fem.notes
            .iter()
            .map(|n| Warning::new(WarningKind::Model, n.clone())),
    );
    if components > 1 {
        info.warnings.push(Warning::new(
            WarningKind::Model,
            format!(
                "the tet mesh has {components} separate parts; {} rigid modes dropped",
                6 * components
            ),
        ));
    }
    info.assemble_s = assemble_s;
    info.total_s = t0.elapsed().as_secs_f64();
    Ok((model, info, fem))
}

fn tet_components(t: &TetMesh) -> usize {
    let mut parent: Vec<usize> = (0..t.nodes.len()).collect();
    fn find(p: &mut [usize], mut x: usize) -> usize {
        while p[x] != x {
            p[x] = p[p[x]];
            x = p[x];
        }
        x
    }
    for tet in &t.tets {
        let a = find(&mut parent, tet[0] as usize);
        for &v in &tet[1..] {
            let b = find(&mut parent, v as usize);
            parent[b] = a;
        }
    }
    let mut roots: Vec<usize> = t
        .tets
        .iter()
        .map(|tet| find(&mut parent, tet[0] as usize))
        .collect();
    roots.sort_unstable();
    roots.dedup();
    roots.len()
}

fn check_params(p: &ModalParams) -> Result<(), ModelError> {
    if let Some(f) = p.max_freq_hz {
        if !(f > 0.0 && f.is_finite()) {
            return Err(ModelError::Params(format!(
                "max frequency {f} Hz must be positive"
            )));
        }
    }
    if p.n_modes == Some(0) {
        return Err(ModelError::Params(
            "the mode count must be at least 1".into(),
        ));
    }
    if p.max_modes == 0 {
        return Err(ModelError::Params(
            "the maximum mode count must be at least 1".into(),
        ));
    }
    if let Some(n) = p.n_modes.filter(|&n| n > p.max_modes) {
        return Err(ModelError::Params(format!(
            "{n} modes is more than the supported {} (the Krylov space grows as 3x the modes)",
            p.max_modes
        )));
    }
    if p.resolution > 2000 {
        return Err(ModelError::Params(format!(
            "resolution {} is absurd (at most 2000)",
            p.resolution
        )));
    }
    Ok(())
}

fn solve_fem(
    fem: &FemModel,
    material: &Material,
    params: &ModalParams,
    components: usize,
    progress: ProgressFn<'_>,
) -> Result<(ModalModel, ModalSolveInfo), ModelError> {
    let t0 = Instant::now();
    let rigid = 6 * components.max(1);
    // Shift: 10 % of the axial fundamental c/(2L) of the largest dimension: near the first
    // elastic mode of slender objects (0.07 c/2L for the 30:1 test bar) and below it for compact
    // ones. Far below λ₁ the rigid modes dominate θ_max = 1/|σ| and the elastic pairs converge
    // slowly; above it nothing breaks (σ < 0 keeps K − σM positive definite).
    let (lo, hi) = fem.surface.bbox();
    let lmax = (0..3).map(|c| hi[c] - lo[c]).fold(0.0, f64::max).max(1e-9);
    let f_ref = material.bar_wave_speed() / (2.0 * lmax);
    let shift = -units::freq_hz_to_lambda(0.1 * f_ref);
    let size_warning = implausible_size(lmax);
    let cutoff = match (params.n_modes, params.max_freq_hz) {
        (None, None) => Some(20_000.0),
        (_, f) => f,
    };
    let until = cutoff.map(units::freq_hz_to_lambda);
    let n_eigen = match params.n_modes {
        Some(n) => n + rigid,
        None => rigid + 40,
    };
    let ep = EigenParams {
        n_eigen: n_eigen.min(fem.n_dofs()),
        shift,
        tolerance: params.tolerance,
        // A count and a cutoff: every mode below the cutoff, at most the count (the same
        // modes as the lowest `n` cut at the cutoff, without solving those above it).
        until_lambda: until,
        max_eigen: params.n_modes.unwrap_or(params.max_modes) + rigid,
        cap_at_max: params.n_modes.is_some(),
        sturm_check: params.sturm_check,
        dof_order: fem.dof_order.clone(),
        method: params.method,
        par: if params.threads == 0 {
            Par::rayon(0)
        } else if params.threads == 1 {
            Par::Seq
        } else {
            Par::rayon(params.threads)
        },
        ..Default::default()
    };
    let (lambdas, phi, einfo) = solve_generalized(fem.k.as_ref(), fem.m.as_ref(), &ep, progress)?;
    let mut info = ModalSolveInfo {
        element: fem.element,
        elements: fem.n_elements,
        dofs: fem.n_dofs(),
        rigid_modes: rigid.min(lambdas.len()),
        ..Default::default()
    };
    info.rigid_max_hz = lambdas[..info.rigid_modes]
        .iter()
        .map(|l| units::lambda_to_freq_hz(l.abs()))
        .fold(0.0, f64::max);
    let mut keep: Vec<usize> = (info.rigid_modes..lambdas.len()).collect();
    if let Some(f) = cutoff {
        let lc = units::freq_hz_to_lambda(f);
        keep.retain(|&j| lambdas[j] <= lc);
    }
    if let Some(n) = params.n_modes {
        keep.truncate(n);
    }
    if keep.is_empty() {
        let f = cutoff.unwrap_or(20_000.0);
        return Err(ModelError::NoModes(format!(
            "the object has no elastic mode below {f:.0} Hz (a stiff or small object: a 1 cm \
             steel cube rings near 170 kHz); raise the cutoff, ask for a mode count, or check \
             the mesh's size and unit{}",
            if fem.n_dofs() <= 3 * 8 {
                " (the model has only 8 nodes: raise the resolution)"
            } else {
                ""
            }
        )));
    }
    if let Some(&first) = keep.first() {
        let f1 = units::lambda_to_freq_hz(lambdas[first]);
        if info.rigid_max_hz > 1e-2 * f1 {
            info.warnings.push(Warning::new(
                WarningKind::Model,
                format!(
                    "rigid-body modes are not near zero ({:.3} Hz vs first elastic {f1:.1} Hz): the model may contain a mechanism (parts joined by an edge or a vertex)",
                    info.rigid_max_hz
                ),
            ));
        }
    }
    if let (Some(from), Some(&last)) = (einfo.truncated_from, keep.last()) {
        info.warnings.push(Warning::new(
            WarningKind::Model,
            format!(
                "only the lowest {} of the {} modes asked for met the residual tolerance (up to {:.0} Hz): the higher ones are left out (ask for at most that many modes to avoid this)",
                keep.len(),
                from.saturating_sub(info.rigid_modes),
                units::lambda_to_freq_hz(lambdas[last])
            ),
        ));
    }
    if einfo.loose_pairs > 0 {
        info.warnings.push(Warning::new(
            WarningKind::Model,
            format!(
                "{} of the {} modes kept met the residual tolerance {:.0e} only within {:.1e} (after every retry); their frequencies are still far more accurate than hearing",
                einfo.loose_pairs,
                keep.len(),
                params.tolerance,
                einfo.max_rel_residual
            ),
        ));
    }
    info.warnings.extend(size_warning);
    if einfo.capped {
        info.warnings.push(Warning::new(
            WarningKind::Model,
            format!(
                "stopped at {} modes (up to {:.0} Hz): the modes above, up to the cutoff {:.0} Hz, are left out",
                keep.len(),
                keep.last().map_or(0.0, |&j| units::lambda_to_freq_hz(lambdas[j])),
                cutoff.unwrap_or(0.0)
            ),
        ));
    }
    let nv = fem.surface.vertices.len();
    let mut shapes = Vec::with_capacity(keep.len() * nv * 3);
    let mut col = vec![0.0; fem.n_dofs()];
    for &j in &keep {
        for (i, c) in col.iter_mut().enumerate() {
            *c = phi[(i, j)];
        }
        for u in fem.surface_field(&col) {
            shapes.extend(u.iter().map(|&x| x as f32));
        }
    }
    let model = ModalModel {
        material: material.clone(),
        eigenvalues: keep.iter().map(|&j| lambdas[j].max(0.0)).collect(),
        vertices: fem.surface.vertices.clone(),
        triangles: fem.surface.triangles.clone(),
        shapes,
        fem_dofs: fem.n_dofs() as u64,
        fem_elements: fem.n_elements as u64,
        transfer: None,
    };
    info.eigen = einfo;
    info.total_s = t0.elapsed().as_secs_f64();
    Ok((model, info))
}

/// A warning when an object's largest side (m) is outside what sounds when struck: a mesh
/// in millimetres read as metres is a 300 m bar whose first mode is below 1 Hz.
pub fn implausible_size(largest_side_m: f64) -> Option<Warning> {
    let message = if largest_side_m > 5.0 {
        format!(
            "the object is {largest_side_m:.3} m across: if the mesh is in millimetres scale it by 0.001 (centimetres: 0.01)"
        )
    } else if largest_side_m < 0.002 {
        format!(
            "the object is {:.3} mm across: if the mesh is in metres already, was it scaled twice? (a struck object is rarely smaller than a few millimetres)",
            largest_side_m * 1e3
        )
    } else {
        return None;
    };
    Some(Warning::new(WarningKind::Model, message))
}
