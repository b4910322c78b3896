//! Mesh loading by file extension, and surface writing.

use crate::atomic::write_atomic;
use crate::{io_err, parse_err, IoError, Result};
use resound_fem::{SurfaceMesh, TetMesh};
use std::path::Path;

/// A mesh as loaded: a closed surface to voxelize, or tetrahedra to use as is.
#[derive(Debug, Clone, PartialEq)]
pub enum LoadedMesh {
    /// Triangle surface.
    Surface(SurfaceMesh),
    /// Tetrahedral volume mesh.
    Tets(TetMesh),
}

impl LoadedMesh {
    /// Multiplies coordinates by `s` (e.g. 0.001 for millimetres).
    pub fn scale(&mut self, s: f64) {
        match self {
            LoadedMesh::Surface(m) => m.scale(s),
            LoadedMesh::Tets(t) => t.scale(s),
        }
    }
}

fn ext(path: &Path) -> String {
    path.extension()
        .map(|e| e.to_string_lossy().to_ascii_lowercase())
        .unwrap_or_default()
}

/// Loads a surface (`.obj .stl .ply`) or tet mesh (`.msh .node .ele .mesh`) and multiplies its
/// coordinates by `scale`.
///
/// # Errors
/// [`IoError`] for unreadable, malformed or unsupported files and a non-positive `scale`.
pub fn load_mesh(path: &Path, scale: f64) -> Result<LoadedMesh> {
    if !(scale > 0.0 && scale.is_finite()) {
        return Err(parse_err(
            path,
            format!("scale {scale} must be a positive number"),
        ));
    }
    let mut m = match ext(path).as_str() {
        "obj" => LoadedMesh::Surface(load_obj(path)?),
        "stl" => LoadedMesh::Surface(load_stl(path)?),
        "ply" => LoadedMesh::Surface(crate::ply::load_ply(path)?),
        "msh" => crate::tetfile::load_msh(path)?,
        "node" | "ele" => LoadedMesh::Tets(crate::tetfile::load_tetgen(path)?),
        "mesh" => crate::tetfile::load_medit(path)?,
        _ => {
            return Err(IoError::Unsupported {
                path: path.to_path_buf(),
            })
        }
    };
    if scale != 1.0 {
        m.scale(scale);
    }
    Ok(m)
}

pub(crate) fn read(path: &Path) -> Result<Vec<u8>> {
    let b = std::fs::read(path).map_err(|e| io_err(path, e))?;
    if b.is_empty() {
        return Err(parse_err(path, "file is empty"));
    }
    Ok(b)
}

fn load_obj(path: &Path) -> Result<SurfaceMesh> {
    let bytes = read(path)?;
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &opts, |_| {
        Err(tobj::LoadError::GenericFailure)
    })
    .map_err(|e| parse_err(path, format!("OBJ: {e}")))?;
    let mut m = SurfaceMesh::default();
    for model in models {
        let mesh = model.mesh;
        let base = m.vertices.len() as u32;
        if mesh.positions.len() % 3 != 0 || mesh.indices.len() % 3 != 0 {
            return Err(parse_err(path, "OBJ: malformed positions or faces"));
        }
        m.vertices.extend(
            mesh.positions
                .chunks_exact(3)
                .map(|p| [p[0] as f64, p[1] as f64, p[2] as f64]),
        );
        let nv = mesh.positions.len() / 3;
        for t in mesh.indices.chunks_exact(3) {
            if t.iter().any(|&i| i as usize >= nv) {
                return Err(parse_err(
                    path,
                    format!("OBJ: face index {t:?} out of range ({nv} vertices)"),
                ));
            }
            m.triangles.push([base + t[0], base + t[1], base + t[2]]);
        }
    }
    if m.triangles.is_empty() {
        return Err(parse_err(path, "OBJ: no faces"));
    }
    Ok(m)
}

fn load_stl(path: &Path) -> Result<SurfaceMesh> {
    let bytes = read(path)?;
    let mut cur = std::io::Cursor::new(bytes);
    let stl = stl_io::read_stl(&mut cur).map_err(|e| parse_err(path, format!("STL: {e}")))?;
    let m = SurfaceMesh {
        vertices: stl
            .vertices
            .iter()
            .map(|v| [v[0] as f64, v[1] as f64, v[2] as f64])
            .collect(),
        triangles: stl
            .faces
            .iter()
            .map(|f| f.vertices.map(|i| i as u32))
            .collect(),
    };
    if m.triangles.is_empty() {
        return Err(parse_err(path, "STL: no facets"));
    }
    Ok(m)
}

/// Writes a surface mesh; the format follows the extension (`.obj`, `.stl` binary, `.ply` ASCII).
///
/// # Errors
/// I/O errors or an unsupported extension.
pub fn save_surface(path: &Path, m: &SurfaceMesh) -> Result<()> {
    match ext(path).as_str() {
        "obj" => write_atomic(path, |w| {
            writeln!(w, "# written by resound")?;
            for v in &m.vertices {
                writeln!(w, "v {:.17e} {:.17e} {:.17e}", v[0], v[1], v[2])?;
            }
            for t in &m.triangles {
                writeln!(w, "f {} {} {}", t[0] + 1, t[1] + 1, t[2] + 1)?;
            }
            Ok(())
        }),
        "stl" => write_atomic(path, |w| {
            w.write_all(&[0u8; 80])?;
            w.write_all(&(m.triangles.len() as u32).to_le_bytes())?;
            for t in &m.triangles {
                let [a, b, c] = t.map(|i| m.vertices[i as usize]);
                let n = resound_core::geometry::cross(
                    resound_core::geometry::sub(b, a),
                    resound_core::geometry::sub(c, a),
                );
                let l = resound_core::geometry::norm(n).max(f64::MIN_POSITIVE);
                for x in n.iter().map(|x| x / l).chain(a).chain(b).chain(c) {
                    w.write_all(&(x as f32).to_le_bytes())?;
                }
                w.write_all(&[0, 0])?;
            }
            Ok(())
        }),
        "ply" => write_atomic(path, |w| {
            writeln!(
                w,
                "ply\nformat ascii 1.0\nelement vertex {}",
                m.vertices.len()
            )?;
            writeln!(w, "property double x\nproperty double y\nproperty double z")?;
            writeln!(
                w,
                "element face {}\nproperty list uchar int vertex_indices\nend_header",
                m.triangles.len()
            )?;
            for v in &m.vertices {
                writeln!(w, "{:.17e} {:.17e} {:.17e}", v[0], v[1], v[2])?;
            }
            for t in &m.triangles {
                writeln!(w, "3 {} {} {}", t[0], t[1], t[2])?;
            }
            Ok(())
        }),
        _ => Err(IoError::Unsupported {
            path: path.to_path_buf(),
        }),
    }
}
