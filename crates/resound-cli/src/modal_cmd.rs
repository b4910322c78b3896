//! `resound modal` and `resound model`.

use crate::util::{parse_vec3, print_json, warn_all};
use anyhow::Result;
use clap::Args;
use resound::core::Material;
use resound::io::model_file;
use resound::modal::ModalParams;
use resound::object::{solve_object, SolveJob, SolveOutcome};
use std::path::PathBuf;

/// Arguments of `resound modal`.
#[derive(Args, Debug)]
pub struct ModalArgs {
    /// Closed surface (.obj .stl .ply) or tet mesh (.msh .node/.ele .mesh).
    pub mesh: PathBuf,
    /// Material: a name (steel, aluminium, glass, ceramic, wood, plastic; metal = steel,
    /// porcelain = ceramic) or E,nu,rho in Pa,-,kg/m^3.
    #[arg(long, short = 'm')]
    pub material: String,
    /// Number of elastic modes (lowest first). Default: all modes up to --max-freq-hz.
    #[arg(long, conflicts_with = "max_freq_hz")]
    pub modes: Option<usize>,
    /// Frequency cutoff in Hz [default: 20000 when --modes is not given].
    #[arg(allow_hyphen_values = true, long)]
    pub max_freq_hz: Option<f64>,
    /// Voxels along the longest side of the bounding box (surface meshes). Default: automatic (~6000 voxels).
    #[arg(long, default_value_t = 0)]
    pub resolution: usize,
    /// Most elastic modes solved below the cutoff: more are refused before the solve (the
    /// count comes first, from one factorization).
    #[arg(long, default_value_t = 2000)]
    pub max_modes: usize,
    /// Multiply mesh coordinates by this (0.001 for a file in mm).
    #[arg(allow_hyphen_values = true, long, default_value_t = 1.0)]
    pub scale: f64,
    /// Write the modal model here (.rmodal).
    #[arg(short = 'o', long)]
    pub output: Option<PathBuf>,
    /// Print a JSON summary on stdout instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Hit point x,y,z (m, after --scale): each mode also gets its gain (u.n/omega) there.
    #[arg(allow_hyphen_values = true, long)]
    pub hit: Option<String>,
    /// Write K and M as Matrix Market files K.mtx and M.mtx into this directory.
    #[arg(long)]
    pub export_matrices: Option<PathBuf>,
    /// Use a lumped (diagonal) mass matrix instead of the consistent one.
    #[arg(long)]
    pub lumped_mass: bool,
    /// Fill holes of a surface mesh whose boundary has at most this many edges.
    #[arg(long, default_value_t = 0)]
    pub max_hole_edges: usize,
    /// Skip the Sturm-sequence check of the mode count (saves one factorization).
    #[arg(long)]
    pub no_sturm: bool,
    /// Threads (0: all cores).
    #[arg(long, default_value_t = 0)]
    pub threads: usize,
    /// Also fit each mode's acoustic transfer (radiated pressure, near and far, as a multipole
    /// expansion on a frequency grid ± 2 octaves around the mode) and store it in the model.
    #[arg(long)]
    pub transfer: bool,
    /// Highest multipole order of the transfer (1–30; its storage per mode grows as (order + 1)²).
    #[arg(long, default_value_t = 20, requires = "transfer")]
    pub transfer_order: usize,
    /// Most equivalent sources of the transfer fit (cost grows as their square).
    #[arg(long, default_value_t = 800, requires = "transfer")]
    pub transfer_sources: usize,
}

/// Arguments of `resound model`.
#[derive(Args, Debug)]
pub struct ModelInfoArgs {
    /// A .rmodal file.
    pub model: PathBuf,
    /// Rescale to this material (same Poisson ratio) without a new solve.
    #[arg(long, short = 'm')]
    pub material: Option<String>,
    /// With --material: take its E/ρ but keep the model's Poisson ratio (exact for that ν;
    /// only an approximation of the other material's modes, whose shapes depend on ν).
    #[arg(long, requires = "material")]
    pub keep_nu: bool,
    /// Hit point x,y,z (m): print per-mode gains there.
    #[arg(allow_hyphen_values = true, long)]
    pub hit: Option<String>,
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

fn params(a: &ModalArgs) -> ModalParams {
    ModalParams {
        n_modes: a.modes,
        max_freq_hz: a.max_freq_hz,
        resolution: a.resolution,
        lumped_mass: a.lumped_mass,
        max_hole_edges: a.max_hole_edges,
        sturm_check: !a.no_sturm,
        threads: a.threads,
        max_modes: a.max_modes,
        ..Default::default()
    }
}

/// Runs `resound modal`.
pub fn run(a: ModalArgs) -> Result<()> {
    crate::util::check_paths([&a.mesh], a.output.iter().chain(&a.export_matrices))?;
    let job = SolveJob {
        mesh: a.mesh.clone(),
        scale: a.scale,
        material: Material::parse(&a.material)?,
        modal: params(&a),
        transfer: a.transfer.then(|| resound::modal::TransferParams {
            max_order: a.transfer_order,
            max_sources: a.transfer_sources,
            ..Default::default()
        }),
        hit_m: a.hit.as_deref().map(parse_vec3).transpose()?,
        export_matrices: a.export_matrices.clone(),
    };
    let SolveOutcome {
        model,
        report,
        repairs,
        ..
    } = crate::util::with_bar("modal", |cb| solve_object(&job, cb))?;
    warn_all(&report.warnings);
    for l in repairs {
        eprintln!("repaired: {l}");
    }
    if let Some(out) = &a.output {
        model_file::save(out, &model)?;
        eprintln!("wrote {} ({} modes)", out.display(), model.n_modes());
    }
    crate::util::show(a.json, &report)
}

/// Runs `resound model`.
pub fn run_info(a: ModelInfoArgs) -> Result<()> {
    let material = a.material.as_deref().map(Material::parse).transpose()?;
    let hit = a.hit.as_deref().map(parse_vec3).transpose()?;
    let info = resound::object::model_info(&a.model, material.as_ref(), a.keep_nu, hit)?;
    crate::util::notes(&info.notes);
    if a.json {
        // The modal report alone: the document Python's `ModalModel.report` gives.
        return print_json(&info.report);
    }
    print!("{info}");
    Ok(())
}
