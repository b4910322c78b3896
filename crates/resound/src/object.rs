//! The struck object: a modal model from a saved `.rmodal` or from a mesh solved on the spot.

use crate::error::{Error, Result};
use resound_core::progress::ProgressFn;
use resound_core::{Hit, Material, ModalModel};
use resound_io::{load_mesh, model_file, LoadedMesh};
use resound_modal::{Geometry, ModalBuilder, ModalParams, ModalSolution, ModalSolveInfo};
use serde::{Deserialize, Serialize};
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

impl ObjectParams {
    /// `n_modes` modes of the mesh scaled by `scale`, solved with the reference material
    /// `reference` (a preset name or `E,nu,rho`).
    ///
    /// # Errors
    /// An unknown or invalid reference material.
    pub fn new(scale: f64, n_modes: usize, reference: &str) -> Result<Self> {
        Ok(Self {
            scale,
            modal: ModalParams {
                n_modes: Some(n_modes),
                ..Default::default()
            },
            reference_material: Material::parse(reference)?,
        })
    }
}

impl ObjectParams {
    /// These settings solving only what sounds for a material of stiffness–density ratio
    /// `gamma_m2_s2` (E/ρ): the modes below `top_hz` in that material, the mode count kept as
    /// the cap. Modes above the band are never heard (a render drops those above its Nyquist
    /// frequency), and solving them cost most of the time: 200 modes of a 10 cm steel bar reach
    /// 270 kHz. Settings with a cutoff of their own, or without a count, are returned as
    /// they are.
    pub fn band_limited(&self, gamma_m2_s2: f64, top_hz: f64) -> ObjectParams {
        let mut p = self.clone();
        let gamma0 = self.reference_material.stiffness_density_ratio();
        if p.modal.n_modes.is_some()
            && p.modal.max_freq_hz.is_none()
            && gamma_m2_s2 > 0.0
            && gamma0 > 0.0
            && top_hz > 0.0
            && (gamma_m2_s2 * top_hz).is_finite()
        {
            // λ scales with γ: f in the reference material is f·√(γ₀/γ). 2 % above, for the
            // damped frequency's shift.
            p.modal.max_freq_hz = Some(1.02 * top_hz * (gamma0 / gamma_m2_s2).sqrt());
        }
        p
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
    progress: ProgressFn<'_>,
) -> Result<ModalSolution> {
    if !(1e-6..=1e6).contains(&scale) {
        return Err(crate::error::invalid(format!(
            "scale must be within 1e-6–1e6 (0.001 reads millimetres), got {scale}"
        )));
    }
    let mesh = load_mesh(path, scale)?;
    let geometry = match &mesh {
        LoadedMesh::Surface(s) => Geometry::Surface(s),
        LoadedMesh::Tets(t) => Geometry::Tets(t),
    };
    let points = match &mesh {
        LoadedMesh::Surface(s) => &s.vertices,
        LoadedMesh::Tets(t) => &t.nodes,
    };
    let (lo, hi) = resound_core::geometry::bbox(points);
    let size_m = (0..3).map(|c| hi[c] - lo[c]).fold(0.0, f64::max);
    ModalBuilder::new(geometry, material)
        .params(params.clone())
        .progress(progress)
        .solve()
        .map_err(|e| {
            let e = Error::from(e);
            if e.is_too_many_modes() {
                // The size tells a file in millimetres from a band too wide; each front end
                // names its own settings for both (`Error::is_too_many_modes`).
                e.context(format!(
                    "{} (the object spans {size_m:.3} m)",
                    path.display()
                ))
            } else {
                e.at(path)
            }
        })
}

/// Refuses a hit off the surface of the mesh in `path` (scaled by `scale`) before any solve,
/// by the rule the solved model applies ([`ModalModel::hit`]): a wrong hit costs
/// milliseconds, not a solve of seconds. Models (`.rmodal`) and tet meshes are checked when
/// loaded, which is as early.
///
/// # Errors
/// An unreadable mesh; a hit off its surface.
pub fn check_hit_before_solve(path: &Path, scale: f64, hit_m: [f64; 3]) -> Result<()> {
    if is_model_file(path) || !(1e-6..=1e6).contains(&scale) {
        return Ok(());
    }
    if let LoadedMesh::Surface(s) = load_mesh(path, scale)? {
        ModalModel::check_hit_on(&s.vertices, &s.triangles, hit_m)
            .map_err(|e| Error::from(e).at(path))?;
    }
    Ok(())
}

/// Checks a microphone against the closed surface in `path` (scaled by `scale`) before any
/// solve: one inside the solid hears nothing physical (it was accepted without a word). A
/// saved model is checked by its surface after loading instead (it holds one).
///
/// # Errors
/// A microphone inside the object; an unreadable mesh.
pub fn check_mic_before_solve(path: &Path, scale: f64, mic_m: [f64; 3]) -> Result<()> {
    let inside = if is_model_file(path) {
        let m = model_file::load(path)?;
        resound_fem::SurfaceMesh {
            vertices: m.vertices.clone(),
            triangles: m.triangles.clone(),
        }
        .contains_point(mic_m)
    } else if !(1e-6..=1e6).contains(&scale) {
        false
    } else {
        match load_mesh(path, scale)? {
            LoadedMesh::Surface(s) => s.contains_point(mic_m),
            _ => false,
        }
    };
    if inside {
        return Err(crate::error::invalid(format!(
            "the microphone at {mic_m:?} m is inside the object: place it in the air"
        ))
        .at(path));
    }
    Ok(())
}

/// The modal model of the object in `path`: loaded from a `.rmodal`, or solved from a mesh.
///
/// # Errors
/// Unreadable files, failed solves, and a model without modes.
pub fn load_object(
    path: &Path,
    params: &ObjectParams,
    progress: ProgressFn<'_>,
) -> Result<ModalModel> {
    let (model, warnings) = load_object_warned(path, params, progress)?;
    for w in warnings {
        progress(crate::Progress::Warning(w));
    }
    Ok(model)
}

/// [`load_object`] that returns the solve's warnings (modes left out, a mechanism) instead
/// of sending them to `progress`, for reports that list them.
///
/// # Errors
/// As [`load_object`].
pub fn load_object_warned(
    path: &Path,
    params: &ObjectParams,
    progress: ProgressFn<'_>,
) -> Result<(ModalModel, Vec<resound_core::Warning>)> {
    let (model, warnings) = if is_model_file(path) {
        (model_file::load(path)?, Vec::new())
    } else {
        let solved = solve_mesh_file(
            path,
            params.scale,
            &params.reference_material,
            &params.modal,
            progress,
        )?;
        (solved.model, solved.info.warnings)
    };
    if model.eigenvalues.is_empty() {
        return Err(crate::error::invalid(format!(
            "{}: the modal model has no modes",
            path.display()
        )));
    }
    Ok((model, warnings))
}

/// Solves a closed surface given as arrays: `vertices` (m, before `params.scale`) and
/// `triangles` (vertex indices). The surface goes through the same repair and checks as a mesh
/// file.
///
/// # Errors
/// Non-finite or huge coordinates, indices out of range, a surface that cannot be repaired, a
/// failed solve, a model without modes.
pub fn solve_surface(
    vertices: &[[f64; 3]],
    triangles: &[[u32; 3]],
    params: &ObjectParams,
    progress: ProgressFn<'_>,
) -> Result<ModalModel> {
    use crate::error::invalid;
    let scale = params.scale;
    if !(1e-6..=1e6).contains(&scale) {
        return Err(invalid(format!(
            "scale must be within 1e-6–1e6 (0.001 reads millimetres), got {scale}"
        )));
    }
    if vertices.len() < 4 || triangles.len() < 4 {
        return Err(invalid(format!(
            "a closed surface needs at least 4 vertices and 4 triangles, got {} and {}",
            vertices.len(),
            triangles.len()
        )));
    }
    let scaled: Vec<[f64; 3]> = vertices
        .iter()
        .map(|p| [p[0] * scale, p[1] * scale, p[2] * scale])
        .collect();
    if let Some(i) = scaled
        .iter()
        .position(|p| !p.iter().all(|c| c.is_finite() && c.abs() <= 1e3))
    {
        return Err(invalid(format!(
            "vertex {i} {:?} is not a finite coordinate within 1 km (after scale {scale})",
            vertices[i]
        )));
    }
    if let Some(t) = triangles
        .iter()
        .position(|t| t.iter().any(|&v| v as usize >= vertices.len()))
    {
        return Err(invalid(format!(
            "triangle {t} {:?} names a vertex beyond the {} given",
            triangles[t],
            vertices.len()
        )));
    }
    let mesh = resound_fem::surface::SurfaceMesh {
        vertices: scaled,
        triangles: triangles.to_vec(),
    };
    let model = ModalBuilder::new(Geometry::Surface(&mesh), &params.reference_material)
        .params(params.modal.clone())
        .progress(progress)
        .solve()?
        .model;
    if model.eigenvalues.is_empty() {
        return Err(invalid("the modal model has no modes"));
    }
    Ok(model)
}

/// One mode of a [`ModalReport`].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModeRow {
    /// Frequency, Hz.
    pub freq_hz: f64,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    /// Gain at the hit, m per N·s.
    pub gain: Option<f64>,
}

/// The material of a [`ModalReport`].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct MaterialRow {
    /// Name.
    pub name: String,
    /// Young's modulus, Pa.
    pub youngs_modulus_pa: f64,
    /// Poisson ratio.
    pub poisson_ratio: f64,
    /// Density, kg/m³.
    pub density_kg_m3: f64,
}

/// The hit of a [`ModalReport`].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct HitRow {
    /// Surface point, m.
    pub point: [f64; 3],
    /// Unit outward normal.
    pub normal: [f64; 3],
    /// Distance from the query point, m.
    pub distance_m: f64,
}

/// The voxel grid of a [`ModalReport`].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct VoxelRow {
    /// Voxels along the longest side.
    pub resolution: usize,
    /// Grid dimensions.
    pub grid: [usize; 3],
    /// Voxel size, m.
    pub voxel_size_m: [f64; 3],
    /// Volume of the finite elements, m³.
    pub fe_volume_m3: f64,
    /// Volume the surface encloses, m³.
    pub surface_volume_m3: f64,
    /// What repair did.
    pub repairs: Vec<String>,
}

/// The solve's figures in a [`ModalReport`].
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SolveRow {
    /// Element type.
    pub element: String,
    /// Nonzeros of K.
    pub nnz: usize,
    /// Nonzeros of the Cholesky factor.
    pub nnz_factor: usize,
    /// Discretization and assembly, s.
    pub assemble_s: f64,
    /// Factorization, s.
    pub factor_s: f64,
    /// Lanczos, s.
    pub eigen_s: f64,
    /// Sturm count check, s.
    pub sturm_s: f64,
    /// Everything, s.
    pub solve_s: f64,
    /// Operator applications.
    pub operator_applications: usize,
    /// Largest true relative residual.
    pub max_rel_residual: f64,
    /// Modes certified below the cutoff by inertia.
    pub sturm_count: Option<usize>,
    /// Rigid-body modes dropped.
    pub rigid_modes_dropped: usize,
    /// Largest rigid-body |frequency|, Hz.
    pub rigid_max_hz: f64,
}

/// The acoustic transfer's fit, as `resound modal --transfer --json` prints it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct TransferRow {
    /// What the fit did.
    #[serde(flatten)]
    pub info: resound_modal::TransferInfo,
    /// Time the fit took, s.
    pub fit_s: f64,
}

/// A modal model and its solve, as `resound modal --json` prints it.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModalReport {
    /// Degrees of freedom.
    pub dofs: usize,
    /// Finite elements.
    pub elements: usize,
    /// What the solve did (absent for a loaded model: it was not solved here).
    #[serde(flatten, default, skip_serializing_if = "Option::is_none")]
    pub solve: Option<SolveRow>,
    /// The reference material.
    pub material: MaterialRow,
    /// Surface vertices.
    pub surface_vertices: usize,
    /// Things the user should know.
    pub warnings: Vec<resound_core::Warning>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    /// The voxel grid (surface meshes).
    pub voxel: Option<VoxelRow>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    /// The hit point (with `--hit`).
    pub hit: Option<HitRow>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    /// Load time of a saved model, ms.
    pub load_ms: Option<f64>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    /// The acoustic transfer fitted here (`resound modal --transfer`).
    pub transfer: Option<TransferRow>,
    /// Whether the model holds an acoustic transfer.
    pub has_transfer: bool,
    /// The modes, ascending.
    pub modes: Vec<ModeRow>,
}

impl std::fmt::Display for ModalReport {
    /// What the solve did and the transfer fit (when done here), then the modes: frequency,
    /// and the gain at the hit point when there is one.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        if let Some(t) = &self.transfer {
            writeln!(
                f,
                "acoustic transfer: {} grid frequencies, {} surface points, up to {} unknowns, \
                 worst misfit {:.3}, {:.1} MB, in {:.2} s",
                t.info.grid_points,
                t.info.surface_points,
                t.info.max_unknowns,
                t.info.worst_residual,
                t.info.bytes as f64 / 1e6,
                t.fit_s
            )?;
        }
        if let Some(e) = &self.solve {
            writeln!(
                f,
                "{} elements ({}), {} DOFs, {} modes in {:.2} s (assemble {:.2} s, factor \
                 {:.2} s, Lanczos {:.2} s, Sturm {:.2} s); max residual {:.1e}",
                self.elements,
                e.element,
                self.dofs,
                self.modes.len(),
                e.solve_s,
                e.assemble_s,
                e.factor_s,
                e.eigen_s,
                e.sturm_s,
                e.max_rel_residual
            )?;
        }
        match &self.hit {
            Some(h) => {
                let (p, n) = (h.point, h.normal);
                writeln!(
                    f,
                    "hit at ({:.4}, {:.4}, {:.4}) m, normal ({:.3}, {:.3}, {:.3})",
                    p[0], p[1], p[2], n[0], n[1], n[2]
                )?;
                writeln!(f, "{:>5} {:>12} {:>14}", "mode", "freq_hz", "gain_m_per_Ns")?;
            }
            None => writeln!(f, "{:>5} {:>12}", "mode", "freq_hz")?,
        }
        for (j, m) in self.modes.iter().enumerate() {
            match m.gain {
                Some(g) => writeln!(f, "{:>5} {:>12.2} {:>14.4e}", j + 1, m.freq_hz, g)?,
                None => writeln!(f, "{:>5} {:>12.2}", j + 1, m.freq_hz)?,
            }
        }
        Ok(())
    }
}

impl ModalReport {
    /// The report of `model` (solved as `info` says, or loaded: `None`), with the gains at
    /// `hit`.
    pub fn new(model: &ModalModel, info: Option<&ModalSolveInfo>, hit: Option<&Hit>) -> Self {
        ModalReport {
            dofs: info.map_or(model.fem_dofs as usize, |i| i.dofs),
            elements: info.map_or(model.fem_elements as usize, |i| i.elements),
            solve: info.map(|info| {
                let e = &info.eigen;
                SolveRow {
                    element: info.element.to_string(),
                    nnz: e.nnz_k,
                    nnz_factor: e.nnz_l,
                    assemble_s: info.assemble_s,
                    factor_s: e.factor_s,
                    eigen_s: e.eigen_s,
                    sturm_s: e.sturm_s,
                    solve_s: info.total_s,
                    operator_applications: e.applications,
                    max_rel_residual: e.max_rel_residual,
                    sturm_count: e.sturm_count,
                    rigid_modes_dropped: info.rigid_modes,
                    rigid_max_hz: info.rigid_max_hz,
                }
            }),
            material: MaterialRow {
                name: model.material.name.clone(),
                youngs_modulus_pa: model.material.youngs_modulus,
                poisson_ratio: model.material.poisson_ratio,
                density_kg_m3: model.material.density,
            },
            surface_vertices: model.n_vertices(),
            transfer: None,
            has_transfer: model.transfer.is_some(),
            warnings: info.map_or_else(Vec::new, |i| i.warnings.clone()),
            voxel: info.and_then(|i| i.discretize.as_ref()).map(|r| VoxelRow {
                resolution: r.resolution,
                grid: r.grid_dims,
                voxel_size_m: r.voxel_size_m,
                fe_volume_m3: r.fe_volume_m3,
                surface_volume_m3: r.surface_volume_m3,
                repairs: r.repair.lines(),
            }),
            hit: hit.map(|h| HitRow {
                point: h.at.point,
                normal: h.at.normal,
                distance_m: h.at.distance,
            }),
            load_ms: None,
            modes: (0..model.n_modes())
                .map(|j| ModeRow {
                    freq_hz: model.freq_hz(j),
                    gain: hit.map(|h| h.gains[j]),
                })
                .collect(),
        }
    }
}

/// A hit at the surface point nearest `query` (model coordinates, m), with a note when the
/// point moved by more than a micrometre (front ends show it: a point far off the surface is
/// usually a mistake).
///
/// # Errors
/// A non-finite query; a model without a surface.
pub fn snap_hit(
    model: &ModalModel,
    query: [f64; 3],
) -> Result<(resound_core::Hit, Option<String>)> {
    let hit = model.hit(query)?;
    let note = (hit.at.distance > 1e-6).then(|| {
        format!(
            "hit point {query:?} is {:.2} mm off the surface; using the nearest surface point {:?}",
            hit.at.distance * 1e3,
            hit.at.point
        )
    });
    Ok((hit, note))
}

/// What [`solve_object`] does: `resound modal`'s inputs (and the studio's object step).
#[derive(Clone, Debug)]
pub struct SolveJob {
    /// A closed surface or tet mesh.
    pub mesh: std::path::PathBuf,
    /// Scale applied to its coordinates (0.001 for millimetres).
    pub scale: f64,
    /// The material of the solve.
    pub material: Material,
    /// The solve's settings.
    pub modal: ModalParams,
    /// Fit each mode's acoustic transfer with these settings too.
    pub transfer: Option<resound_modal::TransferParams>,
    /// A hit point, m (model coordinates): the report gives each mode's gain there.
    pub hit_m: Option<[f64; 3]>,
    /// Write K and M as Matrix Market files `K.mtx` and `M.mtx` into this directory.
    pub export_matrices: Option<std::path::PathBuf>,
}

/// A solved object: the model and its report (`modal --json`).
#[derive(Debug)]
pub struct SolveOutcome {
    /// The model (with its transfer when asked for).
    pub model: ModalModel,
    /// The report (with the hit's gains when a hit was given).
    pub report: ModalReport,
    /// The hit on the surface, when one was given.
    pub hit: Option<Hit>,
    /// Repairs made to the surface mesh, one per line.
    pub repairs: Vec<String>,
}

/// Solves `job`: the modes, then the acoustic transfer and the matrices when asked for.
/// `progress` hears every stage ([`Stage::Assembling`](crate::Stage), the eigen-solve's,
/// [`Stage::Transfer`](crate::Stage)) and the warnings.
///
/// # Errors
/// Unreadable meshes, failed solves or fits, a hit off the surface, unwritable matrices.
pub fn solve_object(job: &SolveJob, progress: ProgressFn<'_>) -> Result<SolveOutcome> {
    use resound_core::progress::{Progress, Stage, Warning, WarningKind};
    if let Some(f) = job.modal.max_freq_hz {
        if !(f > 0.0 && f.is_finite() && f <= 1e6) {
            return Err(Error::Param {
                field: "max_freq_hz",
                message: format!("the top frequency {f} Hz must be in (0, 1e6]"),
            });
        }
    }
    if let Some(h) = job.hit_m {
        check_hit_before_solve(&job.mesh, job.scale, h)?;
    }
    if let Some(dir) = &job.export_matrices {
        crate::files::check_outputs(&[&job.mesh], &[dir])?;
    }
    if let Some(t) = &job.transfer {
        t.validate()
            .map_err(|e| crate::error::invalid(e.to_string()))?;
    }
    progress(Progress::begin(Stage::Assembling));
    let mut solved = solve_mesh_file(&job.mesh, job.scale, &job.material, &job.modal, progress)?;
    let mut warnings = Vec::new();
    let transfer = match &job.transfer {
        Some(params) => {
            progress(
                Progress::begin(Stage::Transfer)
                    .with_label(format!("of {} modes", solved.model.n_modes())),
            );
            let t0 = std::time::Instant::now();
            let info = crate::radiation::add_transfer(&mut solved.model, params)?;
            if info.poorly_fitted > 0 {
                warnings.push(Warning::new(
                    WarningKind::PoorTransfer,
                    format!(
                        "{} modes' surface velocity is fitted with more than 90 % misfit \
                         (worst {:.2}): their radiation is approximate (more equivalent \
                         sources, or a finer mesh)",
                        info.poorly_fitted, info.worst_residual
                    ),
                ));
            }
            Some(TransferRow {
                info,
                fit_s: t0.elapsed().as_secs_f64(),
            })
        }
        None => None,
    };
    if let (Some(dir), Some(fem)) = (&job.export_matrices, &solved.fem) {
        // The directory itself may be new; its parent must exist, as every output's does
        // (`files::check_outputs`): a mistyped parent is refused, not created.
        crate::files::make_output_dir(dir)?;
        let note = format!(
            "resound {} {}: {} DOFs; DOF 3*node+c",
            env!("CARGO_PKG_VERSION"),
            fem.element,
            fem.n_dofs()
        );
        resound_io::mtx::write_symmetric(
            &dir.join("K.mtx"),
            fem.k.as_ref(),
            &format!("stiffness K (N/m)\n{note}"),
        )?;
        resound_io::mtx::write_symmetric(
            &dir.join("M.mtx"),
            fem.m.as_ref(),
            &format!("mass M (kg)\n{note}"),
        )?;
    }
    let hit = job.hit_m.map(|h| solved.model.hit(h)).transpose()?;
    let mut report = ModalReport::new(&solved.model, Some(&solved.info), hit.as_ref());
    report.transfer = transfer;
    report.warnings.extend(warnings);
    for w in &report.warnings {
        progress(Progress::Warning(w.clone()));
    }
    let repairs = solved
        .info
        .discretize
        .as_ref()
        .map(|r| r.repair.lines())
        .unwrap_or_default();
    Ok(SolveOutcome {
        model: solved.model,
        report,
        hit,
        repairs,
    })
}

/// A saved model's summary (`resound model`): its modes as [`ModalReport`], where it came
/// from and what a rescale to another material did.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModelInfo {
    /// The `.rmodal` file.
    pub path: std::path::PathBuf,
    /// The modes (rescaled when a material was given), with gains at the hit.
    #[serde(flatten)]
    pub report: ModalReport,
    /// The stored acoustic transfer, when the model holds one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stored_transfer: Option<StoredTransferRow>,
    /// What the user should know (a Poisson ratio kept).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub notes: Vec<String>,
}

/// The acoustic transfer stored in a model file.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct StoredTransferRow {
    /// Highest multipole order.
    pub max_order: usize,
    /// Size of its coefficients, bytes.
    pub coeff_bytes: usize,
    /// Expansion centre, m.
    pub centre_m: [f64; 3],
    /// Radius of the sphere outside which it holds, m.
    pub radius_m: f64,
}

impl std::fmt::Display for ModelInfo {
    /// The header (counts, material, load time), the stored transfer, then the modes.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (r, m) = (&self.report, &self.report.material);
        writeln!(
            f,
            "{}: {} modes, {} surface vertices, material {} (E {:.3e} Pa, nu {}, rho {} kg/m^3); \
             loaded in {:.2} ms",
            self.path.display(),
            r.modes.len(),
            r.surface_vertices,
            m.name,
            m.youngs_modulus_pa,
            m.poisson_ratio,
            m.density_kg_m3,
            r.load_ms.unwrap_or(0.0)
        )?;
        if let Some(t) = &self.stored_transfer {
            writeln!(
                f,
                "acoustic transfer: order up to {}, {:.1} MB, centre {:?} m, radius {:.4} m",
                t.max_order,
                t.coeff_bytes as f64 / 1e6,
                t.centre_m,
                t.radius_m
            )?;
        }
        write!(f, "{r}")
    }
}

/// Loads a saved model, rescales it to `material` when given (keeping the model's Poisson
/// ratio when `keep_nu`: frequencies then scale exactly by E/ρ), and reports its modes with
/// the gains at `hit_m`.
///
/// # Errors
/// An unreadable file; a material whose ν differs (without `keep_nu`); a hit off the surface.
pub fn model_info(
    path: &Path,
    material: Option<&Material>,
    keep_nu: bool,
    hit_m: Option<[f64; 3]>,
) -> Result<ModelInfo> {
    let t0 = std::time::Instant::now();
    let mut model = model_file::load(path)?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    let mut notes = Vec::new();
    if let Some(target) = material {
        let mut target = target.clone();
        let nu = model.material.poisson_ratio;
        if keep_nu && (target.poisson_ratio - nu).abs() > 1e-12 {
            notes.push(format!(
                "keeping the model's Poisson ratio {nu} (not {}): frequencies scale exactly by \
                 E/ρ, but they are the modes of a material with that ν",
                target.poisson_ratio
            ));
            target.poisson_ratio = nu;
        }
        model = model.rescaled(&target)?;
    }
    let hit = hit_m.map(|h| model.hit(h)).transpose()?;
    let mut report = ModalReport::new(&model, None, hit.as_ref());
    report.load_ms = Some(load_ms);
    let stored_transfer = model.transfer.as_ref().map(|t| StoredTransferRow {
        max_order: t.max_order(),
        coeff_bytes: t.coeff_bytes(),
        centre_m: t.centre_m,
        radius_m: t.radius_m,
    });
    Ok(ModelInfo {
        path: path.to_path_buf(),
        report,
        stored_transfer,
        notes,
    })
}

/// An object's surface for a 3-D view (the studio's), optionally coloured by one mode.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct SurfaceView {
    /// Vertex positions x, y, z after one another, m.
    pub vertices: Vec<f32>,
    /// Triangles as vertex indices, three after one another (outward, counter-clockwise).
    pub triangles: Vec<u32>,
    /// The bounding box, lowest and highest corner, m.
    pub bbox_m: [[f64; 3]; 2],
    /// The mode shown, counting from 1.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub mode: Option<usize>,
    /// Its frequency, Hz.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub freq_hz: Option<f64>,
    /// Its displacement magnitude at each vertex over the largest, 0–1 (nodes are near 0).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub displacement: Option<Vec<f32>>,
}

impl SurfaceView {
    /// The surface of `model`, with mode `mode`'s displacement (counting from 1) when given.
    ///
    /// # Errors
    /// No mode `mode`.
    pub fn new(model: &ModalModel, mode: Option<usize>) -> Result<Self> {
        let (lo, hi) = resound_core::geometry::bbox(&model.vertices);
        let displacement = match mode {
            None => None,
            Some(k) if (1..=model.n_modes()).contains(&k) => {
                let n = model.n_vertices();
                let u = &model.shapes[(k - 1) * n * 3..k * n * 3];
                let mag: Vec<f32> = u
                    .chunks_exact(3)
                    .map(|c| (c[0] * c[0] + c[1] * c[1] + c[2] * c[2]).sqrt())
                    .collect();
                let top = mag.iter().fold(0.0f32, |a, &v| a.max(v));
                Some(if top > 0.0 {
                    mag.iter().map(|v| v / top).collect()
                } else {
                    mag
                })
            }
            Some(k) => {
                return Err(crate::error::invalid(format!(
                    "no mode {k}: the model has {} (counting from 1)",
                    model.n_modes()
                )))
            }
        };
        Ok(Self {
            vertices: model
                .vertices
                .iter()
                .flat_map(|p| p.map(|c| c as f32))
                .collect(),
            triangles: model.triangles.iter().flatten().copied().collect(),
            bbox_m: [lo, hi],
            mode,
            freq_hz: mode.map(|k| model.freq_hz(k - 1)),
            displacement,
        })
    }
}
