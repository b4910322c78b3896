//! `resound bench …`: the harness (benchmark meshes, child processes, peak memory) here and one
//! module per benchmark with its table and JSON. Modal cases run in a fresh child process
//! (`resound bench-case`) so peak memory (VmHWM) belongs to that case alone; scene cases run
//! `resound scene` likewise. Call these from the `resound` binary (they re-run it); its CLI
//! owns the flags and hands each runner its settings.

use anyhow::{bail, Context, Result};
use resound::core::Material;
use resound::fem::{discretize, primitive, SurfaceMesh};
use resound::modal::{EigenMethod, Geometry, ModalBuilder, ModalParams};
use serde::{Deserialize, Serialize};
use std::process::Command;

/// The bundled CC0 mesh (Keenan Crane's Spot), see assets/meshes/LICENSE-spot.md.
const SPOT_OBJ: &[u8] = include_bytes!("../../../../assets/meshes/spot.obj");
/// Spot is in arbitrary units with a 1.7 long side: 0.15 makes it a 26 cm ceramic cow.
const SPOT_SCALE: f64 = 0.15;

mod analyze;
mod batch;
mod estimate;
mod grains;
mod live;
mod modal;
mod radiation;
mod scene;
mod stats;
mod synth;

pub use analyze::run_analyze;
pub use batch::run_batch_bench;
pub use estimate::run_estimate;
pub use grains::run_grains;
pub use live::run_live;
pub use modal::run_modal;
pub use radiation::run_radiation;
pub use scene::{box_scene, run_scene};
pub use stats::run_stats;
pub use synth::run_synth;

/// Settings of `bench radiation`.
#[derive(Debug, Clone)]
pub struct RadiationBenchArgs {
    /// JSON on stdout.
    pub json: bool,
    /// Modes.
    pub modes: usize,
    /// Most equivalent sources of the fit.
    pub sources: usize,
}

/// Settings of `bench batch`.
#[derive(Debug, Clone)]
pub struct BatchBenchArgs {
    /// JSON on stdout.
    pub json: bool,
    /// Meshes (boxes of different sizes).
    pub meshes: usize,
    /// Hit points per mesh (one job each).
    pub hits: usize,
    /// Modes per model.
    pub modes: usize,
    /// Length of each strike, s.
    pub duration_s: f64,
}

/// Settings of `bench live`.
#[derive(Debug, Clone)]
pub struct LiveBenchArgs {
    /// JSON on stdout.
    pub json: bool,
    /// Bodies of the main run.
    pub bodies: usize,
    /// Seconds of the main run.
    pub seconds: f64,
    /// Samples per callback.
    pub block: usize,
    /// Largest body count tried when searching for the first deadline miss (doubling from
    /// `--bodies`, 5 s each).
    pub max_bodies: usize,
}

/// Settings of `bench grains`.
#[derive(Debug, Clone)]
pub struct GrainsBenchArgs {
    /// JSON on stdout.
    pub json: bool,
    /// The shared recordings (with `spatialaudio-ramp/` and `minetest-game/`); default: the
    /// first of ../shared/data/recordings, /work/shared/data/recordings that exists.
    pub data: Option<std::path::PathBuf>,
}

/// Settings of `bench stats`.
#[derive(Debug, Clone)]
pub struct StatsBenchArgs {
    /// JSON on stdout.
    pub json: bool,
}

/// Settings of `bench scene`.
#[derive(Debug, Clone)]
pub struct SceneBenchArgs {
    /// JSON on stdout.
    pub json: bool,
    /// Body counts.
    pub bodies: Vec<usize>,
    /// Seconds of audio.
    pub seconds: f64,
    /// Keep the scene files, library, cache and WAVs in this directory (default: a temporary one).
    pub dir: Option<std::path::PathBuf>,
    /// Physics steps per second (the scene files' default).
    pub steps_per_second: f64,
}

/// Settings of `bench synth`.
#[derive(Debug, Clone)]
pub struct SynthBenchArgs {
    /// JSON on stdout.
    pub json: bool,
    /// Modes in the bank.
    pub modes: usize,
    /// Seconds of audio rendered per measurement.
    pub seconds: f64,
    /// Residual transfer events.
    pub events: usize,
}

/// Settings of `bench estimate`.
#[derive(Debug, Clone)]
pub struct EstimateBenchArgs {
    /// JSON on stdout.
    pub json: bool,
    /// Skip the closed-form / synthesize+STFT comparison rows.
    pub no_synthesized: bool,
}

/// Settings of `bench analyze`.
#[derive(Debug, Clone)]
pub struct AnalyzeBenchArgs {
    /// JSON on stdout.
    pub json: bool,
    /// Single damped sinusoids (protocol 1).
    pub trials: usize,
    /// Mixtures per SNR (protocol 2).
    pub mixtures: usize,
    /// SNRs of protocol 2, dB.
    pub snr_db: String,
    /// Random seed.
    pub seed: u64,
    /// Skip the stage-1-only (Ren 2013 alone) comparison rows.
    pub no_stage1: bool,
    /// Cases per SNR of the wide protocol (4): 20 Hz–22 kHz, d 0.1–1000 1/s, doublets, a noisy
    /// lead-in with a DC offset (0: skip).
    pub wide: usize,
    /// SNRs of the wide protocol, dB.
    pub wide_snr_db: String,
    /// Run only the wide protocol.
    pub wide_only: bool,
    /// Skip the textbook ESPRIT baseline rows of the wide protocol.
    pub no_baseline: bool,
}

/// Settings of `bench modal`.
#[derive(Debug, Clone)]
pub struct ModalBenchArgs {
    /// JSON on stdout.
    pub json: bool,
    /// Target DOF counts.
    pub dofs: Vec<usize>,
    /// Elastic modes per solve.
    pub modes: usize,
    /// Meshes: bar, spot.
    pub meshes: String,
    /// Also certify the count with a Sturm check (one more factorization).
    pub sturm: bool,
    /// Also run faer's single-vector Lanczos (the baseline) on cases up to this many DOFs and
    /// report the speed-up ratio measured in the same run (0: off).
    pub compare_up_to: usize,
    /// Also run the scipy peer (`peer/modal_peer.py`) on each case's matrices.
    pub peer: bool,
}

/// One case (hidden subcommand).
#[derive(Debug, Clone)]
pub struct CaseArgs {
    /// bar or spot.
    pub mesh: String,
    /// Target DOFs.
    pub target_dofs: usize,
    /// Elastic modes.
    pub modes: usize,
    /// Sturm check.
    pub sturm: bool,
    /// Use faer's single-vector Lanczos instead of block Lanczos.
    pub faer_lanczos: bool,
    /// Write K.mtx and M.mtx here after the solve and list every frequency.
    pub export: Option<std::path::PathBuf>,
}

fn bench_mesh(name: &str) -> Result<(SurfaceMesh, Material)> {
    Ok(match name {
        "bar" => (
            primitive::bar([0.3, 0.02, 0.01]),
            Material::preset("steel")?,
        ),
        "spot" => {
            let dir = tempfile_dir()?;
            let p = dir.join("spot.obj");
            std::fs::write(&p, SPOT_OBJ)?;
            let m = match resound::io::load_mesh(&p, SPOT_SCALE)? {
                resound::io::LoadedMesh::Surface(s) => s,
                resound::io::LoadedMesh::Tets(_) => bail!("spot is a surface"),
            };
            let _ = std::fs::remove_dir_all(&dir);
            (m, Material::preset("ceramic")?)
        }
        other => bail!("unknown benchmark mesh '{other}' (bar, spot)"),
    })
}

fn tempfile_dir() -> Result<std::path::PathBuf> {
    let d = std::env::temp_dir().join(format!("resound-bench-{}", std::process::id()));
    std::fs::create_dir_all(&d)?;
    Ok(d)
}

fn peak_rss_mib() -> Option<f64> {
    let s = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = s.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Runs one case and prints one JSON line.
pub fn run_case(a: CaseArgs) -> Result<()> {
    let (mesh, material) = bench_mesh(&a.mesh)?;
    let (surface, _) = mesh.repaired(0)?;
    let resolution = discretize::resolution_for_dofs(&surface, a.target_dofs);
    let t0 = std::time::Instant::now();
    let vp = discretize::VoxelParams {
        resolution,
        ..Default::default()
    };
    let (fem, _) = discretize::discretize_surface(&surface, &material, &vp)?;
    let assemble_s = t0.elapsed().as_secs_f64();
    let method = if a.faer_lanczos {
        EigenMethod::Lanczos
    } else {
        EigenMethod::BlockLanczos
    };
    let p = ModalParams {
        method,
        n_modes: Some(a.modes),
        sturm_check: a.sturm,
        resolution,
        ..Default::default()
    };
    let solved = ModalBuilder::new(
        Geometry::Fem {
            fem: &fem,
            components: 1,
        },
        &material,
    )
    .params(p)
    .solve()?;
    let (model, info) = (solved.model, solved.info);
    let total_s = t0.elapsed().as_secs_f64();
    // The matrices go out after the clock stopped: the peer solves the very same problem.
    if let Some(dir) = &a.export {
        std::fs::create_dir_all(dir)?;
        resound::io::mtx::write_symmetric(&dir.join("K.mtx"), fem.k.as_ref(), "stiffness K (N/m)")?;
        resound::io::mtx::write_symmetric(&dir.join("M.mtx"), fem.m.as_ref(), "mass M (kg)")?;
    }
    let v = ModalCase {
        mesh: a.mesh.clone(),
        method: if a.faer_lanczos {
            "faer-lanczos"
        } else {
            "block-lanczos"
        }
        .into(),
        material: material.name.clone(),
        target_dofs: a.target_dofs,
        resolution,
        dofs: info.dofs,
        elements: info.elements,
        nnz: info.eigen.nnz_k,
        nnz_factor: info.eigen.nnz_l,
        modes: model.n_modes(),
        assemble_s,
        factor_s: info.eigen.factor_s,
        eigen_s: info.eigen.eigen_s,
        sturm_s: info.eigen.sturm_s,
        total_s,
        operator_applications: info.eigen.applications,
        max_rel_residual: info.eigen.max_rel_residual,
        peak_rss_mib: peak_rss_mib(),
        f1_hz: model.freqs_hz().first().copied(),
        f_last_hz: model.freqs_hz().last().copied(),
        baseline_faer_lanczos_total_s: None,
        speedup_vs_faer_lanczos: None,
        freqs_hz: if a.export.is_some() {
            model.freqs_hz().to_vec()
        } else {
            Vec::new()
        },
        peer: None,
    };
    println!("{}", serde_json::to_string(&v)?);
    Ok(())
}

/// One modal case, as the child process prints it (one JSON line).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct ModalCase {
    /// bar or spot.
    pub mesh: String,
    /// block-lanczos or faer-lanczos.
    pub method: String,
    /// Material.
    pub material: String,
    /// DOFs aimed at.
    pub target_dofs: usize,
    /// Voxels along the longest side.
    pub resolution: usize,
    /// DOFs.
    pub dofs: usize,
    /// Elements.
    pub elements: usize,
    /// Nonzeros of K.
    pub nnz: usize,
    /// Nonzeros of the factor.
    pub nnz_factor: usize,
    /// Modes.
    pub modes: usize,
    /// Discretization and assembly, s.
    pub assemble_s: f64,
    /// Factorization, s.
    pub factor_s: f64,
    /// Lanczos, s.
    pub eigen_s: f64,
    /// Sturm check, s.
    pub sturm_s: f64,
    /// Everything, s.
    pub total_s: f64,
    /// Operator applications.
    pub operator_applications: usize,
    /// Largest true relative residual.
    pub max_rel_residual: f64,
    /// Peak resident memory of the case, MiB.
    pub peak_rss_mib: Option<f64>,
    /// First frequency, Hz.
    pub f1_hz: Option<f64>,
    /// Last frequency, Hz.
    pub f_last_hz: Option<f64>,
    /// The baseline's time on the same case, s.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub baseline_faer_lanczos_total_s: Option<f64>,
    /// Baseline time over ours.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub speedup_vs_faer_lanczos: Option<f64>,
    /// Every elastic frequency, Hz (only when the matrices were exported for the peer).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub freqs_hz: Vec<f64>,
    /// The scipy peer on the same matrices, in the same run.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub peer: Option<PeerRow>,
}

/// The scipy peer (`peer/modal_peer.py`) on one case's exported K, M.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct PeerRow {
    /// What solved it: scipy's version and the factorization (cholmod or superlu).
    pub solver: String,
    /// Factorization of K − σM, s.
    pub factor_s: f64,
    /// Factorization and eigsh, s (reading the files not counted).
    pub total_s: f64,
    /// Peak resident memory of the peer's process (files read in included), MiB.
    pub peak_rss_mib: f64,
    /// The peer's time over ours (our time includes discretization and assembly).
    #[serde(default)]
    pub speedup: f64,
    /// Largest relative difference of an elastic frequency, ours against the peer's.
    #[serde(default)]
    pub max_rel_freq_diff: f64,
    /// Every frequency the peer found, Hz (rigid modes first).
    #[serde(default, skip_serializing)]
    pub freqs_hz: Vec<f64>,
}

fn run_child(
    exe: &std::path::Path,
    mesh: &str,
    dofs: usize,
    modes: usize,
    sturm: bool,
    faer: bool,
    export: Option<&std::path::Path>,
) -> Result<ModalCase> {
    let mut cmd = Command::new(exe);
    cmd.args([
        "bench-case",
        "--mesh",
        mesh,
        "--target-dofs",
        &dofs.to_string(),
        "--modes",
        &modes.to_string(),
    ]);
    if sturm {
        cmd.arg("--sturm");
    }
    if faer {
        cmd.arg("--faer-lanczos");
    }
    if let Some(dir) = export {
        cmd.arg("--export").arg(dir);
    }
    let out = cmd.output().context("running a benchmark case")?;
    if !out.status.success() {
        bail!(
            "benchmark case {mesh}/{dofs} failed: {}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    serde_json::from_slice(&out.stdout).context("parsing a benchmark case")
}
