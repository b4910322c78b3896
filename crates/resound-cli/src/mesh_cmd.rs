//! `resound mesh …`.

use crate::util::parse_list;
use anyhow::Result;
use clap::{Args, Subcommand};
use resound::mesh::{check_mesh, write_primitive, PrimitiveKind};
use std::path::PathBuf;

/// Mesh subcommands.
#[derive(Subcommand, Debug)]
pub enum MeshCmd {
    /// Write a closed primitive surface (sizes in m): bar/box x,y,z; plate x,y,thickness; cylinder radius,height; sphere radius; bowl radius,thickness(,depth).
    Primitive(PrimitiveArgs),
    /// Check a mesh: counts, bounding box, volume, and what repair would change (or why it cannot be used).
    Check(CheckArgs),
}

/// Arguments of `mesh primitive`.
#[derive(Args, Debug)]
pub struct PrimitiveArgs {
    /// Which shape, centred on the origin: bar and box (x,y,z), plate (x,y,thickness),
    /// cylinder (radius,height along z), sphere (radius), bowl (radius,thickness(,depth); rim
    /// at z = 0, the bowl below it).
    #[arg(value_parser = parse_kind)]
    pub kind: PrimitiveKind,
    /// Comma-separated sizes in m (see the shape).
    #[arg(allow_hyphen_values = true, long)]
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
    #[arg(allow_hyphen_values = true, long, default_value_t = 1.0)]
    pub scale: f64,
    /// Fill holes with at most this many boundary edges.
    #[arg(long, default_value_t = 0)]
    pub max_hole_edges: usize,
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

fn parse_kind(s: &str) -> std::result::Result<PrimitiveKind, String> {
    PrimitiveKind::from_name(s).ok_or_else(|| {
        let names: Vec<&str> = PrimitiveKind::NAMES.iter().map(|(n, _)| *n).collect();
        format!("unknown shape '{s}' (one of {})", names.join(", "))
    })
}

/// Runs a mesh subcommand.
pub fn run(c: MeshCmd) -> Result<()> {
    match c {
        MeshCmd::Primitive(a) => {
            let info = write_primitive(a.kind, &parse_list(&a.size)?, a.segments, &a.output)?;
            eprintln!("wrote {} ({info})", a.output.display());
            crate::util::warn_all(&info.warnings);
        }
        MeshCmd::Check(a) => {
            let r = check_mesh(&a.mesh, a.scale, a.max_hole_edges)?;
            crate::util::show(a.json, &r)?;
        }
    }
    Ok(())
}
