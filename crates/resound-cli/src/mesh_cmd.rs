//! `resound mesh …`.

use crate::util::parse_list;
use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand, ValueEnum};
use resound::fem::primitive;
use resound::io::{load_mesh, save_surface, LoadedMesh};
use serde_json::json;
use std::path::PathBuf;

/// Mesh subcommands.
#[derive(Subcommand, Debug)]
pub enum MeshCmd {
    /// Write a closed primitive surface (sizes in m): bar/box x,y,z; plate x,y,thickness; cylinder radius,height; sphere radius; bowl radius,thickness(,depth).
    Primitive(PrimitiveArgs),
    /// Check a mesh: counts, bounding box, volume, and what repair would change (or why it cannot be used).
    Check(CheckArgs),
}

/// Primitive shapes.
#[derive(ValueEnum, Clone, Copy, Debug)]
pub enum Kind {
    /// Axis-aligned box x,y,z.
    Bar,
    /// Same as bar.
    Box,
    /// Box x,y,thickness.
    Plate,
    /// Closed cylinder radius,height along z.
    Cylinder,
    /// Sphere radius.
    Sphere,
    /// Spherical bowl radius,thickness(,depth), rim at z = 0.
    Bowl,
}

/// Arguments of `mesh primitive`.
#[derive(Args, Debug)]
pub struct PrimitiveArgs {
    /// Which shape.
    pub kind: Kind,
    /// Comma-separated sizes in m (see the shape).
    #[arg(long)]
    pub size: String,
    /// Segments around curved shapes.
    #[arg(long, default_value_t = 48)]
    pub segments: usize,
    /// Output file (.obj, .stl or .ply).
    #[arg(short = 'o', long)]
    pub output: PathBuf,
}

/// Arguments of `mesh check`.
#[derive(Args, Debug)]
pub struct CheckArgs {
    /// The mesh file.
    pub mesh: PathBuf,
    /// Multiply coordinates by this.
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
    /// Fill holes with at most this many boundary edges.
    #[arg(long, default_value_t = 0)]
    pub max_hole_edges: usize,
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

/// Runs a mesh subcommand.
pub fn run(c: MeshCmd) -> Result<()> {
    match c {
        MeshCmd::Primitive(a) => {
            let s = parse_list(&a.size)?;
            let need = |n: &[usize]| -> Result<()> {
                if !n.contains(&s.len()) {
                    bail!(
                        "{:?} takes {} sizes, got {}",
                        a.kind,
                        n.iter()
                            .map(|x| x.to_string())
                            .collect::<Vec<_>>()
                            .join(" or "),
                        s.len()
                    );
                }
                Ok(())
            };
            if !(3..=4096).contains(&a.segments) {
                bail!("--segments must be in 3..=4096");
            }
            let m = match a.kind {
                Kind::Bar | Kind::Box => {
                    need(&[3])?;
                    primitive::bar([s[0], s[1], s[2]])
                }
                Kind::Plate => {
                    need(&[3])?;
                    primitive::plate(s[0], s[1], s[2])
                }
                Kind::Cylinder => {
                    need(&[2])?;
                    primitive::cylinder(s[0], s[1], a.segments)
                }
                Kind::Sphere => {
                    need(&[1])?;
                    primitive::sphere(s[0], a.segments)
                }
                Kind::Bowl => {
                    need(&[2, 3])?;
                    if s[1] >= s[0] {
                        bail!(
                            "bowl thickness {} must be smaller than its radius {}",
                            s[1],
                            s[0]
                        );
                    }
                    primitive::bowl(s[0], s[1], *s.get(2).unwrap_or(&s[0]), a.segments)
                }
            };
            save_surface(&a.output, &m)
                .with_context(|| format!("writing {}", a.output.display()))?;
            eprintln!(
                "wrote {} ({} vertices, {} triangles, volume {:.4e} m^3)",
                a.output.display(),
                m.vertices.len(),
                m.triangles.len(),
                m.signed_volume()
            );
            Ok(())
        }
        MeshCmd::Check(a) => {
            let m = load_mesh(&a.mesh, a.scale)?;
            let s = match m {
                LoadedMesh::Surface(s) => s,
                LoadedMesh::Tets(t) => {
                    let fem = resound::fem::discretize::discretize_tets(
                        &t,
                        &resound::core::Material::preset("steel")?,
                        false,
                    )?;
                    let v = json!({"kind": "tets", "nodes": t.nodes.len(), "tets": t.tets.len(), "boundary_triangles": fem.surface.triangles.len(), "volume_m3": fem.surface.signed_volume(), "notes": fem.notes});
                    println!(
                        "{}",
                        if a.json {
                            serde_json::to_string_pretty(&v)?
                        } else {
                            v.to_string()
                        }
                    );
                    return Ok(());
                }
            };
            let (lo, hi) = s.bbox();
            let (r, report) = s
                .repaired(a.max_hole_edges)
                .context("the mesh cannot be used")?;
            let v = json!({
                "kind": "surface",
                "vertices": s.vertices.len(),
                "triangles": s.triangles.len(),
                "bbox_min_m": lo,
                "bbox_max_m": hi,
                "volume_m3": r.signed_volume(),
                "repairs": report.lines(),
            });
            if a.json {
                println!("{}", serde_json::to_string_pretty(&v)?);
            } else {
                println!(
                    "{} vertices, {} triangles; bbox {:?} .. {:?} m; closed volume {:.4e} m^3",
                    s.vertices.len(),
                    s.triangles.len(),
                    lo,
                    hi,
                    r.signed_volume()
                );
                for l in report.lines() {
                    println!("repair: {l}");
                }
            }
            Ok(())
        }
    }
}
