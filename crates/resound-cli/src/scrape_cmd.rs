//! `resound scrape`: a probe scraped over a surface texture (Traer et al. 2019 §4).

use crate::util::named;
use anyhow::{bail, Result};
use clap::Args;
use resound::core::DampedMode;
use resound::io::{write_wav, WavFormat};
use resound::scrape::{read_trajectory, render_scrape, Path1d, ScrapeJob, SurfaceSpec};
use resound::synth::scrape::ScrapeParams;
use std::path::PathBuf;

/// Arguments of `scrape`.
#[derive(Args, Debug)]
pub struct ScrapeArgs {
    #[command(flatten)]
    pub object: crate::util::ObjectSourceArgs,
    /// Surface: "fractal" (a 1/f² Brownian profile) or a height profile (.npy, metres; quilted).
    #[arg(long, default_value = "fractal")]
    pub surface: String,
    /// Sample spacing of the surface profile, m (the PyImpact profiles' spacing is not
    /// documented; 10 µm is our assumption).
    #[arg(allow_hyphen_values = true, long, default_value_t = 1e-5)]
    pub surface_spacing_m: f64,
    /// RMS height of the fractal surface, m.
    #[arg(allow_hyphen_values = true, long, default_value_t = 5e-6)]
    pub roughness_m: f64,
    /// Trajectory CSV: `time_s,position_m` per line (position along the surface).
    #[arg(long, conflicts_with = "speed")]
    pub trajectory: Option<PathBuf>,
    /// Constant scraping speed instead of a trajectory, m/s.
    #[arg(allow_hyphen_values = true, long)]
    pub speed: Option<f64>,
    /// Length of the output, s.
    #[arg(allow_hyphen_values = true, long, default_value_t = 2.0)]
    pub duration: f64,
    /// Probe mass, kg.
    #[arg(allow_hyphen_values = true, long, default_value_t = 0.01)]
    pub probe_mass: f64,
    /// Shear-friction coefficient A of eq. 8.
    #[arg(allow_hyphen_values = true, long, default_value_t = 100.0)]
    pub friction: f64,
    /// Exponent γ of eq. 8.
    #[arg(allow_hyphen_values = true, long, default_value_t = 1.0)]
    pub gamma: f64,
    /// Width of the probe's tip, m (it smooths the texture: a spatial low-pass).
    #[arg(allow_hyphen_values = true, long, default_value_t = 2e-4)]
    pub tip_width: f64,
    /// Location-dependent IRs along the path (eq. 9), 1–256 (each one renders the whole path
    /// once).
    #[arg(long, default_value_t = 8)]
    pub irs: usize,
    /// Seed (IR sample, surface, quilting, IR variation).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Output sample rate, Hz.
    #[arg(long, default_value_t = 48_000)]
    pub sample_rate: u32,
    /// Output WAV.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Output sample format.
    #[arg(long, value_name = "pcm16|pcm24|float", default_value = "pcm24", value_parser = named::<WavFormat>)]
    pub format: WavFormat,
    /// JSON summary on stdout.
    #[arg(long)]
    pub json: bool,
}

fn object_modes(a: &ScrapeArgs, fs: f64) -> Result<Vec<DampedMode>> {
    let source = a.object.source(a.seed, Default::default())?;
    let (modes, notes) =
        crate::util::with_bar("modal", |cb| resound::strike::source_modes(&source, fs, cb))?;
    crate::util::notes(&notes);
    Ok(modes)
}

/// Runs `scrape`.
pub fn run(a: ScrapeArgs) -> Result<()> {
    let inputs = a.object.inputs().into_iter().chain(a.trajectory.as_deref());
    crate::util::check_paths(inputs, [&a.output])?;
    let fs = f64::from(a.sample_rate);
    let path = match (&a.trajectory, a.speed) {
        (Some(t), _) => Path1d::Trajectory(read_trajectory(t)?),
        (None, Some(v)) => Path1d::Speed(v),
        (None, None) => bail!("give --trajectory FILE or --speed M/S"),
    };
    let surface = if a.surface == "fractal" {
        SurfaceSpec::Fractal {
            roughness_m: a.roughness_m,
        }
    } else {
        SurfaceSpec::Profile(PathBuf::from(&a.surface))
    };
    let job = ScrapeJob {
        modes: object_modes(&a, fs)?,
        surface,
        surface_spacing_m: a.surface_spacing_m,
        path,
        params: ScrapeParams {
            probe_mass_kg: a.probe_mass,
            friction: a.friction,
            gamma: a.gamma,
            tip_width_m: a.tip_width,
        },
        irs: a.irs,
        seed: a.seed,
        duration_s: a.duration,
        sample_rate_hz: a.sample_rate,
    };
    let r = render_scrape(&job)?;
    crate::util::warn_all(&r.info.warnings);
    crate::util::notes(&r.info.notes);
    write_wav(&a.output, &r.samples, a.sample_rate, a.format)?;
    if a.json {
        crate::util::print_json(&r.info)?;
    } else {
        eprintln!(
            "wrote {} ({:.2} m scraped)",
            a.output.display(),
            r.info.path_m
        );
    }
    Ok(())
}
