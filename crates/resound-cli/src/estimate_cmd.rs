//! `resound estimate` and `resound materials`: material estimation and the material library.

use crate::util::{parse_vec3, warn_all};
use anyhow::Result;
use clap::{Args, Subcommand};
use resound::io::library::{read_material, write_material};
use resound::material::{
    check_name_free, estimate_files, library_material as get, list_library, read_library,
    remove_material, store_material, EstimateFiles, EstimateMaterialParams,
};
use resound::object::ObjectParams;
use resound::signal::AnalyzeParams;
use std::path::PathBuf;

/// Arguments of `estimate`.
#[derive(Args, Debug)]
pub struct EstimateArgs {
    /// Recording(s) of the object struck at the hit point. Several files (microphones, takes)
    /// are combined into one estimate: α, β, γ shared, each recording with its own σ.
    #[arg(required = true, num_args = 1..)]
    pub audio: Vec<PathBuf>,
    /// The object: a closed surface or tet mesh, or a saved modal model (.rmodal).
    #[arg(long)]
    pub mesh: PathBuf,
    /// Hit point x,y,z in metres (snapped to the nearest surface point).
    #[arg(long, allow_hyphen_values = true)]
    pub hit: String,
    /// Scale applied to the mesh coordinates (0.001 for millimetres).
    #[arg(allow_hyphen_values = true, long, default_value_t = 1.0)]
    pub scale: f64,
    /// Elastic modes to compute at most when a mesh is given: those below 20 kHz (and the
    /// recorded modes, within the Nyquist frequency) in the estimated material are solved.
    #[arg(long, default_value_t = 200)]
    pub modes: usize,
    /// Reference material for the modal solve (only E/ρ's ratio matters; ν is kept).
    #[arg(long, default_value = "ceramic")]
    pub reference_material: String,
    /// Zero-phase 4th-order Butterworth high-pass first (e.g. 100 against room rumble). Without
    /// it, one is chosen when rumble is measured before or after the strike (reported).
    #[arg(allow_hyphen_values = true, long, value_name = "HZ")]
    pub highpass_hz: Option<f64>,
    #[command(flatten)]
    pub take: crate::util::TakeArgs,
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
    /// Keep an estimate whose parameters are not credible (β at the optimizer's floor, γ
    /// outside the range of solids) with a warning instead of failing.
    #[arg(long)]
    pub allow_implausible: bool,
    /// Replace a library entry of the same name (`--name`).
    #[arg(long)]
    pub force: bool,
    /// Where the microphone was, x,y,z in metres (model coordinates): the forward model weights
    /// each mode by what it radiates there (the model's acoustic transfer: `resound modal
    /// --transfer`, or fitted now), so σ and the levels are those `synth --mic` renders.
    #[arg(long, allow_hyphen_values = true)]
    pub mic: Option<String>,
}

/// Runs `estimate`.
pub fn run(a: EstimateArgs) -> Result<()> {
    crate::util::check_paths(
        a.audio.iter().chain([&a.mesh]).chain(&a.library),
        a.output.iter().chain(&a.plot),
    )?;
    if let Some(name) = &a.name {
        check_name_free(a.library.as_deref(), name, a.force)?;
    }
    let job = EstimateFiles {
        recordings: a.audio.clone(),
        recording: a.take.recording()?,
        analyze: AnalyzeParams {
            highpass_hz: a.highpass_hz,
            strike: a.take.strike_index()?,
            ..AnalyzeParams::default()
        },
        select: a.take.selection(),
        object: a.mesh.clone(),
        object_params: ObjectParams::new(a.scale, a.modes, &a.reference_material)?,
        hit_m: parse_vec3(&a.hit)?,
        params: EstimateMaterialParams {
            name: a.name.clone().unwrap_or_default(),
            residual: !a.no_residual,
            allow_implausible: a.allow_implausible,
            mic_m: a.mic.as_deref().map(parse_vec3).transpose()?,
            ..Default::default()
        },
    };
    // A refused estimate still shows its report; nothing is written or stored.
    let out =
        crate::util::with_bar("estimate", |cb| estimate_files(&job, cb)).inspect_err(|e| {
            if let Some(info) = e.refused_report() {
                warn_all(&info.warnings);
                let _ = crate::util::show(a.json, info);
            }
        })?;
    crate::util::notes(&out.notes);
    let (material, info) = (&out.material, &out.info);
    warn_all(&info.warnings);
    if let Some(o) = &a.output {
        write_material(o, material)?;
    }
    if let Some(path) = &a.plot {
        let title = a.audio[0]
            .file_name()
            .map_or(String::new(), |s| s.to_string_lossy().into_owned());
        out.plot(path, &title, &job.params.estimate)?;
    }
    if a.name.is_some() {
        store_material(a.library.as_deref(), material, a.force)?;
    }
    crate::util::show(a.json, &info)
}

/// `resound materials …`.
#[derive(Args, Debug)]
pub struct MaterialsArgs {
    #[command(subcommand)]
    pub cmd: MaterialsCmd,
    /// Material library (default: $RESOUND_LIBRARY or ~/.local/share/resound/materials.sqlite).
    #[arg(long, global = true)]
    pub library: Option<PathBuf>,
}

/// The `materials` subcommands.
#[derive(Subcommand, Debug)]
pub enum MaterialsCmd {
    /// List the library's materials.
    List,
    /// Print one material as JSON.
    Show {
        /// Material name.
        name: String,
    },
    /// Add (or replace) a material from a material file.
    Import {
        /// Material file (JSON).
        file: PathBuf,
        /// Replace a library entry of the same name.
        #[arg(long)]
        force: bool,
    },
    /// Write one material to a material file.
    Export {
        /// Material name.
        name: String,
        /// Output material file (JSON).
        file: PathBuf,
    },
    /// Remove a material.
    Remove {
        /// Material name.
        name: String,
    },
}

/// Runs `materials`.
pub fn run_materials(a: MaterialsArgs) -> Result<()> {
    let lib = a.library.as_deref();
    match a.cmd {
        MaterialsCmd::List => {
            let listing = list_library(lib)?;
            crate::util::notes(listing.note.as_slice());
            print!("{listing}");
        }
        MaterialsCmd::Show { name } => {
            let m = get(read_library(lib)?.as_ref(), &name)?;
            println!("{}", serde_json::to_string_pretty(&m)?);
        }
        MaterialsCmd::Import { file, force } => {
            let m = read_material(&file)?;
            store_material(lib, &m, force)?;
            eprintln!("imported {:?}", m.name);
        }
        MaterialsCmd::Export { name, file } => {
            crate::util::check_paths(lib, [&file])?;
            write_material(&file, &get(read_library(lib)?.as_ref(), &name)?)?;
        }
        MaterialsCmd::Remove { name } => remove_material(lib, &name)?,
    }
    Ok(())
}
