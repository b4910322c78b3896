//! Scraping (Traer 2019 §4) from files: a trajectory, a surface texture, an object's modes.

use crate::error::{invalid, Error, Result};
use resound_core::{DampedMode, Warning};
use resound_synth::render::{bank_modes, REFERENCE_IMPULSE_N_S};
use resound_synth::scrape::{positions, scrape, scrape_force, ScrapeParams, Surface};
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// Reads a trajectory CSV: `time_s,position_m` per line (a header line and `#` comments are
/// skipped), times increasing, at least two points.
///
/// # Errors
/// Unreadable files; malformed lines (with their number); times that do not increase.
pub fn read_trajectory(path: &Path) -> Result<Vec<(f64, f64)>> {
    let text = std::fs::read_to_string(path).map_err(|e| {
        Error::from(resound_io::IoError::Io {
            path: path.to_path_buf(),
            error: e,
        })
    })?;
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
                    return Err(invalid(format!(
                        "{} line {}: times must increase",
                        path.display(),
                        i + 1
                    )));
                }
                out.push((t, x));
            }
            _ if out.is_empty() && i == 0 => {} // a header line
            _ => {
                return Err(invalid(format!(
                    "{} line {}: expected `time_s,position_m`, got {line:?}",
                    path.display(),
                    i + 1
                )))
            }
        }
    }
    if out.len() < 2 {
        return Err(invalid(format!(
            "{}: a trajectory needs at least two points",
            path.display()
        )));
    }
    Ok(out)
}

/// The scraped surface.
#[derive(Clone, Debug, PartialEq)]
pub enum SurfaceSpec {
    /// A procedural 1/f² (Brownian) profile of this RMS height, m.
    Fractal {
        /// RMS height, m.
        roughness_m: f64,
    },
    /// A measured height profile (`.npy`, metres), quilted to length.
    Profile(PathBuf),
}

/// Where the probe is.
#[derive(Clone, Debug, PartialEq)]
pub enum Path1d {
    /// A trajectory: (time s, position m) points, interpolated.
    Trajectory(Vec<(f64, f64)>),
    /// Constant speed from position 0, m/s.
    Speed(f64),
}

/// A scrape to render.
#[derive(Clone, Debug)]
pub struct ScrapeJob {
    /// The scraped object's modes (per unit impulse, as [`resound_core::SoundMaterial::modes`]).
    pub modes: Vec<DampedMode>,
    /// The surface.
    pub surface: SurfaceSpec,
    /// Sample spacing of the surface profile, m.
    pub surface_spacing_m: f64,
    /// The probe's path.
    pub path: Path1d,
    /// Eq. 8's probe, friction, exponent and tip.
    pub params: ScrapeParams,
    /// Location-dependent IRs along the path (eq. 9), 1 to [`MAX_IRS`].
    pub irs: usize,
    /// Seed (surface, quilting, IR variation).
    pub seed: u64,
    /// Length, s.
    pub duration_s: f64,
    /// Sample rate, Hz.
    pub sample_rate_hz: u32,
}

/// Most location-dependent IRs a scrape takes: the cost is linear in them, and Traer's
/// variation between neighbours is smooth long before this.
pub const MAX_IRS: usize = 256;

/// What [`render_scrape`] did: the report `scrape --json` prints and Python returns.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ScrapeInfo {
    /// Modes below Nyquist that sounded.
    pub modes: usize,
    /// Length of the path scraped, m.
    pub path_m: f64,
    /// Peak before any level change, full scale = 1.
    pub peak: f32,
    /// Level change applied to avoid clipping, dB (0 or negative).
    pub gain_db: f32,
    /// Things the user should know (an inaudible render).
    pub warnings: Vec<Warning>,
    /// Notes for the user (the render turned down).
    #[serde(default)]
    pub notes: Vec<String>,
}

/// A rendered scrape.
#[derive(Clone, Debug)]
pub struct ScrapeRender {
    /// Mono samples at the job's rate, never clipping (turned down when they would).
    pub samples: Vec<f32>,
    /// The report.
    pub info: ScrapeInfo,
}

/// Renders `job`: the sound at its physical level (turned down only where it would clip; the
/// report says by how much) and the report.
///
/// # Errors
/// Parameters out of range (IRs beyond [`MAX_IRS`]), an unusable surface, no modes below
/// Nyquist.
pub fn render_scrape(job: &ScrapeJob) -> Result<ScrapeRender> {
    let fs = f64::from(job.sample_rate_hz);
    let p = &job.params;
    if !resound_core::limits::sample_rate_ok(fs) {
        return Err(invalid(resound_core::limits::sample_rate_message(fs)));
    }
    if !(job.duration_s > 0.0 && job.duration_s <= 600.0) {
        return Err(invalid(format!(
            "duration must be in (0, 600] s, got {}",
            job.duration_s
        )));
    }
    if !(p.tip_width_m.is_finite() && p.tip_width_m >= 0.0 && p.tip_width_m < 0.05) {
        return Err(invalid("tip width must be in [0, 0.05) m"));
    }
    if !(p.probe_mass_kg > 0.0
        && p.probe_mass_kg.is_finite()
        && p.friction >= 0.0
        && p.friction.is_finite()
        && p.gamma > 0.0
        && p.gamma <= 4.0)
    {
        return Err(invalid(
            "probe mass must be > 0, friction ≥ 0 and gamma in (0, 4]",
        ));
    }
    if !(1..=MAX_IRS).contains(&job.irs) {
        return Err(invalid(format!(
            "IRs along the path must be 1–{MAX_IRS} (each renders the whole path once), got {}",
            job.irs
        )));
    }
    let samples = (job.duration_s * fs).round() as usize;
    let x = match &job.path {
        Path1d::Trajectory(t) => positions(t, fs, samples),
        Path1d::Speed(v) if v.is_finite() && v.abs() < 100.0 => {
            (0..samples).map(|i| v * i as f64 / fs).collect()
        }
        Path1d::Speed(v) => return Err(invalid(format!("speed must be below 100 m/s, got {v}"))),
    };
    let surface = match &job.surface {
        SurfaceSpec::Fractal { roughness_m } => {
            Surface::fractal(1 << 20, job.surface_spacing_m, 2.0, *roughness_m, job.seed)?
        }
        SurfaceSpec::Profile(path) => {
            let heights = resound_io::npy::read_npy_f64(path)?;
            let patch = (heights.len() / 8).clamp(16, 8192);
            Surface::quilt(
                &heights,
                job.surface_spacing_m,
                heights.len().max(1 << 18),
                patch,
                job.seed,
            )
            .map_err(|e| Error::from(e).context(format!("quilting {}", path.display())))?
        }
    };
    let modes: Vec<DampedMode> = job
        .modes
        .iter()
        .copied()
        .filter(|m| m.freq_hz < 0.5 * fs)
        .collect();
    if modes.is_empty() {
        return Err(invalid("the scraped object has no modes below Nyquist"));
    }
    let mut bm = bank_modes(&modes);
    bm.iter_mut().for_each(|m| m.gain /= REFERENCE_IMPULSE_N_S);
    let force = scrape_force(&surface, &x, fs, p);
    let mut out = scrape(&bm, &force, &x, fs, job.irs, job.seed)?;
    let path_m = x.windows(2).map(|w| (w[1] - w[0]).abs()).sum::<f64>();
    let level = resound_synth::render::normalize(&mut out, resound_synth::render::CEILING)?;
    Ok(ScrapeRender {
        samples: out,
        info: ScrapeInfo {
            modes: modes.len(),
            path_m,
            peak: level.peak_before,
            gain_db: level.gain_db,
            warnings: level.quiet_warning().into_iter().collect(),
            notes: level.note().into_iter().collect(),
        },
    })
}
