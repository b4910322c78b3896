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

use crate::error::{invalid, Error, Result};
use crate::material::resolve_material;
use crate::model_cache::{KeyBuilder, ModelCache};
use resound_core::progress::{Progress, ProgressFn, Stage, Warning, WarningKind};
use resound_core::{Material, ModalModel, SoundMaterial};
use resound_fem::{primitive, SurfaceMesh};
use resound_io::library::Library;
use resound_io::scene::{BodyFile, SceneFile, ShapeFile};
use resound_modal::{ModalBuilder, ModalParams};
use resound_physics::{BodySound, BodySpec, SceneParams, Shape};
use resound_synth::excitation::Elastic;
use std::path::{Path, PathBuf};

/// Where to look things up while building.
pub struct BuildOptions<'a> {
    /// Directory of the scene file (mesh and material paths are relative to it).
    pub base_dir: &'a Path,
    /// The material library, if any.
    pub library: Option<&'a Library>,
    /// Directory for cached modal models (`None`: no cache).
    pub cache_dir: Option<PathBuf>,
    /// Progress: [`Stage::Building`] per body, [`Stage::Transfer`], and build warnings.
    pub progress: ProgressFn<'a>,
}

/// The surface mesh and collider shape of a body, in the body frame.
fn geometry(b: &BodyFile, base_dir: &Path) -> Result<(SurfaceMesh, Shape)> {
    Ok(match &b.shape {
        ShapeFile::Box(s) | ShapeFile::Plate(s) => (
            // The modal solve refines the surface to the voxel scale (fem), so contacts anywhere
            // on a face find the mode shapes there.
            primitive::bar(*s),
            Shape::Cuboid([0.5 * s[0], 0.5 * s[1], 0.5 * s[2]]),
        ),
        ShapeFile::Sphere(r) => (primitive::sphere(*r, 24), Shape::Ball(*r)),
        ShapeFile::Cylinder([r, h]) => (
            primitive::cylinder(*r, *h, 32),
            Shape::Cylinder {
                half_height: 0.5 * h,
                radius: *r,
            },
        ),
        ShapeFile::Bowl(v) => {
            let depth = v.get(2).copied().unwrap_or(v[0]);
            let m = primitive::bowl(v[0], v[1], depth, 48);
            let hull = Shape::ConvexHull(m.vertices.clone());
            (m, hull)
        }
        ShapeFile::Mesh(p) => {
            let path = base_dir.join(p);
            let mesh = match resound_io::load_mesh(&path, b.scale)? {
                resound_io::LoadedMesh::Surface(s) => s,
                resound_io::LoadedMesh::Tets(_) => {
                    return Err(invalid(
                        "tet meshes are not supported in scenes; give a surface",
                    ))
                }
            };
            let shape = if b.fixed {
                Shape::TriMesh {
                    vertices: mesh.vertices.clone(),
                    triangles: mesh.triangles.clone(),
                }
            } else {
                Shape::ConvexHull(mesh.vertices.clone())
            };
            (mesh, shape)
        }
    })
}

/// The modal model of a scene body: from the model cache (identical bodies are solved once
/// per build even without a cache directory), solved when it is in neither memory nor the
/// directory. Returns it with its cache file.
fn modal_model(
    mesh: &SurfaceMesh,
    material: &Material,
    b: &BodyFile,
    models: &mut ModelCache,
) -> Result<(std::sync::Arc<ModalModel>, Option<PathBuf>)> {
    let mut key = KeyBuilder::new();
    for v in &mesh.vertices {
        key.f64s(v);
    }
    for t in &mesh.triangles {
        for c in t {
            key.bytes(&c.to_le_bytes());
        }
    }
    key.f64s(&[
        material.youngs_modulus,
        material.poisson_ratio,
        material.density,
    ])
    .count(b.modes)
    .count(b.resolution);
    models.get_or_solve(key.finish(), || {
        let params = ModalParams {
            n_modes: Some(b.modes),
            max_freq_hz: None,
            resolution: b.resolution,
            target_voxels: if b.resolution == 0 { 1500 } else { 0 },
            sturm_check: false,
            ..Default::default()
        };
        Ok(ModalBuilder::surface(mesh, material)
            .params(params)
            .solve()?
            .model)
    })
}

/// Acoustic transfers fitted or loaded during one scene build, by modal model.
type Transfers = std::collections::HashMap<usize, std::sync::Arc<resound_core::AcousticTransfer>>;

/// The acoustic transfer of a scene body's `model`: the model's own, else fitted (default
/// settings) and stored with the model in the cache, so the next build loads it.
fn body_transfer(
    model: &std::sync::Arc<ModalModel>,
    cache_file: Option<&Path>,
    transfers: &mut Transfers,
    progress: ProgressFn<'_>,
) -> Result<std::sync::Arc<resound_core::AcousticTransfer>> {
    let key = std::sync::Arc::as_ptr(model) as usize;
    if let Some(t) = transfers.get(&key) {
        return Ok(std::sync::Arc::clone(t));
    }
    let t = match &model.transfer {
        Some(t) => std::sync::Arc::new(t.clone()),
        None => {
            progress(Progress::begin(Stage::Transfer));
            let mut m = (**model).clone();
            crate::radiation::add_transfer(
                &mut m,
                &resound_modal::radiation::TransferParams::default(),
            )?;
            if let Some(f) = cache_file {
                crate::model_cache::store(f, &m);
            }
            std::sync::Arc::new(
                m.transfer
                    .take()
                    .ok_or_else(|| invalid("the acoustic transfer fit stored nothing"))?,
            )
        }
    };
    transfers.insert(key, std::sync::Arc::clone(&t));
    Ok(t)
}

/// The sound model of a body of `material` with modal `model` (solved at the body's density).
///
/// With `transfer` (the model's acoustic transfer), the modes radiate by it in scenes.
pub fn body_sound(
    model: &ModalModel,
    material: &SoundMaterial,
    poisson: f64,
    sample_rate_hz: f64,
    transfer: Option<std::sync::Arc<resound_core::AcousticTransfer>>,
) -> BodySound {
    let m = model.n_modes();
    let vertex_gains = model.vertex_gains();
    // The forward model at unit gain: frequencies and decays, and which modes are kept.
    let gamma0 = model.gamma0();
    let kept = material.modes_indexed(
        &model.eigenvalues,
        &vec![1.0; m],
        gamma0,
        0.5 * sample_rate_hz,
    );
    let modes: Vec<(f64, f64)> = kept
        .iter()
        .map(|(_, d)| (d.freq_hz, d.damping_per_s))
        .collect();
    let keep: Vec<usize> = kept.iter().map(|&(j, _)| j).collect();
    let scale = material.sigma / resound_synth::render::REFERENCE_IMPULSE_N_S;
    let nv = model.n_vertices();
    let mut gains = Vec::with_capacity(nv * keep.len());
    for v in 0..nv {
        for &j in &keep {
            gains.push((vertex_gains[v * m + j] * scale) as f32);
        }
    }
    BodySound {
        modes,
        vertices: model.vertices.clone(),
        gains,
        elastic: Elastic {
            youngs_modulus: material.gamma * model.material.density,
            poisson_ratio: poisson,
        },
        contact_loss: resound_physics::DEFAULT_CONTACT_LOSS,
        radiation: transfer.map(|transfer| resound_physics::BodyRadiation {
            transfer,
            modes: keep,
        }),
    }
}

/// A body sounding from mode statistics: one sampled IR, its mode powers varied by ±20 % from
/// vertex to vertex (Traer eq. 9), the level relative to the reference impact.
fn stats_sound(
    path: &Path,
    mesh: &SurfaceMesh,
    b: &BodyFile,
    material: &SoundMaterial,
    seed: u64,
    sample_rate_hz: f64,
) -> Result<BodySound> {
    let stats = crate::files::load_stats(path)?;
    let ir: Vec<_> = stats
        .sample(seed)?
        .into_iter()
        .filter(|m| m.freq_hz < 0.5 * sample_rate_hz)
        .collect();
    let modes: Vec<(f64, f64)> = ir.iter().map(|m| (m.freq_hz, m.damping_per_s)).collect();
    let mut gains = Vec::with_capacity(mesh.vertices.len() * ir.len());
    for v in 0..mesh.vertices.len() {
        let varied =
            resound_stats::perturb(&ir, seed.wrapping_mul(1_000_003).wrapping_add(v as u64));
        gains.extend(
            varied
                .iter()
                .map(|m| (m.amplitude / resound_synth::render::REFERENCE_IMPULSE_N_S) as f32),
        );
    }
    Ok(BodySound {
        modes,
        vertices: mesh.vertices.clone(),
        gains,
        elastic: Elastic {
            youngs_modulus: material.gamma * b.density,
            poisson_ratio: b.poisson,
        },
        contact_loss: resound_physics::DEFAULT_CONTACT_LOSS,
        radiation: None,
    })
}

/// The body's surface texture, if it has one: `"fractal"` or a `.npy` height profile (quilted).
fn surface_of(
    b: &BodyFile,
    base_dir: &Path,
    seed: u64,
) -> Result<Option<std::sync::Arc<resound_synth::scrape::Surface>>> {
    use resound_synth::scrape::Surface;
    let Some(spec) = &b.surface else {
        return Ok(None);
    };
    let s = if spec == "fractal" {
        Surface::fractal(1 << 18, b.surface_spacing, 2.0, b.roughness, seed)
    } else {
        let path = base_dir.join(spec);
        let h = resound_io::npy::read_npy_f64(&path)?;
        let patch = (h.len() / 8).clamp(16, 8192);
        Surface::quilt(&h, b.surface_spacing, h.len().max(1 << 18), patch, seed)
    }
    .map_err(|e| invalid(format!("surface {spec:?}: {e}")))?;
    Ok(Some(std::sync::Arc::new(s)))
}

/// Most bodies in one scene.
pub const MAX_BODIES: usize = 4096;

/// Builds the bodies and settings of `scene`.
///
/// # Errors
/// More than [`MAX_BODIES`] bodies; a body whose material, geometry, sound or surface fails
/// (the error names the body). Identical sounding bodies share one modal solve.
pub fn build_scene(
    scene: &SceneFile,
    opts: &BuildOptions<'_>,
) -> Result<(Vec<BodySpec>, SceneParams)> {
    let fs = f64::from(scene.sample_rate);
    if scene.body.len() > MAX_BODIES {
        return Err(invalid(format!(
            "{} bodies: a scene takes at most {MAX_BODIES} (each sounding body keeps its own \
             gains at every surface vertex)",
            scene.body.len()
        )));
    }
    let mut models = ModelCache::new(opts.cache_dir.clone(), usize::MAX);
    let mut transfers = Transfers::new();
    let mut bodies = Vec::with_capacity(scene.body.len());
    let mut loaded: std::collections::HashMap<
        std::path::PathBuf,
        std::sync::Arc<resound_grains::Dictionary>,
    > = std::collections::HashMap::new();
    for (i, b) in scene.body.iter().enumerate() {
        let fail = |e: Error| e.context(format!("body {:?}", b.name));
        (opts.progress)(
            Progress::fraction(Stage::Building, i as f64 / scene.body.len() as f64)
                .with_label(format!("body {}/{}: {}", i + 1, scene.body.len(), b.name)),
        );
        let material = match &b.material {
            resound_io::scene::MaterialSpec::Name(spec) => {
                resolve_material(spec, opts.base_dir, opts.library).map_err(fail)?
            }
            resound_io::scene::MaterialSpec::Inline(m) => (**m).clone(),
        };
        let (mesh, shape) = geometry(b, opts.base_dir).map_err(fail)?;
        let grains = match b.grains_file() {
            Some((file, gain)) => {
                let path = opts.base_dir.join(file);
                let dictionary = match loaded.get(&path) {
                    Some(d) => std::sync::Arc::clone(d),
                    None => {
                        let d = std::sync::Arc::new(
                            resound_io::grains_file::load(&path).map_err(|e| fail(e.into()))?,
                        );
                        loaded.insert(path, std::sync::Arc::clone(&d));
                        d
                    }
                };
                Some(resound_physics::GrainSound {
                    dictionary,
                    params: resound_grains::player::PlayerParams {
                        gain,
                        seed: scene.seed.wrapping_add(i as u64),
                        ..Default::default()
                    },
                })
            }
            None => None,
        };
        let sound = if grains.is_some() {
            None
        } else if let Some(stats) = b.stats_file() {
            Some(
                stats_sound(
                    &opts.base_dir.join(stats),
                    &mesh,
                    b,
                    &material,
                    i as u64 + scene.seed,
                    fs,
                )
                .map_err(fail)?,
            )
        } else if b.sounds() {
            let elastic = Material {
                name: "custom".into(),
                youngs_modulus: material.gamma * b.density,
                poisson_ratio: b.poisson,
                density: b.density,
            };
            let (model, file) = modal_model(&mesh, &elastic, b, &mut models).map_err(fail)?;
            let transfer = if scene.radiation {
                Some(
                    body_transfer(&model, file.as_deref(), &mut transfers, opts.progress)
                        .map_err(fail)?,
                )
            } else {
                None
            };
            let s = body_sound(&model, &material, b.poisson, fs, transfer);
            if let Some(r) = &s.radiation {
                // Said on every build (the transfer may come from the cache).
                let poor = r
                    .modes
                    .iter()
                    .zip(&s.modes)
                    .filter(|&(&j, &(f, _))| {
                        r.transfer.misfit_at(j, f).is_some_and(|m| {
                            f64::from(m) > resound_core::limits::POOR_TRANSFER_MISFIT
                        })
                    })
                    .count();
                if poor > 0 {
                    (opts.progress)(Progress::Warning(Warning::new(
                        WarningKind::PoorTransfer,
                        format!(
                            "body {:?}: the acoustic transfer fits {poor} of its {} sounding \
                             modes poorly (misfit > 0.9: a shape far from smooth, or \
                             wavelengths shorter than the fit resolves): their levels are \
                             uncertain",
                            b.name,
                            s.modes.len()
                        ),
                    )));
                }
            }
            Some(s)
        } else {
            None
        };
        if scene.radiation && sound.as_ref().is_some_and(|s| s.radiation.is_none()) {
            (opts.progress)(Progress::Warning(Warning::new(
                WarningKind::PoorTransfer,
                format!(
                    "body {:?} sounds from statistics and has no acoustic transfer: its modes \
                     radiate alike (1/r)",
                    b.name
                ),
            )));
        }
        let mut sound = sound;
        if let (Some(s), Some(eta)) = (sound.as_mut(), b.contact_damping) {
            s.contact_loss = eta;
        }
        let deg = std::f64::consts::PI / 180.0;
        bodies.push(BodySpec {
            name: b.name.clone(),
            shape,
            fixed: b.fixed,
            density: b.density,
            position: b.position,
            rotation: b.rotation.map(|r| r * deg),
            linvel: b.velocity,
            angvel: b.angular_velocity,
            restitution: b.restitution,
            friction: b.friction,
            sound,
            surface: surface_of(b, opts.base_dir, scene.seed + i as u64).map_err(fail)?,
            grains,
        });
    }
    let params = SceneParams {
        duration_s: scene.duration,
        sample_rate_hz: fs,
        listener: scene.listener.position,
        stereo: scene.stereo,
        seed: scene.seed,
        steps_per_s: scene.steps_per_second,
        gravity: scene.gravity,
        reflection: scene
            .floor
            .as_ref()
            .map(|f| resound_synth::spatial::FloorReflection {
                height_m: f.height,
                coefficient: f.reflection,
            }),
        ambisonics: scene.ambisonics,
        air: scene.air.absorption.then_some(resound_synth::air::Air {
            temperature_c: scene.air.temperature,
            humidity_pct: scene.air.humidity,
            pressure_kpa: scene.air.pressure,
        }),
    };
    Ok((bodies, params))
}

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
