//! Meshes for the user: primitives by name and sizes, and what a mesh file holds (and what
//! repair would do to it).

use crate::error::{invalid, Result};
use resound_fem::{primitive, SurfaceMesh};
use resound_io::{load_mesh, LoadedMesh};
use serde::Serialize;
use std::path::Path;

/// The primitives.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PrimitiveKind {
    /// A box centred at the origin: sizes x, y, z (m).
    Bar,
    /// The same as `Bar`.
    Box,
    /// A plate: length, width, thickness (m).
    Plate,
    /// A cylinder: radius, height (m).
    Cylinder,
    /// A sphere: radius (m).
    Sphere,
    /// A bowl: radius, wall thickness and optionally depth (m).
    Bowl,
}

impl PrimitiveKind {
    /// Every kind by its name.
    pub const NAMES: [(&'static str, PrimitiveKind); 6] = [
        ("bar", PrimitiveKind::Bar),
        ("box", PrimitiveKind::Box),
        ("plate", PrimitiveKind::Plate),
        ("cylinder", PrimitiveKind::Cylinder),
        ("sphere", PrimitiveKind::Sphere),
        ("bowl", PrimitiveKind::Bowl),
    ];

    /// The kind called `name` (lower case).
    pub fn from_name(name: &str) -> Option<Self> {
        Self::NAMES
            .iter()
            .find(|(n, _)| *n == name)
            .map(|&(_, k)| k)
    }
}

/// What [`write_primitive`] wrote.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct PrimitiveInfo {
    /// Surface vertices.
    pub vertices: usize,
    /// Surface triangles.
    pub triangles: usize,
    /// Enclosed volume, m³.
    pub volume_m3: f64,
    /// A size no struck object has (sizes in millimetres read as metres).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub warnings: Vec<resound_core::Warning>,
}

impl std::fmt::Display for PrimitiveInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{} vertices, {} triangles, volume {:.4e} m^3",
            self.vertices, self.triangles, self.volume_m3
        )
    }
}

/// Makes a primitive ([`make_primitive`]) and saves it to `out` (OBJ, STL or PLY by its
/// extension).
///
/// # Errors
/// As [`make_primitive`]; an unwritable file.
pub fn write_primitive(
    kind: PrimitiveKind,
    sizes_m: &[f64],
    segments: usize,
    out: &Path,
) -> Result<PrimitiveInfo> {
    crate::files::check_outputs(&[], &[out])?;
    let m = make_primitive(kind, sizes_m, segments)?;
    resound_io::save_surface(out, &m)?;
    let (lo, hi) = m.bbox();
    let largest = (0..3).map(|c| hi[c] - lo[c]).fold(0.0, f64::max);
    Ok(PrimitiveInfo {
        vertices: m.vertices.len(),
        triangles: m.triangles.len(),
        volume_m3: m.signed_volume(),
        warnings: resound_modal::model::implausible_size(largest)
            .into_iter()
            .collect(),
    })
}

/// A primitive surface from its sizes (m) and, for round shapes, `segments` around.
///
/// # Errors
/// The wrong number of sizes, `segments` outside 3..=4096, a bowl thicker than its radius.
pub fn make_primitive(kind: PrimitiveKind, s: &[f64], segments: usize) -> Result<SurfaceMesh> {
    let need = |n: &[usize]| -> Result<()> {
        if n.contains(&s.len()) {
            return Ok(());
        }
        let counts: Vec<String> = n.iter().map(|x| x.to_string()).collect();
        Err(invalid(format!(
            "{kind:?} takes {} sizes, got {}",
            counts.join(" or "),
            s.len()
        )))
    };
    if !(3..=4096).contains(&segments) {
        return Err(invalid("the segment count must be in 3..=4096"));
    }
    if s.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
        return Err(invalid("every size must be a positive number of metres"));
    }
    Ok(match kind {
        PrimitiveKind::Bar | PrimitiveKind::Box => {
            need(&[3])?;
            primitive::bar([s[0], s[1], s[2]])
        }
        PrimitiveKind::Plate => {
            need(&[3])?;
            primitive::plate(s[0], s[1], s[2])
        }
        PrimitiveKind::Cylinder => {
            need(&[2])?;
            primitive::cylinder(s[0], s[1], segments)
        }
        PrimitiveKind::Sphere => {
            need(&[1])?;
            primitive::sphere(s[0], segments)
        }
        PrimitiveKind::Bowl => {
            need(&[2, 3])?;
            if s[1] >= s[0] {
                return Err(invalid(format!(
                    "bowl thickness {} must be smaller than its radius {}",
                    s[1], s[0]
                )));
            }
            primitive::bowl(s[0], s[1], *s.get(2).unwrap_or(&s[0]), segments)
        }
    })
}

/// What a mesh file holds.
#[derive(Clone, Debug, Serialize)]
#[serde(tag = "kind", rename_all = "lowercase")]
pub enum MeshReport {
    /// A surface mesh and what repair does to it.
    Surface {
        /// Vertices as read.
        vertices: usize,
        /// Triangles as read.
        triangles: usize,
        /// Bounding box, m.
        bbox_min_m: [f64; 3],
        /// Bounding box, m.
        bbox_max_m: [f64; 3],
        /// Volume of the repaired surface, m³.
        volume_m3: f64,
        /// What repair did.
        repairs: Vec<String>,
    },
    /// A tet mesh.
    Tets {
        /// Nodes.
        nodes: usize,
        /// Tetrahedra.
        tets: usize,
        /// Triangles of its boundary.
        boundary_triangles: usize,
        /// Volume, m³.
        volume_m3: f64,
        /// Notes of the discretization.
        notes: Vec<String>,
    },
}

impl std::fmt::Display for MeshReport {
    /// A surface: its size, bounding box, closed volume and each repair, one per line; a tet
    /// mesh: its counts, volume and notes.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            MeshReport::Surface {
                vertices,
                triangles,
                bbox_min_m,
                bbox_max_m,
                volume_m3,
                repairs,
            } => {
                write!(
                    f,
                    "{vertices} vertices, {triangles} triangles; bbox {bbox_min_m:?} .. \
                     {bbox_max_m:?} m; closed volume {volume_m3:.4e} m^3"
                )?;
                repairs.iter().try_for_each(|l| write!(f, "\nrepair: {l}"))
            }
            MeshReport::Tets {
                nodes,
                tets,
                boundary_triangles,
                volume_m3,
                notes,
            } => {
                write!(
                    f,
                    "{nodes} nodes, {tets} tetrahedra, {boundary_triangles} boundary triangles; \
                     volume {volume_m3:.4e} m^3"
                )?;
                notes.iter().try_for_each(|l| write!(f, "\nnote: {l}"))
            }
        }
    }
}

/// Reads `path` (scaled by `scale`) and reports it, repairing surfaces (holes up to
/// `max_hole_edges` filled).
///
/// # Errors
/// Unreadable files; a surface that cannot be repaired; unusable tets.
pub fn check_mesh(path: &Path, scale: f64, max_hole_edges: usize) -> Result<MeshReport> {
    Ok(match load_mesh(path, scale)? {
        LoadedMesh::Tets(t) => {
            let steel = resound_core::Material::preset("steel")?;
            let fem = resound_fem::discretize::discretize_tets(&t, &steel, false)
                .map_err(|e| invalid(e.to_string()))?;
            MeshReport::Tets {
                nodes: t.nodes.len(),
                tets: t.tets.len(),
                boundary_triangles: fem.surface.triangles.len(),
                volume_m3: fem.surface.signed_volume(),
                notes: fem.notes,
            }
        }
        LoadedMesh::Surface(s) => {
            let (lo, hi) = s.bbox();
            let (r, report) = s
                .repaired(max_hole_edges)
                .map_err(|e| invalid(format!("the mesh cannot be used: {e}")))?;
            MeshReport::Surface {
                vertices: s.vertices.len(),
                triangles: s.triangles.len(),
                bbox_min_m: lo,
                bbox_max_m: hi,
                volume_m3: r.signed_volume(),
                repairs: report.lines(),
            }
        }
    })
}
