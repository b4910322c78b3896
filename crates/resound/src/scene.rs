//! From a scene file to sounding bodies: shapes → surface meshes → modal models (computed once
//! per shape, material and resolution, cached by content hash) → modes and per-vertex gains of
//! each body's material → [`resound_physics::BodySpec`].
//!
//! Materials in a scene are a material file (`*.json`), a library name, or `preset:NAME`: an
//! elastic preset (steel, aluminium, glass, ceramic, wood, plastic: γ = E/ρ from standard
//! tables) with the Rayleigh damping of the matching Ren 2013 Table I material (steel and
//! aluminium → metal, ceramic → porcelain) and σ = 1. A plain name that is not in the library
//! but is a preset is taken as `preset:NAME`. (Ren's Table I γ values suit his meshes' units, not
//! metres: `preset:` gives metre-scale objects their real pitch.)
//!
//! The modal model of a body is solved with the body's own density and E = γρ, so λ needs no
//! rescaling and the mass-normalised shapes carry the body's real mass.

use resound_core::{Material, ModalModel, SoundMaterial};
use resound_fem::{primitive, SurfaceMesh};
use resound_io::library::{read_material, Library};
use resound_io::scene::{BodyFile, SceneFile, ShapeFile};
use resound_modal::ModalParams;
use resound_physics::{BodySound, BodySpec, SceneParams, Shape};
use resound_synth::excitation::Elastic;
use std::path::{Path, PathBuf};

/// Why a scene cannot be built.
#[derive(Debug, thiserror::Error)]
pub enum SceneBuildError {
    /// A body's material, mesh or modal model failed.
    #[error("body {name:?}: {message}")]
    Body {
        /// Body name.
        name: String,
        /// What went wrong.
        message: String,
    },
}

/// Where to look things up while building.
pub struct BuildOptions<'a> {
    /// Directory of the scene file (mesh and material paths are relative to it).
    pub base_dir: &'a Path,
    /// The material library, if any.
    pub library: Option<&'a Library>,
    /// Directory for cached modal models (`None`: no cache).
    pub cache_dir: Option<PathBuf>,
    /// Progress messages.
    pub progress: &'a dyn Fn(&str),
}

/// The Rayleigh α, β of Ren's Table I material that matches an elastic preset.
fn table_damping(preset: &str) -> Option<(f64, f64)> {
    let ren = match preset {
        "steel" | "aluminium" => "metal",
        "ceramic" => "porcelain",
        "glass" => "glass",
        "wood" => "wood",
        "plastic" => "plastic",
        _ => return None,
    };
    SoundMaterial::ren_table_1()
        .into_iter()
        .find(|m| m.name == ren)
        .map(|m| (m.alpha, m.beta))
}

/// `preset:NAME` as a sound material (see the module docs).
pub fn preset_sound_material(name: &str) -> Option<SoundMaterial> {
    let m = Material::preset(name).ok()?;
    let (alpha, beta) = table_damping(name)?;
    Some(SoundMaterial::rayleigh(
        &format!("preset:{name}"),
        alpha,
        beta,
        m.youngs_modulus / m.density,
        1.0,
    ))
}

/// Resolves a scene's material reference.
pub fn resolve_material(
    spec: &str,
    base_dir: &Path,
    library: Option<&Library>,
) -> Result<SoundMaterial, String> {
    if let Some(p) = spec.strip_prefix("preset:") {
        return preset_sound_material(p).ok_or_else(|| {
            format!("unknown preset {p:?} (steel, aluminium, glass, ceramic, wood, plastic)")
        });
    }
    let path = base_dir.join(spec);
    if spec.ends_with(".json") || path.is_file() {
        return read_material(&path).map_err(|e| e.to_string());
    }
    if let Some(lib) = library {
        if let Some(m) = lib.get(spec).map_err(|e| e.to_string())? {
            return Ok(m);
        }
    }
    preset_sound_material(spec).ok_or_else(|| {
        format!("no material {spec:?} in the library, no such file, and not a preset")
    })
}

/// Splits every triangle into four (midpoints shared), `times` times: boxes get vertices on
/// their faces, so excitation can follow the contact point.
fn subdivide(mut m: SurfaceMesh, times: usize) -> SurfaceMesh {
    for _ in 0..times {
        let mut mid = std::collections::HashMap::new();
        let mut tris = Vec::with_capacity(m.triangles.len() * 4);
        let mut midpoint = |a: u32, b: u32, v: &mut Vec<[f64; 3]>| {
            *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                let (p, q) = (v[a as usize], v[b as usize]);
                v.push([
                    0.5 * (p[0] + q[0]),
                    0.5 * (p[1] + q[1]),
                    0.5 * (p[2] + q[2]),
                ]);
                (v.len() - 1) as u32
            })
        };
        for t in m.triangles.clone() {
            let ab = midpoint(t[0], t[1], &mut m.vertices);
            let bc = midpoint(t[1], t[2], &mut m.vertices);
            let ca = midpoint(t[2], t[0], &mut m.vertices);
            tris.extend([[t[0], ab, ca], [ab, t[1], bc], [ca, bc, t[2]], [ab, bc, ca]]);
        }
        m.triangles = tris;
    }
    m
}

/// The surface mesh and collider shape of a body, in the body frame.
fn geometry(b: &BodyFile, base_dir: &Path) -> Result<(SurfaceMesh, Shape), String> {
    Ok(match &b.shape {
        ShapeFile::Box(s) | ShapeFile::Plate(s) => (
            subdivide(primitive::bar(*s), 2),
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
            let mesh = match resound_io::load_mesh(&path, b.scale).map_err(|e| e.to_string())? {
                resound_io::LoadedMesh::Surface(s) => s,
                resound_io::LoadedMesh::Tets(_) => {
                    return Err("tet meshes are not supported in scenes; give a surface".into())
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

/// 64-bit FNV-1a: a content hash that is the same on every build (the cache key).
fn fnv1a(bytes: &[u8], mut h: u64) -> u64 {
    for &b in bytes {
        h ^= u64::from(b);
        h = h.wrapping_mul(0x100_0000_01b3);
    }
    h
}

fn modal_model(
    mesh: &SurfaceMesh,
    material: &Material,
    b: &BodyFile,
    cache_dir: Option<&Path>,
) -> Result<ModalModel, String> {
    let mut h = 0xcbf2_9ce4_8422_2325u64;
    for v in &mesh.vertices {
        for c in v {
            h = fnv1a(&c.to_le_bytes(), h);
        }
    }
    for t in &mesh.triangles {
        for c in t {
            h = fnv1a(&c.to_le_bytes(), h);
        }
    }
    for x in [
        material.youngs_modulus,
        material.poisson_ratio,
        material.density,
    ] {
        h = fnv1a(&x.to_le_bytes(), h);
    }
    h = fnv1a(&(b.modes as u64).to_le_bytes(), h);
    h = fnv1a(&(b.resolution as u64).to_le_bytes(), h);
    let file = cache_dir.map(|d| d.join(format!("{h:016x}.rmodal")));
    if let Some(f) = &file {
        if let Ok(m) = resound_io::model_file::load(f) {
            return Ok(m);
        }
    }
    let params = ModalParams {
        n_modes: Some(b.modes),
        max_freq_hz: None,
        resolution: b.resolution,
        target_voxels: if b.resolution == 0 { 1500 } else { 0 },
        sturm_check: false,
        ..Default::default()
    };
    let (model, _) = resound_modal::compute_modal_model(mesh, material, &params, &|_| {})
        .map_err(|e| format!("modal analysis: {e}"))?;
    if let Some(f) = &file {
        // A cache that cannot be written only costs time later.
        if let Some(d) = f.parent() {
            let _ = std::fs::create_dir_all(d);
        }
        let _ = resound_io::model_file::save(f, &model);
    }
    Ok(model)
}

/// The sound model of a body of `material` with modal `model` (solved at the body's density).
pub fn body_sound(
    model: &ModalModel,
    material: &SoundMaterial,
    poisson: f64,
    sample_rate_hz: f64,
) -> BodySound {
    let damping = material.damping();
    let m = model.n_modes();
    let vertex_gains = model.vertex_gains();
    let mut modes = Vec::new();
    let mut keep = Vec::new();
    for (j, &lambda) in model.eigenvalues.iter().enumerate() {
        let d = material
            .mode_damping
            .iter()
            .find(|o| o.mode == j)
            .map_or_else(|| damping.damping_per_s(lambda), |o| o.damping_per_s);
        let w2 = lambda - d * d;
        if !(w2 > 0.0) {
            continue;
        }
        let f = w2.sqrt() / std::f64::consts::TAU;
        if f < 0.5 * sample_rate_hz {
            modes.push((f, d));
            keep.push(j);
        }
    }
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
) -> Result<BodySound, String> {
    let text = std::fs::read_to_string(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let stats: resound_stats::ModeStatistics = serde_json::from_str(&text)
        .map_err(|e| format!("{}: not a statistics file: {e}", path.display()))?;
    let ir: Vec<_> = stats
        .sample(seed)
        .map_err(|e| e.to_string())?
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
    })
}

/// The body's surface texture, if it has one: `"fractal"` or a `.npy` height profile (quilted).
fn surface_of(
    b: &BodyFile,
    base_dir: &Path,
    seed: u64,
) -> Result<Option<std::sync::Arc<resound_synth::scrape::Surface>>, String> {
    use resound_synth::scrape::Surface;
    let Some(spec) = &b.surface else {
        return Ok(None);
    };
    let s = if spec == "fractal" {
        Surface::fractal(1 << 18, b.surface_spacing, 2.0, b.roughness, seed)
    } else {
        let path = base_dir.join(spec);
        let h = resound_io::npy::read_npy_f64(&path).map_err(|e| e.to_string())?;
        let patch = (h.len() / 8).clamp(16, 8192);
        Surface::quilt(&h, b.surface_spacing, h.len().max(1 << 18), patch, seed)
    }
    .map_err(|e| format!("surface {spec:?}: {e}"))?;
    Ok(Some(std::sync::Arc::new(s)))
}

/// Builds the bodies and settings of `scene`.
pub fn build_scene(
    scene: &SceneFile,
    opts: &BuildOptions<'_>,
) -> Result<(Vec<BodySpec>, SceneParams), SceneBuildError> {
    let fs = f64::from(scene.sample_rate);
    let mut bodies = Vec::with_capacity(scene.body.len());
    let mut loaded: std::collections::HashMap<
        std::path::PathBuf,
        std::sync::Arc<resound_grains::Dictionary>,
    > = std::collections::HashMap::new();
    for (i, spanned) in scene.body.iter().enumerate() {
        let b = spanned.get_ref();
        let fail = |message: String| SceneBuildError::Body {
            name: b.name.clone(),
            message,
        };
        (opts.progress)(&format!("body {}/{}: {}", i + 1, scene.body.len(), b.name));
        let material = resolve_material(&b.material, opts.base_dir, opts.library).map_err(fail)?;
        material.validate().map_err(fail)?;
        let (mesh, shape) = geometry(b, opts.base_dir).map_err(fail)?;
        let grains = match b.grains_file() {
            Some((file, gain)) => {
                let path = opts.base_dir.join(file);
                let dictionary = match loaded.get(&path) {
                    Some(d) => std::sync::Arc::clone(d),
                    None => {
                        let d = std::sync::Arc::new(
                            resound_io::grains_file::load(&path)
                                .map_err(|e| fail(e.to_string()))?,
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
            let model = modal_model(&mesh, &elastic, b, opts.cache_dir.as_deref()).map_err(fail)?;
            Some(body_sound(&model, &material, b.poisson, fs))
        } else {
            None
        };
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
    };
    Ok((bodies, params))
}
