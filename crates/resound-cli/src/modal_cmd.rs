//! `resound modal` and `resound model`.

use crate::util::{parse_vec3, spinner, stage_message};
use anyhow::{bail, Context, Result};
use clap::Args;
use resound::core::{Material, ModalModel};
use resound::io::{load_mesh, model_file, mtx, LoadedMesh};
use resound::modal::{
    compute_modal_model_from_tets, compute_modal_model_keep_fem, ModalParams, ModalSolveInfo,
};
use serde_json::{json, Value};
use std::path::PathBuf;

/// Arguments of `resound modal`.
#[derive(Args, Debug)]
pub struct ModalArgs {
    /// Closed surface (.obj .stl .ply) or tet mesh (.msh .node/.ele .mesh).
    pub mesh: PathBuf,
    /// Material: a preset (steel, aluminium, glass, ceramic, wood, plastic) or E,nu,rho in Pa,-,kg/m^3.
    #[arg(long, short = 'm')]
    pub material: String,
    /// Number of elastic modes (lowest first). Default: all modes up to --max-freq-hz.
    #[arg(long, conflicts_with = "max_freq_hz")]
    pub modes: Option<usize>,
    /// Frequency cutoff in Hz [default: 20000 when --modes is not given].
    #[arg(long)]
    pub max_freq_hz: Option<f64>,
    /// Voxels along the longest side of the bounding box (surface meshes). Default: automatic (~6000 voxels).
    #[arg(long, default_value_t = 0)]
    pub resolution: usize,
    /// Multiply mesh coordinates by this (0.001 for a file in mm).
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
    /// Write the modal model here (.rmodal).
    #[arg(short = 'o', long)]
    pub output: Option<PathBuf>,
    /// Print a JSON summary on stdout instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Hit point x,y,z (m, after --scale): each mode also gets its gain (u.n/omega) there.
    #[arg(long)]
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
}

/// Arguments of `resound model`.
#[derive(Args, Debug)]
pub struct ModelInfoArgs {
    /// A .rmodal file.
    pub model: PathBuf,
    /// Rescale to this material (same Poisson ratio) without a new solve.
    #[arg(long, short = 'm')]
    pub material: Option<String>,
    /// Hit point x,y,z (m): print per-mode gains there.
    #[arg(long)]
    pub hit: Option<String>,
    /// JSON on stdout.
    #[arg(long)]
    pub json: bool,
}

fn params(a: &ModalArgs) -> Result<ModalParams> {
    if let Some(f) = a.max_freq_hz {
        if !(f > 0.0 && f.is_finite() && f <= 1e6) {
            bail!("--max-freq-hz {f} must be in (0, 1e6]");
        }
    }
    Ok(ModalParams {
        n_modes: a.modes,
        max_freq_hz: a.max_freq_hz,
        resolution: a.resolution,
        lumped_mass: a.lumped_mass,
        max_hole_edges: a.max_hole_edges,
        sturm_check: !a.no_sturm,
        threads: a.threads,
        ..Default::default()
    })
}

/// Runs `resound modal`.
pub fn run(a: ModalArgs) -> Result<()> {
    let material = Material::parse(&a.material)?;
    let hit = a.hit.as_deref().map(parse_vec3).transpose()?;
    let p = params(&a)?;
    let mesh = load_mesh(&a.mesh, a.scale).context("loading the mesh")?;
    let pb = spinner("modal");
    let progress = |s| stage_message(&pb, s);
    pb.set_message("voxelizing and assembling");
    let result = match &mesh {
        LoadedMesh::Surface(s) => compute_modal_model_keep_fem(s, &material, &p, &progress),
        LoadedMesh::Tets(t) => compute_modal_model_from_tets(t, &material, &p, &progress),
    };
    pb.finish_and_clear();
    let (model, info, fem) = result.context("modal analysis")?;
    if let Some(dir) = &a.export_matrices {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
        let note = format!(
            "resound {} {}: {} DOFs; DOF 3*node+c",
            env!("CARGO_PKG_VERSION"),
            fem.element,
            fem.n_dofs()
        );
        mtx::write_symmetric(
            &dir.join("K.mtx"),
            fem.k.as_ref(),
            &format!("stiffness K (N/m)\n{note}"),
        )?;
        mtx::write_symmetric(
            &dir.join("M.mtx"),
            fem.m.as_ref(),
            &format!("mass M (kg)\n{note}"),
        )?;
    }
    for w in &info.warnings {
        eprintln!("warning: {w}");
    }
    if let Some(r) = info.discretize.as_ref() {
        for l in r.repair.lines() {
            eprintln!("repaired: {l}");
        }
    }
    if let Some(out) = &a.output {
        model_file::save(out, &model).with_context(|| format!("writing {}", out.display()))?;
    }
    let gains = match hit {
        Some(h) => Some(hit_gains(&model, h)?),
        None => None,
    };
    if a.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&summary(&model, &info, gains.as_ref()))?
        );
    } else {
        print_table(&model, &info, gains.as_ref());
    }
    Ok(())
}

/// Gains per mode, surface point (m), unit normal, distance from the query (m).
pub type Hit = (Vec<f64>, [f64; 3], [f64; 3], f64);

pub fn hit_gains(model: &ModalModel, h: [f64; 3]) -> Result<Hit> {
    let (lo, hi) = resound::core::geometry::bbox(&model.vertices);
    let diag = (0..3).map(|c| (hi[c] - lo[c]).powi(2)).sum::<f64>().sqrt();
    let sp = model.locate_hit(h, 0.05 * diag)?;
    Ok((model.gains(&sp), sp.point, sp.normal, sp.distance))
}

fn summary(model: &ModalModel, info: &ModalSolveInfo, gains: Option<&Hit>) -> Value {
    let modes: Vec<Value> = (0..model.n_modes())
        .map(|j| match gains {
            Some(g) => json!({"freq_hz": model.freq_hz(j), "gain": g.0[j]}),
            None => json!({"freq_hz": model.freq_hz(j)}),
        })
        .collect();
    let mut v = json!({
        "dofs": info.dofs,
        "elements": info.elements,
        "element": info.element,
        "nnz": info.eigen.nnz_k,
        "nnz_factor": info.eigen.nnz_l,
        "assemble_s": info.assemble_s,
        "factor_s": info.eigen.factor_s,
        "eigen_s": info.eigen.eigen_s,
        "sturm_s": info.eigen.sturm_s,
        "solve_s": info.total_s,
        "operator_applications": info.eigen.applications,
        "max_rel_residual": info.eigen.max_rel_residual,
        "sturm_count": info.eigen.sturm_count,
        "rigid_modes_dropped": info.rigid_modes,
        "rigid_max_hz": info.rigid_max_hz,
        "material": {
            "name": model.material.name,
            "youngs_modulus_pa": model.material.youngs_modulus,
            "poisson_ratio": model.material.poisson_ratio,
            "density_kg_m3": model.material.density,
        },
        "surface_vertices": model.n_vertices(),
        "warnings": info.warnings,
        "modes": modes,
    });
    if let Some(r) = &info.discretize {
        v["voxel"] = json!({
            "resolution": r.resolution,
            "grid": r.grid_dims,
            "voxel_size_m": r.voxel_size_m,
            "fe_volume_m3": r.fe_volume_m3,
            "surface_volume_m3": r.surface_volume_m3,
            "repairs": r.repair.lines(),
        });
    }
    if let Some(g) = gains {
        v["hit"] = json!({"point": g.1, "normal": g.2, "distance_m": g.3});
    }
    v
}

fn print_table(model: &ModalModel, info: &ModalSolveInfo, gains: Option<&Hit>) {
    println!(
        "{} elements ({}), {} DOFs, {} modes in {:.2} s (assemble {:.2} s, factor {:.2} s, Lanczos {:.2} s, Sturm {:.2} s); max residual {:.1e}",
        info.elements, info.element, info.dofs, model.n_modes(), info.total_s, info.assemble_s,
        info.eigen.factor_s, info.eigen.eigen_s, info.eigen.sturm_s, info.eigen.max_rel_residual
    );
    if let Some(g) = gains {
        println!(
            "hit at ({:.4}, {:.4}, {:.4}) m, normal ({:.3}, {:.3}, {:.3})",
            g.1[0], g.1[1], g.1[2], g.2[0], g.2[1], g.2[2]
        );
        println!("{:>5} {:>12} {:>14}", "mode", "freq_hz", "gain_m_per_Ns");
    } else {
        println!("{:>5} {:>12}", "mode", "freq_hz");
    }
    for j in 0..model.n_modes() {
        match gains {
            Some(g) => println!("{:>5} {:>12.2} {:>14.4e}", j + 1, model.freq_hz(j), g.0[j]),
            None => println!("{:>5} {:>12.2}", j + 1, model.freq_hz(j)),
        }
    }
}

/// Runs `resound model`.
pub fn run_info(a: ModelInfoArgs) -> Result<()> {
    let t0 = std::time::Instant::now();
    let mut model = model_file::load(&a.model)?;
    let load_ms = t0.elapsed().as_secs_f64() * 1e3;
    if let Some(m) = &a.material {
        model = model.rescaled(&Material::parse(m)?)?;
    }
    let gains = a
        .hit
        .as_deref()
        .map(parse_vec3)
        .transpose()?
        .map(|h| hit_gains(&model, h))
        .transpose()?;
    if a.json {
        let mut info = ModalSolveInfo {
            dofs: model.fem_dofs as usize,
            elements: model.fem_elements as usize,
            ..Default::default()
        };
        info.element = "";
        let mut v = summary(&model, &info, gains.as_ref());
        v["load_ms"] = json!(load_ms);
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "{}: {} modes, {} surface vertices, material {} (E {:.3e} Pa, nu {}, rho {} kg/m^3); loaded in {load_ms:.2} ms",
            a.model.display(), model.n_modes(), model.n_vertices(), model.material.name,
            model.material.youngs_modulus, model.material.poisson_ratio, model.material.density
        );
        for j in 0..model.n_modes() {
            match &gains {
                Some(g) => println!("{:>5} {:>12.2} {:>14.4e}", j + 1, model.freq_hz(j), g.0[j]),
                None => println!("{:>5} {:>12.2}", j + 1, model.freq_hz(j)),
            }
        }
    }
    Ok(())
}
