//! `resound synth`: render one strike of an object made of a material, or of analysed modes.

use crate::estimate_cmd::{get, load_model, open};
use crate::modal_cmd::hit_gains;
use crate::util::parse_vec3;
use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};
use resound::core::{DampedMode, Material, SoundMaterial};
use resound::io::library::read_material;
use resound::io::{write_wav, WavFormat};
use resound::synth::excitation::{ContactModel, Elastic, Impact};
use resound::synth::render::{bank_modes, normalize, render_strike};
use resound::synth::residual::{GriffinLim, Pairing, ResidualSource};
use serde_json::json;
use std::path::PathBuf;

/// Contact force law.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum ContactArg {
    /// Hertz contact: duration shrinks with speed.
    Hertz,
    /// Linear spring (Traer eq. 5): half sine, fixed duration.
    Spring,
    /// Ideal impulse.
    Impulse,
}

/// Output sample format.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum FormatArg {
    /// 16-bit PCM.
    Pcm16,
    /// 24-bit PCM.
    Pcm24,
    /// 32-bit float.
    Float,
}

impl From<ContactArg> for ContactModel {
    fn from(c: ContactArg) -> Self {
        match c {
            ContactArg::Hertz => ContactModel::Hertz,
            ContactArg::Spring => ContactModel::Spring,
            ContactArg::Impulse => ContactModel::Impulse,
        }
    }
}

impl From<FormatArg> for WavFormat {
    fn from(f: FormatArg) -> Self {
        match f {
            FormatArg::Pcm16 => WavFormat::Pcm16,
            FormatArg::Pcm24 => WavFormat::Pcm24,
            FormatArg::Float => WavFormat::Float32,
        }
    }
}

/// Arguments of `synth`.
#[derive(Args, Debug)]
pub struct SynthArgs {
    /// Material: a library name or a material file (JSON).
    #[arg(long, required_unless_present_any = ["modes", "stats"])]
    pub material: Option<String>,
    /// The struck object: a surface or tet mesh, or a saved modal model (.rmodal).
    #[arg(long, required_unless_present_any = ["modes", "stats"])]
    pub mesh: Option<PathBuf>,
    /// Hit point x,y,z in metres (snapped to the nearest surface point).
    #[arg(long, allow_hyphen_values = true, required_unless_present_any = ["modes", "stats"])]
    pub hit: Option<String>,
    /// Render analysed modes directly (the JSON of `resound analyze --json`) instead.
    #[arg(long, conflicts_with_all = ["material", "mesh", "hit"])]
    pub modes: Option<PathBuf>,
    /// Render an impulse response sampled from mode statistics (`resound stats`) instead.
    #[arg(long, conflicts_with_all = ["material", "mesh", "hit", "modes"])]
    pub stats: Option<PathBuf>,
    /// Seed of the sampled impulse response (`--stats`); the per-impact variation uses seed + 1.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Impact speed, m/s.
    #[arg(long, default_value_t = 1.0, allow_hyphen_values = true)]
    pub velocity: f64,
    /// Impactor mass, kg (default: a sphere of --impactor-radius of the impactor material).
    #[arg(long)]
    pub impactor_mass: Option<f64>,
    /// Impactor radius at the contact, m.
    #[arg(long, default_value_t = 0.005)]
    pub impactor_radius: f64,
    /// Impactor material (preset name or E,nu,rho).
    #[arg(long, default_value = "steel")]
    pub impactor_material: String,
    /// Contact force law.
    #[arg(long, value_enum, default_value = "hertz")]
    pub contact: ContactArg,
    /// Leave out the material's residual (Ren §6).
    #[arg(long)]
    pub no_residual: bool,
    /// Length of the output, s.
    #[arg(long, default_value_t = 2.0)]
    pub duration: f64,
    /// Output sample rate, Hz.
    #[arg(long, default_value_t = 48_000)]
    pub sample_rate: u32,
    /// Scale applied to mesh coordinates (0.001 for millimetres).
    #[arg(long, default_value_t = 1.0)]
    pub scale: f64,
    /// Elastic modes to compute when a mesh is given.
    #[arg(long, default_value_t = 200)]
    pub mesh_modes: usize,
    /// Reference material for the modal solve (its density also sets the object's E = γρ for
    /// Hertz contact).
    #[arg(long, default_value = "ceramic")]
    pub reference_material: String,
    /// Material library path.
    #[arg(long)]
    pub library: Option<PathBuf>,
    /// Output WAV file.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output sample format.
    #[arg(long, value_enum, default_value = "pcm24")]
    pub format: FormatArg,
    /// Print a JSON summary.
    #[arg(long)]
    pub json: bool,
    /// Also play it on the default audio device (the engine runs in the audio callback; needs
    /// the `live` build feature).
    #[arg(long)]
    pub play: bool,
}

/// The reference impact σ is calibrated to: the default impactor (a 5 mm steel ball) at 1 m/s
/// on an immovable object. A material's σ makes its object sound at the recording's level for
/// that impact; other impacts scale with their impulse.
fn reference_impulse_n_s() -> f64 {
    resound::synth::render::REFERENCE_IMPULSE_N_S
}

fn impactor_mass(a: &SynthArgs, impactor: &Material) -> f64 {
    a.impactor_mass.unwrap_or_else(|| {
        4.0 / 3.0 * std::f64::consts::PI * a.impactor_radius.powi(3) * impactor.density
    })
}

pub fn load_sound_material(spec: &str, library: &Option<PathBuf>) -> Result<SoundMaterial> {
    let path = std::path::Path::new(spec);
    if path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("json"))
        || path.is_file()
    {
        return Ok(read_material(path)?);
    }
    let lib = open(library)?;
    get(&lib, spec)
}

/// Runs `synth`.
pub fn run(a: SynthArgs) -> Result<()> {
    let fs = f64::from(a.sample_rate);
    if !(8000.0..=192_000.0).contains(&fs) {
        bail!(
            "--sample-rate must be within 8000–192000 Hz, got {}",
            a.sample_rate
        );
    }
    if !(a.duration > 0.0 && a.duration <= 600.0) {
        bail!("--duration must be in (0, 600] s, got {}", a.duration);
    }
    if !(a.velocity.is_finite() && a.velocity >= 0.0 && a.velocity < 1000.0) {
        bail!("--velocity must be in [0, 1000) m/s, got {}", a.velocity);
    }
    let samples = (a.duration * fs).round() as usize;
    let t0 = std::time::Instant::now();
    let (mut out, summary, live) = match (&a.modes, &a.stats) {
        (Some(p), _) => render_modes(&a, p, fs, samples)?,
        (None, Some(p)) => render_stats(&a, p, fs, samples)?,
        (None, None) => render_material(&a, fs, samples)?,
    };
    let level = normalize(&mut out, 0.891)?;
    if level.gain_db < 0.0 {
        eprintln!(
            "note: peak {:.2} of full scale; turned down by {:.1} dB to −1 dBFS (no clipping)",
            level.peak_before, -level.gain_db
        );
    }
    let format = WavFormat::from(a.format);
    write_wav(&a.output, &out, a.sample_rate, format)?;
    if a.play {
        let mut live = live;
        live.gain = 10f32.powf(level.gain_db / 20.0);
        crate::live::play(live, a.sample_rate, a.duration)?;
    }
    let mut summary = summary;
    summary["output"] = json!(a.output.display().to_string());
    summary["peak"] = json!(level.peak_before);
    summary["gain_db"] = json!(level.gain_db);
    summary["elapsed_s"] = json!(t0.elapsed().as_secs_f64());
    if a.json {
        println!("{}", serde_json::to_string_pretty(&summary)?);
    } else {
        eprintln!(
            "wrote {} ({:.2} s, {} Hz)",
            a.output.display(),
            a.duration,
            a.sample_rate
        );
    }
    Ok(())
}

type Rendered = (Vec<f32>, serde_json::Value, crate::live::LiveParts);

fn render_modes(
    a: &SynthArgs,
    path: &std::path::Path,
    fs: f64,
    samples: usize,
) -> Result<Rendered> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let v: serde_json::Value =
        serde_json::from_str(&text).with_context(|| format!("{}: not JSON", path.display()))?;
    let modes: Vec<DampedMode> = serde_json::from_value(v["modes"].clone()).with_context(|| {
        format!(
            "{}: no \"modes\" list of {{freq_hz, damping_per_s, amplitude, phase_rad}}",
            path.display()
        )
    })?;
    if modes.is_empty() {
        bail!("{}: the modes list is empty", path.display());
    }
    if let Some(m) = modes.iter().find(|m| {
        !(m.freq_hz.is_finite()
            && m.damping_per_s.is_finite()
            && m.amplitude.is_finite()
            && m.phase_rad.is_finite())
            || m.damping_per_s < 0.0
    }) {
        bail!("{}: unusable mode {m:?}", path.display());
    }
    let kept: Vec<DampedMode> = modes
        .iter()
        .copied()
        .filter(|m| m.freq_hz < 0.5 * fs)
        .collect();
    // Exactly as analysed (phases included), in f64, at the level of the recording for the
    // reference impact and scaled by this impact's impulse.
    let impactor = Material::parse(&a.impactor_material)?;
    let mass = impactor_mass(a, &impactor);
    let scale = 2.0 * mass * a.velocity / reference_impulse_n_s();
    let x: Vec<f32> = resound::core::damped::synthesize(&kept, fs, samples)
        .iter()
        .map(|&v| (v * scale) as f32)
        .collect();
    let live = crate::live::LiveParts {
        modes: Vec::new(),
        force: Vec::new(),
        extra: x.clone(),
        gain: 1.0,
    };
    Ok((
        x,
        json!({"modes": kept.len(), "source": path.display().to_string(), "impulse_n_s": 2.0 * mass * a.velocity}),
        live,
    ))
}

/// An IR sampled from statistics, struck by the impact. The struck object's elastic constants
/// are unknown here: Hertz contact takes the impactor's on both sides.
fn render_stats(
    a: &SynthArgs,
    path: &std::path::Path,
    fs: f64,
    samples: usize,
) -> Result<Rendered> {
    let stats = crate::stats_cmd::load(path)?;
    let ir = resound::stats::perturb(&stats.sample(a.seed)?, a.seed.wrapping_add(1));
    let modes: Vec<DampedMode> = ir.into_iter().filter(|m| m.freq_hz < 0.5 * fs).collect();
    if modes.is_empty() {
        bail!("the sampled impulse response has no modes below Nyquist");
    }
    let impactor = Material::parse(&a.impactor_material)?;
    let elastic = Elastic {
        youngs_modulus: impactor.youngs_modulus,
        poisson_ratio: impactor.poisson_ratio,
    };
    let impact = Impact {
        impactor_mass_kg: impactor_mass(a, &impactor),
        impactor_radius_m: a.impactor_radius,
        impactor: elastic,
        object: elastic,
        object_mass_kg: None,
        speed_m_s: a.velocity,
    };
    let model_kind = ContactModel::from(a.contact);
    let force = impact.force_pulse(model_kind, fs, 0.0)?;
    let mut bm = bank_modes(&modes);
    bm.iter_mut()
        .for_each(|m| m.gain /= reference_impulse_n_s());
    let mut out = render_strike(&bm, &force, fs, samples)?;
    // The transient noise bands, when the statistics have them, at the impact's level.
    let mut extra = Vec::new();
    if let Some(ts) = &stats.transient {
        let t = ts.sample(a.seed.wrapping_add(2));
        let scale = impact.impulse_n_s() / reference_impulse_n_s();
        extra = resound::stats::transient::synthesize_transient(&t, fs, samples, a.seed)
            .iter()
            .map(|v| (v * scale) as f32)
            .collect();
        for (o, v) in out.iter_mut().zip(&extra) {
            *o += v;
        }
    }
    let live = crate::live::LiveParts {
        modes: bm,
        force,
        extra,
        gain: 1.0,
    };
    Ok((
        out,
        json!({"stats": path.display().to_string(), "material": stats.material, "modes": modes.len(), "seed": a.seed, "impulse_n_s": impact.impulse_n_s()}),
        live,
    ))
}

fn render_material(a: &SynthArgs, fs: f64, samples: usize) -> Result<Rendered> {
    let (Some(spec), Some(mesh), Some(hit)) = (&a.material, &a.mesh, &a.hit) else {
        bail!("give --material, --mesh and --hit (or --modes)");
    };
    let material = load_sound_material(spec, &a.library)?;
    material.validate().map_err(anyhow::Error::msg)?;
    let hit = parse_vec3(hit)?;
    let model = load_model(mesh, a.scale, a.mesh_modes, &a.reference_material)?;
    let (gains0, point, _, distance) = hit_gains(&model, hit)?;
    if distance > 1e-6 {
        eprintln!(
            "note: hit point {:?} is {:.2} mm off the surface; using the nearest surface point {:?}",
            hit,
            distance * 1e3,
            point
        );
    }
    let gamma0 = model.material.youngs_modulus / model.material.density;
    let modes = material.modes(&model.eigenvalues, &gains0, gamma0, 0.5 * fs);
    if modes.is_empty() {
        bail!(
            "the object has no modes below Nyquist ({} Hz) with this material",
            0.5 * fs
        );
    }
    let impactor = Material::parse(&a.impactor_material)?;
    let mass = impactor_mass(a, &impactor);
    let impact = Impact {
        impactor_mass_kg: mass,
        impactor_radius_m: a.impactor_radius,
        impactor: Elastic {
            youngs_modulus: impactor.youngs_modulus,
            poisson_ratio: impactor.poisson_ratio,
        },
        object: Elastic {
            youngs_modulus: material.gamma * model.material.density,
            poisson_ratio: model.material.poisson_ratio,
        },
        object_mass_kg: None,
        speed_m_s: a.velocity,
    };
    let model_kind = ContactModel::from(a.contact);
    let force = impact.force_pulse(model_kind, fs, 0.0)?;
    let j_ref = reference_impulse_n_s();
    // Gains per N·s: σa⁰ is the recording's level for the reference impact.
    let mut bm = bank_modes(&modes);
    bm.iter_mut().for_each(|m| m.gain /= j_ref);
    let mut out = render_strike(&bm, &force, fs, samples)?;
    let mut extra = Vec::new();
    let mut residual_s = 0.0;
    let mut pairing_used = "none";
    if let (Some(r), false) = (&material.residual, a.no_residual) {
        let same_object = material.provenance.as_ref().is_some_and(|p| {
            p.mesh == mesh.display().to_string()
                && (0..3).all(|i| (p.hit[i] - point[i]).abs() < 1e-6)
        });
        let pairing = if same_object {
            pairing_used = "natural";
            Pairing::Natural
        } else {
            pairing_used = "dominant";
            Pairing::Dominant(8)
        };
        // The residual's modes are at the recording's rate; the target modes at ours.
        let mut src = ResidualSource::new(r);
        let t1 = std::time::Instant::now();
        let res = src.transfer(&modes, pairing, &GriffinLim::default());
        residual_s = t1.elapsed().as_secs_f64();
        let res: Vec<f64> = res.iter().map(|&v| f64::from(v)).collect();
        let res = if (r.sample_rate_hz - fs).abs() > 0.5 {
            resound::signal::resample::resample(&res, r.sample_rate_hz.round() as u32, fs as u32)
                .map_err(anyhow::Error::msg)?
        } else {
            res
        };
        let scale = impact.impulse_n_s() / j_ref;
        extra = res.iter().map(|v| (v * scale) as f32).collect();
        for (o, v) in out.iter_mut().zip(&extra) {
            *o += v;
        }
    }
    let live = crate::live::LiveParts {
        modes: bm,
        force,
        extra,
        gain: 1.0,
    };
    Ok((
        out,
        json!({
            "material": material.name,
            "modes": modes.len(),
            "hit": point,
            "impulse_n_s": impact.impulse_n_s(),
            "contact_s": impact.duration_s(model_kind),
            "residual": pairing_used,
            "residual_transfer_s": residual_s,
        }),
        live,
    ))
}
