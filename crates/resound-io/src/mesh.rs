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
    let points = match &m {
        LoadedMesh::Surface(s) => &s.vertices,
        LoadedMesh::Tets(t) => &t.nodes,
    };
    if let Some((i, p)) = points.iter().enumerate().find(|(_, p)| {
        !p.iter()
            .all(|c| c.is_finite() && c.abs() <= MAX_COORDINATE_M)
    }) {
        return Err(parse_err(
            path,
            format!(
                "vertex {} at {p:?} m (after scaling by {scale}) lies beyond ±{MAX_COORDINATE_M:e} m: not a \
                 credible object coordinate",
                i + 1
            ),
        ));
    }
    Ok(m)
}

/// Largest coordinate a mesh may hold, m (after scaling): a sounding object is not 1000 km
/// from the origin, and beyond it voxelization would see one point.
pub const MAX_COORDINATE_M: f64 = 1e6;

pub(crate) fn read(path: &Path) -> Result<Vec<u8>> {
    let b = std::fs::read(path).map_err(|e| io_err(path, e))?;
    if b.is_empty() {
        return Err(parse_err(path, "file is empty"));
    }
    Ok(b)
}

/// The first `v` or `f` line of an OBJ that tobj would refuse, named by line number (tobj's own
/// message says "position parse error" for a bad face index).
fn obj_first_bad_line(text: &str) -> Option<String> {
    let mut vertices: i64 = 0;
    for (no, line) in text.lines().enumerate() {
        let mut w = line.split_whitespace();
        match w.next() {
            Some("v") => {
                let ok = w.take(3).filter(|t| t.parse::<f64>().is_ok()).count() == 3;
                if !ok {
                    return Some(format!(
                        "line {}: a vertex needs 3 numbers: {line:?}",
                        no + 1
                    ));
                }
                vertices += 1;
            }
            Some("f") => {
                let corners: Vec<&str> = w.collect();
                if corners.len() < 3 {
                    return Some(format!("line {}: a face needs 3 corners: {line:?}", no + 1));
                }
                for c in corners {
                    let i = c.split('/').next().and_then(|v| v.parse::<i64>().ok());
                    let fine =
                        i.is_some_and(|i| (i > 0 && i <= vertices) || (i < 0 && -i <= vertices));
                    if !fine {
                        return Some(format!(
                            "line {}: face corner {c:?} is not one of the {vertices} vertices defined above it",
                            no + 1
                        ));
                    }
                }
            }
            _ => {}
        }
    }
    None
}

fn load_obj(path: &Path) -> Result<SurfaceMesh> {
    let bytes = read(path)?;
    let text = String::from_utf8_lossy(&bytes).into_owned();
    let opts = tobj::LoadOptions {
        triangulate: true,
        single_index: false,
        ..Default::default()
    };
    let (models, _) = tobj::load_obj_buf(&mut std::io::Cursor::new(bytes), &opts, |_| {
        Err(tobj::LoadError::GenericFailure)
    })
    .map_err(|e| match obj_first_bad_line(&text) {
        Some(why) => parse_err(path, format!("OBJ: {why}")),
        None => parse_err(path, format!("OBJ: {e}")),
    })?;
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
    // Binary STL: 80-byte header, facet count, 50 bytes a facet. stl_io says only "failed to
    // fill whole buffer" when the file is shorter than its count.
    if !bytes.starts_with(b"solid") && bytes.len() >= 84 {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as usize;
        let want = 84 + 50 * n;
        if bytes.len() < want {
            return Err(parse_err(
                path,
                format!(
                    "STL: truncated: the header promises {n} facets ({want} bytes), the file has {} bytes",
                    bytes.len()
                ),
            ));
        }
    } else if !bytes.starts_with(b"solid") {
        return Err(parse_err(
            path,
            format!(
                "STL: {} bytes is shorter than a binary STL header (84)",
                bytes.len()
            ),
        ));
    }
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
