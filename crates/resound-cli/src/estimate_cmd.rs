//! `resound estimate` and `resound materials`: material estimation and the material library.

use crate::modal_cmd::hit_gains;
use crate::util::{parse_vec3, spinner, stage_message};
use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use resound::core::{Material, ModalModel, Provenance, SoundMaterial};
use resound::estimate::{
    estimate, estimate::starting_points_within, estimate::Objective, EstimateParams, ModalSide,
};
use resound::io::library::{default_library_path, read_material, write_material, Library};
use resound::io::{load_audio, load_mesh, model_file, LoadedMesh};
use resound::modal::{compute_modal_model, compute_modal_model_from_tets, ModalParams};
use resound::signal::{analyze, filter::highpass_zero_phase, AnalyzeParams};
use serde_json::json;
use std::path::PathBuf;

/// Arguments of `estimate`.
#[derive(Args, Debug)]
pub struct EstimateArgs {
    /// Recording of one strike of the object.
    pub audio: PathBuf,
    /// The object: a closed surface or tet mesh, or a saved modal model (.rmodal).
    #[arg(long)]
    pub mesh: PathBuf,
    /// Hit point x,y,z in metres (snapped to the nearest surface point).
    #[arg(long, allow_hyphen_values = true)]
    pub hit: String,
    /// Scale applied to the mesh coordinates (0.001 for millimetres).
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
    /// Elastic modes to compute when a mesh is given.
    #[arg(long, default_value_t = 200)]
    pub modes: usize,
    /// Reference material for the modal solve (only E/ρ's ratio matters; ν is kept).
    #[arg(long, default_value = "ceramic")]
    pub reference_material: String,
    /// Zero-phase high-pass before analysis (e.g. 100 against room rumble).
    #[arg(long, value_name = "HZ")]
    pub highpass_hz: Option<f64>,
    /// Store the result in the library under this name.
    #[arg(long)]
    pub name: Option<String>,
    /// Write the material file (JSON) here.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
    /// JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
    /// Draw recorded vs estimated features in the (f, d) plane with the Rayleigh curve, and
    /// the two loudness images the metric compares, to this PNG.
    #[arg(long, value_name = "OUT.png")]
    pub plot: Option<PathBuf>,
    /// Material library (default: $RESOUND_LIBRARY or ~/.local/share/resound/materials.sqlite).
    #[arg(long)]
    pub library: Option<PathBuf>,
    /// Do not compute and store the residual (Ren §6.1).
    #[arg(long)]
    pub no_residual: bool,
}

/// Longest residual stored with a material, s (keeps material files small; a residual is
/// mostly the strike's transient).
const MAX_RESIDUAL_S: f64 = 1.0;

/// The material library path from `--library` or the default.
pub fn library_path(p: &Option<PathBuf>) -> Result<PathBuf> {
    match p {
        Some(p) => Ok(p.clone()),
        None => default_library_path()
            .context("no home directory for the default library; pass --library PATH"),
    }
}

/// A modal model from a saved `.rmodal` or a mesh (solved here with `reference_material`).
pub fn load_model(
    mesh_path: &std::path::Path,
    scale: f64,
    modes: usize,
    reference_material: &str,
) -> Result<ModalModel> {
    if mesh_path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("rmodal"))
    {
        return Ok(model_file::load(mesh_path)?);
    }
    let material = Material::parse(reference_material)?;
    let p = ModalParams {
        n_modes: Some(modes),
        max_freq_hz: None,
        ..Default::default()
    };
    let mesh = load_mesh(mesh_path, scale).context("loading the mesh")?;
    let pb = spinner("modal");
    let progress = |s| stage_message(&pb, s);
    let r = match &mesh {
        LoadedMesh::Surface(s) => compute_modal_model(s, &material, &p, &progress),
        LoadedMesh::Tets(t) => {
            compute_modal_model_from_tets(t, &material, &p, &progress).map(|(m, i, _)| (m, i))
        }
    };
    pb.finish_and_clear();
    Ok(r.context("modal analysis")?.0)
}

/// Runs `estimate`.
pub fn run(a: EstimateArgs) -> Result<()> {
    let hit = parse_vec3(&a.hit)?;
    if let Some(n) = &a.name {
        SoundMaterial::rayleigh(n, 1.0, 1.0, 1.0, 1.0)
            .validate()
            .map_err(anyhow::Error::msg)?;
    }
    let clip = load_audio(&a.audio)?;
    let x = clip.mono(None, &a.audio)?;
    let fs = f64::from(clip.sample_rate_hz);
    let params = AnalyzeParams {
        highpass_hz: a.highpass_hz,
        ..AnalyzeParams::default()
    };
    let analysis =
        analyze(&x, fs, &params).with_context(|| format!("analysing {}", a.audio.display()))?;
    for w in &analysis.warnings {
        eprintln!("warning: {w}");
    }
    if analysis.modes.is_empty() {
        bail!(
            "no modes found in {}: nothing to estimate from",
            a.audio.display()
        );
    }
    let model = load_model(&a.mesh, a.scale, a.modes, &a.reference_material)?;
    let (gains, point, _, distance) = hit_gains(&model, hit)?;
    if distance > 1e-6 {
        eprintln!(
            "note: hit point {:?} is {:.2} mm off the surface; using the nearest surface point {:?}",
            hit,
            distance * 1e3,
            point
        );
    }
    let gamma0 = model.material.youngs_modulus / model.material.density;
    let side = ModalSide {
        eigenvalues0: model.eigenvalues.clone(),
        gains0: gains,
        gamma0,
    };
    let band_top = analysis.modes.iter().map(|m| m.freq_hz).fold(0.0, f64::max);
    if model.eigenvalues.is_empty() {
        bail!("the modal model has no modes");
    }
    let onset = (analysis.onset_s * fs).round() as usize;
    let mut seg = x[onset.min(x.len())..].to_vec();
    if let Some(f) = a.highpass_hz {
        highpass_zero_phase(&mut seg, f, fs);
    }
    seg.truncate(analysis.samples);
    let ep = EstimateParams::default();
    let n_starts =
        starting_points_within(&side, &analysis.modes, ep.dominant, seg.len() as f64 / fs)
            .len()
            .min(resound::estimate::estimate::MAX_STARTS);
    let pb = ProgressBar::new(n_starts as u64);
    pb.set_style(
        ProgressStyle::with_template("{prefix} [{elapsed}] {bar:30} {pos}/{len} starts")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    pb.set_prefix("estimate");
    let t0 = std::time::Instant::now();
    let tick = || pb.inc(1);
    let est = estimate(&side, &seg, fs, &analysis.modes, &ep, &tick)
        .with_context(|| format!("estimating the material of {}", a.audio.display()))?;
    pb.finish_and_clear();
    let elapsed_s = t0.elapsed().as_secs_f64();
    let name = a.name.clone().unwrap_or_else(|| {
        a.audio
            .file_stem()
            .map_or("estimated".into(), |s| s.to_string_lossy().into_owned())
    });
    // Ren §6.1: the residual against the estimated modes on this object at this hit.
    let estimated_modes = resound::estimate::forward_modes(
        &side.eigenvalues0,
        &side.gains0,
        side.gamma0,
        &est.params,
        0.5 * fs,
    );
    let residual = if a.no_residual {
        None
    } else {
        let mut r =
            resound::synth::residual::compute_residual(&seg, fs, &analysis.modes, &estimated_modes);
        r.samples.truncate((MAX_RESIDUAL_S * fs) as usize);
        Some(r)
    };
    let material = SoundMaterial {
        residual,
        provenance: Some(Provenance {
            recording: a.audio.display().to_string(),
            mesh: a.mesh.display().to_string(),
            hit: point,
            metric: est.metric,
            features: analysis.modes.clone(),
        }),
        ..SoundMaterial::rayleigh(
            &name,
            est.params.alpha,
            est.params.beta,
            est.params.gamma,
            est.params.sigma,
        )
    };
    if let Some(o) = &a.output {
        write_material(o, &material)?;
    }
    if let Some(path) = &a.plot {
        let objective = Objective::new(&side, &seg, fs, &analysis.modes, ep.floor_db, ep.route)?;
        let estimated = objective.modes(&est.params);
        let level = |m: &resound::core::DampedMode| {
            resound::signal::mode_level(m, resound::signal::LEVEL_WINDOW_S)
        };
        let floor = analysis.modes.iter().map(level).fold(0.0, f64::max) * 1e-3;
        let shown: Vec<_> = estimated
            .into_iter()
            .filter(|m| level(m) >= floor)
            .collect();
        crate::plot::estimate_png(
            path,
            &crate::plot::EstimatePlot {
                title: &a
                    .audio
                    .file_name()
                    .map_or(String::new(), |s| s.to_string_lossy().into_owned()),
                reference: &analysis.modes,
                estimated: &shown,
                alpha: est.params.alpha,
                beta: est.params.beta,
                reference_image: objective.reference_image(),
                estimated_image: &objective.image(&est.params),
            },
        )?;
    }
    if a.name.is_some() {
        let mut lib = Library::open(&library_path(&a.library)?)?;
        lib.put(&material)?;
    }
    let lowest_model_hz = model.freq_hz(0) * (est.params.gamma / gamma0).sqrt();
    if lowest_model_hz > band_top {
        eprintln!("warning: the object's lowest mode ({lowest_model_hz:.0} Hz) lies above every recorded mode");
    }
    if a.json {
        let v = json!({
            "name": name,
            "alpha": est.params.alpha,
            "beta": est.params.beta,
            "gamma": est.params.gamma,
            "sigma": est.params.sigma,
            "metric": est.metric,
            "elapsed_s": elapsed_s,
            "starts": est.starts,
            "evaluations": est.evaluations,
            "reference_modes": analysis.modes.len(),
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "{name}: alpha {:.4e} 1/s, beta {:.4e} s, gamma {:.4e} m²/s², sigma {:.4e}; metric {:.4e} ({} starts, {} evaluations, {:.1} s)",
            est.params.alpha, est.params.beta, est.params.gamma, est.params.sigma, est.metric, est.starts, est.evaluations, elapsed_s
        );
    }
    Ok(())
}

/// `resound materials …`.
#[derive(Subcommand, Debug)]
pub enum MaterialsCmd {
    /// List the library's materials.
    List(LibArg),
    /// Print one material as JSON.
    Show(NameArg),
    /// Add (or replace) a material from a material file.
    Import(FileArg),
    /// Write one material to a material file.
    Export(ExportArg),
    /// Remove a material.
    Remove(NameArg),
}

/// Library location.
#[derive(Args, Debug)]
pub struct LibArg {
    /// Material library path.
    #[arg(long)]
    pub library: Option<PathBuf>,
}

/// A material name.
#[derive(Args, Debug)]
pub struct NameArg {
    /// Material name.
    pub name: String,
    /// Material library path.
    #[arg(long)]
    pub library: Option<PathBuf>,
}

/// A material file.
#[derive(Args, Debug)]
pub struct FileArg {
    /// Material file (JSON).
    pub file: PathBuf,
    /// Material library path.
    #[arg(long)]
    pub library: Option<PathBuf>,
}

/// Export arguments.
#[derive(Args, Debug)]
pub struct ExportArg {
    /// Material name.
    pub name: String,
    /// Output material file (JSON).
    pub file: PathBuf,
    /// Material library path.
    #[arg(long)]
    pub library: Option<PathBuf>,
}

pub fn open(p: &Option<PathBuf>) -> Result<Library> {
    let path = library_path(p)?;
    Library::open(&path).with_context(|| format!("opening the material library {}", path.display()))
}

pub fn get(lib: &Library, name: &str) -> Result<SoundMaterial> {
    lib.get(name)?.with_context(|| {
        format!(
            "no material {name:?} in the library (known: {})",
            lib.names().unwrap_or_default().join(", ")
        )
    })
}

/// Runs `materials`.
pub fn run_materials(c: MaterialsCmd) -> Result<()> {
    match c {
        MaterialsCmd::List(a) => {
            let lib = open(&a.library)?;
            for n in lib.names()? {
                let m = get(&lib, &n)?;
                println!(
                    "{n:<16} alpha {:.4e}  beta {:.4e}  gamma {:.4e}  sigma {:.4e}{}",
                    m.alpha,
                    m.beta,
                    m.gamma,
                    m.sigma,
                    if m.provenance.is_some() {
                        "  (estimated)"
                    } else {
                        ""
                    }
                );
            }
        }
        MaterialsCmd::Show(a) => {
            let lib = open(&a.library)?;
            println!("{}", serde_json::to_string_pretty(&get(&lib, &a.name)?)?);
        }
        MaterialsCmd::Import(a) => {
            let m = read_material(&a.file)?;
            let mut lib = open(&a.library)?;
            lib.put(&m)?;
            eprintln!("imported {:?}", m.name);
        }
        MaterialsCmd::Export(a) => {
            let lib = open(&a.library)?;
            write_material(&a.file, &get(&lib, &a.name)?)?;
        }
        MaterialsCmd::Remove(a) => {
            let mut lib = open(&a.library)?;
            if !lib.remove(&a.name)? {
                bail!("no material {:?} in the library", a.name);
            }
        }
    }
    Ok(())
}
