//! Scene file → bodies: geometry, materials, sounds, surfaces.

use super::cache::{body_transfer, modal_model, Transfers};
use super::*;
use crate::mesh::{make_primitive, PrimitiveKind};

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
        // Primitives go through `mesh primitive`'s own checks (a bowl thicker than its radius
        // is refused there; the raw primitive panicked).
        ShapeFile::Box(s) | ShapeFile::Plate(s) => (
            // The modal solve refines the surface to the voxel scale (fem), so contacts anywhere
            // on a face find the mode shapes there.
            make_primitive(PrimitiveKind::Bar, s, 4)?,
            Shape::Cuboid([0.5 * s[0], 0.5 * s[1], 0.5 * s[2]]),
        ),
        ShapeFile::Sphere(r) => (
            make_primitive(PrimitiveKind::Sphere, &[*r], 24)?,
            Shape::Ball(*r),
        ),
        ShapeFile::Cylinder([r, h]) => (
            make_primitive(PrimitiveKind::Cylinder, &[*r, *h], 32)?,
            Shape::Cylinder {
                half_height: 0.5 * h,
                radius: *r,
            },
        ),
        ShapeFile::Bowl(v) => {
            let m = make_primitive(PrimitiveKind::Bowl, v, 48)?;
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

/// Most memory the sounding bodies' gain tables of one scene may take, bytes.
pub const MAX_SOUND_BYTES: usize = 2 << 30;

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
    // Shapes first: bodies that start inside one another are refused before any sound model
    // is built (thousands at one point made every pair a contact and held gigabytes).
    // Each body's spec without its sound yet, and the surface its sound is built on.
    let deg = std::f64::consts::PI / 180.0;
    let mut meshes: Vec<SurfaceMesh> = Vec::with_capacity(scene.body.len());
    let mut bare: Vec<BodySpec> = Vec::with_capacity(scene.body.len());
    for b in &scene.body {
        let (mesh, shape) =
            geometry(b, opts.base_dir).map_err(|e| e.context(format!("body {:?}", b.name)))?;
        meshes.push(mesh);
        bare.push(BodySpec {
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
            sound: None,
            surface: None,
            grains: None,
        });
    }
    resound_physics::check_start_overlaps(&bare)?;
    if let Some(name) = resound_physics::body_containing(&bare, scene.listener.position)? {
        return Err(invalid(format!(
            "the listener at {:?} m is inside body {name:?}: place it in the air",
            scene.listener.position
        )));
    }
    let mut specs = bare.into_iter().zip(meshes);
    let mut models = ModelCache::new(opts.cache_dir.clone(), usize::MAX);
    let mut sound_bytes = 0usize;
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
        let (spec, mesh) = specs
            .next()
            .ok_or_else(|| invalid("a body without its geometry"))?;
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
            // Each sounding body holds its gains at every surface vertex: refused up front
            // when the scene would need more than the budget (the rest taken like this one).
            let table = model.n_vertices() * (model.n_modes() * 4 + 24);
            sound_bytes += table;
            let projected = sound_bytes + table * (scene.body.len() - i - 1);
            if projected > MAX_SOUND_BYTES {
                return Err(invalid(format!(
                    "the sounding bodies would hold about {:.1} GiB of gain tables (body {:?}: \
                     {} vertices × {} modes), more than {} GiB: fewer sounding bodies (`sound \
                     = false`), fewer modes (`modes = N`), or coarser meshes",
                    projected as f64 / f64::from(1u32 << 30),
                    b.name,
                    model.n_vertices(),
                    model.n_modes(),
                    MAX_SOUND_BYTES >> 30
                )));
            }
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
        bodies.push(BodySpec {
            sound,
            surface: surface_of(b, opts.base_dir, scene.seed + i as u64).map_err(fail)?,
            grains,
            ..spec
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
