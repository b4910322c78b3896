//! `resound scrape`: a probe scraped over a surface texture (Traer et al. 2019 §4).

use crate::estimate_cmd::{load_model, snap};
use crate::synth_cmd::{load_sound_material, FormatArg};
use crate::util::parse_vec3;
use anyhow::{bail, Context, Result};
use clap::Args;
use resound::core::DampedMode;
use resound::io::{write_wav, WavFormat};
use resound::synth::render::{bank_modes, normalize, REFERENCE_IMPULSE_N_S};
use resound::synth::scrape::{positions, scrape, scrape_force, ScrapeParams, Surface};
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Arguments of `scrape`.
#[derive(Args, Debug)]
pub struct ScrapeArgs {
    /// The scraped object as mode statistics (`resound stats`).
    #[arg(long, conflicts_with_all = ["material", "modes"])]
    pub stats: Option<PathBuf>,
    /// The scraped object as analysed modes (`resound analyze --json`).
    #[arg(long, conflicts_with_all = ["material"])]
    pub modes: Option<PathBuf>,
    /// The scraped object's material (library name or file); needs --mesh and --hit.
    #[arg(long, requires_all = ["mesh", "hit"])]
    pub material: Option<String>,
    /// Mesh or .rmodal of the object (with --material).
    #[arg(long)]
    pub mesh: Option<PathBuf>,
    /// Where on the object the scrape happens (with --material), m.
    #[arg(long, allow_hyphen_values = true)]
    pub hit: Option<String>,
    /// Surface: "fractal" (a 1/f² Brownian profile) or a height profile (.npy, metres; quilted).
    #[arg(long, default_value = "fractal")]
    pub surface: String,
    /// Sample spacing of the surface profile, m (the PyImpact profiles' spacing is not
    /// documented; 10 µm is our assumption).
    #[arg(long, default_value_t = 1e-5)]
    pub surface_spacing_m: f64,
    /// RMS height of the fractal surface, m.
    #[arg(long, default_value_t = 5e-6)]
    pub roughness_m: f64,
    /// Trajectory CSV: `time_s,position_m` per line (position along the surface).
    #[arg(long, conflicts_with = "speed")]
    pub trajectory: Option<PathBuf>,
    /// Constant scraping speed instead of a trajectory, m/s.
    #[arg(long)]
    pub speed: Option<f64>,
    /// Length of the output, s.
    #[arg(long, default_value_t = 2.0)]
    pub duration: f64,
    /// Probe mass, kg.
    #[arg(long, default_value_t = 0.01)]
    pub probe_mass: f64,
    /// Shear-friction coefficient A of eq. 8.
    #[arg(long, default_value_t = 100.0)]
    pub friction: f64,
    /// Exponent γ of eq. 8.
    #[arg(long, default_value_t = 1.0)]
    pub gamma: f64,
    /// Width of the probe's tip, m (it smooths the texture: a spatial low-pass).
    #[arg(long, default_value_t = 2e-4)]
    pub tip_width: f64,
    /// Location-dependent IRs along the path (eq. 9).
    #[arg(long, default_value_t = 8)]
    pub irs: usize,
    /// Seed (IR sample, surface, quilting, IR variation).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output sample rate, Hz.
    #[arg(long, default_value_t = 48_000)]
    pub sample_rate: u32,
    /// Material library path.
    #[arg(long)]
    pub library: Option<PathBuf>,
    /// Output WAV.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output sample format.
    #[arg(long, value_enum, default_value = "pcm24")]
    pub format: FormatArg,
    /// JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

fn read_trajectory(path: &Path) -> Result<Vec<(f64, f64)>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    let mut out: Vec<(f64, f64)> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let parts: Vec<&str> = line.split(',').map(str::trim).collect();
        let parsed = (parts.len() == 2)
            .then(|| Some((parts[0].parse::<f64>().ok()?, parts[1].parse::<f64>().ok()?)))
            .flatten();
        match parsed {
            Some((t, x)) if t.is_finite() && x.is_finite() => {
                if out.last().is_some_and(|&(t0, _)| t <= t0) {
                    bail!("{} line {}: times must increase", path.display(), i + 1);
                }
                out.push((t, x));
            }
            _ if out.is_empty() && i == 0 => {} // a header line
            _ => bail!(
                "{} line {}: expected `time_s,position_m`, got {line:?}",
                path.display(),
                i + 1
            ),
        }
    }
    if out.len() < 2 {
        bail!("{}: a trajectory needs at least two points", path.display());
    }
    Ok(out)
}

fn object_modes(a: &ScrapeArgs, fs: f64) -> Result<Vec<DampedMode>> {
    if let Some(p) = &a.stats {
        let s = resound::files::load_stats(p)?;
        return Ok(s.sample(a.seed)?);
    }
    if let Some(p) = &a.modes {
        return Ok(resound::files::load_modes(p)?);
    }
    let (Some(spec), Some(mesh), Some(hit)) = (&a.material, &a.mesh, &a.hit) else {
        bail!("give the scraped object: --stats, --modes, or --material with --mesh and --hit");
    };
    let material = load_sound_material(spec, &a.library)?;
    let model = load_model(mesh, 1.0, 200, "ceramic")?;
    let hit = snap(&model, parse_vec3(hit)?)?;
    let gamma0 = model.material.youngs_modulus / model.material.density;
    Ok(material.modes(&model.eigenvalues, &hit.gains, gamma0, 0.5 * fs))
}

/// Runs `scrape`.
pub fn run(a: ScrapeArgs) -> Result<()> {
    let fs = f64::from(a.sample_rate);
    if !((8000.0..=192_000.0).contains(&fs) && a.duration > 0.0 && a.duration <= 600.0) {
        bail!("--sample-rate must be within 8000–192000 Hz and --duration in (0, 600] s");
    }
    let p = ScrapeParams {
        probe_mass_kg: a.probe_mass,
        friction: a.friction,
        gamma: a.gamma,
        tip_width_m: a.tip_width,
    };
    if !(a.tip_width.is_finite() && a.tip_width >= 0.0 && a.tip_width < 0.05) {
        bail!("--tip-width must be in [0, 0.05) m");
    }
    if !(p.probe_mass_kg > 0.0
        && p.probe_mass_kg.is_finite()
        && p.friction >= 0.0
        && p.friction.is_finite()
        && p.gamma > 0.0
        && p.gamma <= 4.0)
    {
        bail!("--probe-mass must be > 0, --friction ≥ 0 and --gamma in (0, 4]");
    }
    let samples = (a.duration * fs).round() as usize;
    let x = match (&a.trajectory, a.speed) {
        (Some(t), _) => positions(&read_trajectory(t)?, fs, samples),
        (None, Some(v)) if v.is_finite() && v.abs() < 100.0 => {
            (0..samples).map(|i| v * i as f64 / fs).collect()
        }
        (None, Some(v)) => bail!("--speed must be below 100 m/s, got {v}"),
        (None, None) => bail!("give --trajectory FILE or --speed M/S"),
    };
    let surface = if a.surface == "fractal" {
        Surface::fractal(1 << 20, a.surface_spacing_m, 2.0, a.roughness_m, a.seed)?
    } else {
        let heights = resound::io::npy::read_npy_f64(Path::new(&a.surface))?;
        let patch = (heights.len() / 8).clamp(16, 8192);
        Surface::quilt(
            &heights,
            a.surface_spacing_m,
            heights.len().max(1 << 18),
            patch,
            a.seed,
        )
        .with_context(|| format!("quilting {}", a.surface))?
    };
    let modes: Vec<DampedMode> = object_modes(&a, fs)?
        .into_iter()
        .filter(|m| m.freq_hz < 0.5 * fs)
        .collect();
    if modes.is_empty() {
        bail!("the scraped object has no modes below Nyquist");
    }
    let mut bm = bank_modes(&modes);
    bm.iter_mut().for_each(|m| m.gain /= REFERENCE_IMPULSE_N_S);
    let force = scrape_force(&surface, &x, fs, &p);
    let mut out = scrape(&bm, &force, &x, fs, a.irs, a.seed)?;
    let level = normalize(&mut out, resound::synth::render::CEILING)?;
    if level.gain_db < 0.0 {
        eprintln!(
            "note: peak {:.2} of full scale; turned down by {:.1} dB (no clipping)",
            level.peak_before, -level.gain_db
        );
    }
    let format = WavFormat::from(a.format);
    write_wav(&a.output, &out, a.sample_rate, format)?;
    let path_m = x
        .iter()
        .zip(x.iter().skip(1))
        .map(|(a, b)| (b - a).abs())
        .sum::<f64>();
    if a.json {
        #[derive(Serialize)]
        struct Output {
            output: String,
            modes: usize,
            path_m: f64,
            peak: f32,
            gain_db: f32,
        }
        crate::util::print_json(&Output {
            output: a.output.display().to_string(),
            modes: modes.len(),
            path_m,
            peak: level.peak_before,
            gain_db: level.gain_db,
        })?;
    } else {
        eprintln!("wrote {} ({:.2} m scraped)", a.output.display(), path_m);
    }
    Ok(())
}
