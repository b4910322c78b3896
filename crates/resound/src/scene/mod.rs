//! From a scene file to sounding bodies: shapes → surface meshes → modal models (computed once
//! per shape, material and resolution, cached by content hash) → modes and per-vertex gains of
//! each body's material → [`resound_physics::BodySpec`].
//!
//! Materials in a scene are a material file (`*.json`), a library name, a built-in
//! ([`resound_core::SoundMaterial::builtin`]), or `preset:NAME`: an elastic preset (steel,
//! aluminium, glass, ceramic, wood, plastic: γ = E/ρ from standard tables) with the Rayleigh
//! damping of the matching Ren 2013 Table I material (steel and aluminium → metal, ceramic →
//! porcelain) and σ = [`resound_core::DEFAULT_SIGMA`]. A plain name that is neither in the
//! library nor a built-in but is a preset is taken as `preset:NAME`.
//!
//! The modal model of a body is solved with the body's own density and E = γρ, so λ needs no
//! rescaling and the mass-normalised shapes carry the body's real mass.
//!
//! [`build`](build_scene) turns the file into bodies, its cache of models and acoustic
//! transfers lives in `cache`, and this module renders (offline or through the live path).

use crate::error::{invalid, Error, Result};
use crate::material::resolve_material;
use crate::model_cache::{KeyBuilder, ModelCache};
use resound_core::progress::{Progress, ProgressFn, Stage, Warning, WarningKind};
use resound_core::{Material, ModalModel, SoundMaterial};
use resound_fem::SurfaceMesh;
use resound_io::library::Library;
use resound_io::scene::{BodyFile, SceneFile, ShapeFile};
use resound_modal::{ModalBuilder, ModalParams};
use resound_physics::{BodySound, BodySpec, SceneParams, Shape};
use resound_synth::excitation::Elastic;
use std::path::{Path, PathBuf};

mod build;
mod cache;
pub use build::{body_sound, build_scene, BuildOptions, MAX_BODIES};

/// How to render a scene file.
#[derive(Clone, Debug, Default)]
pub struct SceneRenderParams {
    /// The material library (`None`: the default one).
    pub library: Option<PathBuf>,
    /// Directory of cached modal models (`None`: no cache).
    pub cache_dir: Option<PathBuf>,
    /// Keep the σ-calibrated level instead of normalizing the peak to −1 dBFS (a mix that would
    /// clip is still turned down).
    pub keep_level: bool,
    /// Run through the live path with a simulated device (`None`: offline).
    pub live: Option<resound_physics::live::LiveParams>,
}

/// Figures of a rendered scene.
#[derive(Clone, Debug, Default, serde::Serialize, serde::Deserialize)]
pub struct SceneSummary {
    /// Bodies.
    pub bodies: usize,
    /// Length, s.
    pub duration_s: f64,
    /// Building the bodies (modal models included), s.
    pub build_s: f64,
    /// Simulating and rendering, s.
    pub simulate_s: f64,
    /// Of which physics and contacts, s.
    pub physics_s: f64,
    /// Of which sound, s.
    pub audio_s: f64,
    /// Seconds of audio per second of simulation.
    pub realtime_factor: f64,
    /// Impacts.
    pub impacts: usize,
    /// Body-steps of sliding.
    pub sliding_steps: usize,
    /// Body-steps of rolling.
    pub rolling_steps: usize,
    /// Most sources sounding at once.
    pub max_voices: usize,
    /// Peak before the level change, full scale = 1.
    pub peak: f32,
    /// Level change applied, dB.
    pub gain_db: f32,
    /// Event-log lines.
    pub events: usize,
    /// This process's peak resident memory, MB (0 where unknown).
    pub peak_rss_mb: f64,
    /// Things the user should know (uncertain radiation, silence).
    pub warnings: Vec<Warning>,
    /// What was done to the level (turned down to avoid clipping).
    pub notes: Vec<String>,
    /// Live-path figures (a run with a simulated device).
    #[serde(skip_serializing_if = "Option::is_none", default)]
    pub live: Option<resound_physics::live::LiveReport>,
}

impl std::fmt::Display for SceneSummary {
    /// One line: impacts and speed, or the live path's figures.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match &self.live {
            Some(l) => write!(
                f,
                "{} impacts; through the live path: {} blocks of {}, latency {} samples, \
                 callback p99 {:.0}% of its deadline, {} xruns",
                self.impacts,
                l.callbacks,
                l.block,
                l.latency_samples,
                100.0 * l.p99_share,
                l.xruns
            ),
            None => write!(
                f,
                "{} impacts, {:.1}x real time",
                self.impacts, self.realtime_factor
            ),
        }
    }
}

/// A rendered scene.
#[derive(Clone, Debug)]
pub struct SceneRender {
    /// One or two channels at `sample_rate_hz`, levelled.
    pub channels: Vec<Vec<f32>>,
    /// Sample rate, Hz.
    pub sample_rate_hz: u32,
    /// The event log.
    pub events: Vec<resound_physics::Event>,
    /// Figures.
    pub summary: SceneSummary,
}

/// This process's peak resident memory (VmHWM), MB; 0 where /proc is unavailable.
pub fn peak_rss_mb() -> f64 {
    std::fs::read_to_string("/proc/self/status")
        .ok()
        .and_then(|s| {
            s.lines()
                .find(|l| l.starts_with("VmHWM:"))
                .and_then(|l| l.split_whitespace().nth(1))
                .and_then(|kb| kb.parse::<f64>().ok())
        })
        .map_or(0.0, |kb| kb / 1024.0)
}

/// Reads and builds the scene file `path` (bodies with their sound, and settings), without
/// running it; `progress` hears the build's stages and warnings.
///
/// # Errors
/// Unreadable or invalid scene files (with line and field), bodies that cannot be built.
pub fn load_scene(
    path: &Path,
    params: &SceneRenderParams,
    progress: ProgressFn<'_>,
) -> Result<(Vec<BodySpec>, SceneParams)> {
    let scene = resound_io::scene::read_scene(path)?;
    let base_dir = path
        .parent()
        .map_or_else(|| PathBuf::from("."), PathBuf::from);
    build_parsed(
        &scene,
        &base_dir,
        &path.display().to_string(),
        params,
        progress,
    )
}

fn build_parsed(
    scene: &resound_io::scene::SceneFile,
    base_dir: &Path,
    label: &str,
    params: &SceneRenderParams,
    progress: ProgressFn<'_>,
) -> Result<(Vec<BodySpec>, SceneParams)> {
    let library = crate::material::read_library(params.library.as_deref())?;
    build_scene(
        scene,
        &BuildOptions {
            base_dir,
            library: library.as_ref(),
            cache_dir: params.cache_dir.clone(),
            progress,
        },
    )
    .map_err(|e| e.context(format!("building {label}")))
}

/// Reads, builds and renders the scene file `path`: `progress` hears [`Stage::Building`],
/// [`Stage::Transfer`], [`Stage::Simulating`] and every warning (which the summary keeps). With `params.live`, the scene runs through the live path (physics
/// on its own thread, device blocks from a simulated device) and the result is what a device
/// would have played, `latency` samples late.
///
/// # Errors
/// Unreadable or invalid scene files (with line and field), bodies that cannot be built, a
/// failed simulation, a non-finite mix.
pub fn render_scene(
    path: &Path,
    params: &SceneRenderParams,
    progress: ProgressFn<'_>,
) -> Result<SceneRender> {
    let t0 = std::time::Instant::now();
    let warnings = std::sync::Mutex::new(Vec::new());
    let (bodies, sp) = load_scene(path, params, &collecting(progress, &warnings))?;
    run_built(
        bodies,
        sp,
        t0,
        &path.display().to_string(),
        params,
        progress,
        warnings.into_inner().unwrap_or_default(),
    )
}

/// `progress`, keeping a copy of every warning for the summary (which every front end shows,
/// while a progress report may not be).
fn collecting<'a>(
    progress: ProgressFn<'a>,
    warnings: &'a std::sync::Mutex<Vec<Warning>>,
) -> impl Fn(Progress) + Sync + 'a {
    move |p: Progress| {
        if let (Progress::Warning(w), Ok(mut all)) = (&p, warnings.lock()) {
            all.push(w.clone());
        }
        progress(p);
    }
}

/// [`render_scene`] of scene text (TOML, the scene file format) that is in no file: `label`
/// names it in messages, and its relative paths (meshes, statistics, grains, textures) are
/// taken from `base_dir`. Scenes built in code (the Python package) come this way.
///
/// # Errors
/// As [`render_scene`].
pub fn render_scene_text(
    text: &str,
    label: &str,
    base_dir: &Path,
    params: &SceneRenderParams,
    progress: ProgressFn<'_>,
) -> Result<SceneRender> {
    let t0 = std::time::Instant::now();
    let scene = resound_io::scene::parse_scene(text, label)?;
    render_parsed(&scene, t0, label, base_dir, params, progress)
}

/// [`render_scene`] of a scene deserialized into the scene file's types from any format (a
/// Python dict, JSON, an HTTP body), checked with the scene file's rules and messages (which
/// name fields; there are no lines). `label` and `base_dir` as in [`render_scene_text`].
///
/// # Errors
/// As [`render_scene`].
pub fn render_scene_value(
    scene: resound_io::scene::SceneFile,
    label: &str,
    base_dir: &Path,
    params: &SceneRenderParams,
    progress: ProgressFn<'_>,
) -> Result<SceneRender> {
    let t0 = std::time::Instant::now();
    let scene = resound_io::scene::validate_scene(scene, label, None)?;
    render_parsed(&scene, t0, label, base_dir, params, progress)
}

fn render_parsed(
    scene: &resound_io::scene::SceneFile,
    t0: std::time::Instant,
    label: &str,
    base_dir: &Path,
    params: &SceneRenderParams,
    progress: ProgressFn<'_>,
) -> Result<SceneRender> {
    let warnings = std::sync::Mutex::new(Vec::new());
    let (bodies, sp) = build_parsed(
        scene,
        base_dir,
        label,
        params,
        &collecting(progress, &warnings),
    )?;
    run_built(
        bodies,
        sp,
        t0,
        label,
        params,
        progress,
        warnings.into_inner().unwrap_or_default(),
    )
}

fn run_built(
    bodies: Vec<BodySpec>,
    sp: SceneParams,
    t0: std::time::Instant,
    label: &str,
    params: &SceneRenderParams,
    progress: ProgressFn<'_>,
    build_warnings: Vec<Warning>,
) -> Result<SceneRender> {
    let build_s = t0.elapsed().as_secs_f64();
    let t1 = std::time::Instant::now();
    let context =
        |e: resound_physics::SceneError| Error::from(e).context(format!("simulating {label}"));
    let (mut out, live) = match &params.live {
        None => (
            resound_physics::simulate(&bodies, &sp, progress).map_err(context)?,
            None,
        ),
        Some(lp) => {
            let o = resound_physics::live::render_live(&bodies, &sp, lp).map_err(context)?;
            (
                resound_physics::SceneOutput {
                    channels: o.channels,
                    events: o.events,
                    stats: o.stats,
                },
                Some(o.report),
            )
        }
    };
    let simulate_s = t1.elapsed().as_secs_f64();
    let mode = if params.keep_level {
        resound_synth::render::Level::Guard
    } else {
        resound_synth::render::Level::Normalize
    };
    let level =
        resound_synth::render::set_level(&mut out.channels, resound_synth::render::CEILING, mode)?;
    let mut warnings = build_warnings;
    let mut notes = Vec::new();
    if level.peak_before == 0.0 {
        let w = Warning::new(
            WarningKind::Quiet,
            "the scene is silent (no sounding contacts)",
        );
        progress(Progress::Warning(w.clone()));
        warnings.push(w);
    } else if let Some(w) = level.quiet_warning() {
        progress(Progress::Warning(w.clone()));
        warnings.push(w);
    } else if params.keep_level && level.gain_db < 0.0 {
        notes.push(format!(
            "peak {:.2} of full scale; turned down by {:.1} dB (no clipping)",
            level.peak_before, -level.gain_db
        ));
    }
    if let Some(l) = live
        .as_ref()
        .filter(|l| l.late_steps > 0 || l.dropped_cues > 0)
    {
        let w = Warning::new(
            WarningKind::Realtime,
            format!(
                "the live path fell behind: {} late steps, {} dropped cues",
                l.late_steps, l.dropped_cues
            ),
        );
        progress(Progress::Warning(w.clone()));
        warnings.push(w);
    }
    let s = &out.stats;
    let summary = SceneSummary {
        bodies: bodies.len(),
        duration_s: sp.duration_s,
        build_s,
        simulate_s,
        physics_s: s.physics_s,
        audio_s: s.audio_s,
        realtime_factor: sp.duration_s / simulate_s.max(1e-9),
        impacts: s.impacts,
        sliding_steps: s.sliding_steps,
        rolling_steps: s.rolling_steps,
        max_voices: s.max_voices,
        peak: level.peak_before,
        gain_db: level.gain_db,
        events: out.events.len(),
        peak_rss_mb: peak_rss_mb(),
        warnings,
        notes,
        live,
    };
    Ok(SceneRender {
        channels: out.channels,
        sample_rate_hz: sp.sample_rate_hz as u32,
        events: out.events,
        summary,
    })
}
