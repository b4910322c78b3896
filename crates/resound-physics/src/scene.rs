//! The simulation loop: rapier steps, contact classification, excitation, rendering.

use crate::texture::{at, fractal_profile};
use crate::{BodySpec, SceneError, SceneParams, Shape};
use rapier3d::parry::query::distance;
use rapier3d::prelude::*;
use resound_grains::player::GrainPlayer;
use resound_grains::Contact;
use resound_synth::bank::{BankMode, ModalBank};
use resound_synth::excitation::{ContactModel, Impact};
use serde::Serialize;
use std::collections::HashMap;

/// Approach speed below which a new contact is not an impact, m/s.
const IMPACT_MIN_SPEED: f64 = 0.02;
/// Slip speed below which a contact does not slide, m/s.
const SLIP_MIN_SPEED: f64 = 0.01;
/// Speed below which a contact rests, m/s.
const MOVE_MIN_SPEED: f64 = 0.02;
/// Roughness: sliding force per unit normal force at 1 m/s and unit profile.
const ROUGHNESS: f64 = 0.05;
/// Force ring per body, samples.
const FORCE_RING: usize = 1 << 14;
/// Speed of sound, m/s.
const SPEED_OF_SOUND: f64 = 343.0;
/// Continuous contacts are logged at most this often, s.
const LOG_INTERVAL_S: f64 = 0.05;

/// What kind of contact an event is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ContactKind {
    /// A new contact: a force pulse.
    Impact,
    /// A persistent contact with slip.
    Sliding,
    /// A persistent moving contact without slip.
    Rolling,
}

/// One line of the event log.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Event {
    /// Time, s (impacts: the interpolated instant of contact).
    pub time_s: f64,
    /// The two bodies' names.
    pub bodies: [String; 2],
    /// Kind.
    pub kind: ContactKind,
    /// Impacts: the impulse (N·s); continuous contacts: the normal force (N).
    pub force: f64,
    /// Impacts: approach speed; sliding: slip speed; rolling: rolling speed (m/s).
    pub speed_m_s: f64,
    /// Contact point (world), m.
    pub point: [f64; 3],
}

/// Figures of a run.
#[derive(Clone, Debug, Default, PartialEq, Serialize)]
pub struct SceneStats {
    /// Physics steps.
    pub steps: usize,
    /// Wall time in the physics engine and contact handling, s.
    pub physics_s: f64,
    /// Wall time rendering and mixing, s.
    pub audio_s: f64,
    /// Most bodies sounding at once.
    pub max_voices: usize,
    /// Impacts.
    pub impacts: usize,
    /// Body-steps of sliding contact.
    pub sliding_steps: usize,
    /// Body-steps of rolling contact.
    pub rolling_steps: usize,
}

/// Audio and events of a scene.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneOutput {
    /// One or two channels.
    pub channels: Vec<Vec<f32>>,
    /// The event log.
    pub events: Vec<Event>,
    /// Figures.
    pub stats: SceneStats,
}

struct Voice {
    bank: ModalBank,
    modes: usize,
    gains: Vec<f64>,
    force: Vec<f32>,
    head: usize,
    /// Samples from `head` on that may hold force.
    pending: usize,
}

#[derive(Default)]
struct PairState {
    path_m: f64,
    lowpass: [f64; 2],
    last_log_s: f64,
    last_kind: Option<ContactKind>,
    offset_m: f64,
}

fn v3(a: [f64; 3]) -> Vector {
    Vector::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

fn arr(v: Vector) -> [f64; 3] {
    [f64::from(v.x), f64::from(v.y), f64::from(v.z)]
}

fn check_body(b: &BodySpec) -> Result<(), SceneError> {
    let err = |m: String| SceneError::Body {
        name: b.name.clone(),
        message: m,
    };
    let finite3 = |a: &[f64; 3]| a.iter().all(|v| v.is_finite());
    if !(b.density.is_finite() && b.density > 0.0) {
        return Err(err(format!("density must be > 0, got {}", b.density)));
    }
    if !(finite3(&b.position) && finite3(&b.rotation) && finite3(&b.linvel) && finite3(&b.angvel)) {
        return Err(err(
            "position, rotation and velocities must be finite".into()
        ));
    }
    if !((0.0..=1.0).contains(&b.restitution) && b.friction >= 0.0 && b.friction.is_finite()) {
        return Err(err(format!(
            "restitution must be in [0, 1] and friction ≥ 0 (got {}, {})",
            b.restitution, b.friction
        )));
    }
    let pos = |v: f64| v.is_finite() && v > 0.0;
    let ok = match &b.shape {
        Shape::Ball(r) => pos(*r),
        Shape::Cuboid(h) => h.iter().all(|&v| pos(v)),
        Shape::Cylinder {
            half_height,
            radius,
        } => pos(*half_height) && pos(*radius),
        Shape::ConvexHull(p) => p.len() >= 4 && p.iter().all(finite3),
        Shape::TriMesh {
            vertices,
            triangles,
        } => {
            if !b.fixed {
                return Err(err(
                    "a triangle-mesh collider must be fixed (dynamic bodies use convex hulls)"
                        .into(),
                ));
            }
            !triangles.is_empty()
                && vertices.iter().all(finite3)
                && triangles
                    .iter()
                    .all(|t| t.iter().all(|&i| (i as usize) < vertices.len()))
        }
    };
    if !ok {
        return Err(err(format!("unusable shape {:?}", shape_kind(&b.shape))));
    }
    if let Some(s) = &b.sound {
        if s.vertices.is_empty() || s.gains.len() != s.vertices.len() * s.modes.len() {
            return Err(err(format!(
                "sound model: {} gains for {} vertices × {} modes",
                s.gains.len(),
                s.vertices.len(),
                s.modes.len()
            )));
        }
    }
    Ok(())
}

fn shape_kind(s: &Shape) -> &'static str {
    match s {
        Shape::Ball(_) => "ball",
        Shape::Cuboid(_) => "cuboid",
        Shape::Cylinder { .. } => "cylinder",
        Shape::ConvexHull(_) => "convex hull",
        Shape::TriMesh { .. } => "triangle mesh",
    }
}

fn collider(b: &BodySpec, index: usize) -> Result<ColliderBuilder, SceneError> {
    let builder = match &b.shape {
        Shape::Ball(r) => ColliderBuilder::ball(*r as f32),
        Shape::Cuboid(h) => ColliderBuilder::cuboid(h[0] as f32, h[1] as f32, h[2] as f32),
        Shape::Cylinder {
            half_height,
            radius,
        } => ColliderBuilder::cylinder(*half_height as f32, *radius as f32).position(
            Pose::rotation(Vector::new(std::f32::consts::FRAC_PI_2, 0.0, 0.0)),
        ),
        Shape::ConvexHull(p) => {
            let pts: Vec<Vector> = p.iter().map(|&q| v3(q)).collect();
            ColliderBuilder::convex_hull(&pts).ok_or_else(|| SceneError::Body {
                name: b.name.clone(),
                message: "no convex hull (flat or degenerate points)".into(),
            })?
        }
        Shape::TriMesh {
            vertices,
            triangles,
        } => ColliderBuilder::trimesh(vertices.iter().map(|&q| v3(q)).collect(), triangles.clone())
            .map_err(|e| SceneError::Body {
                name: b.name.clone(),
                message: format!("triangle mesh: {e}"),
            })?,
    };
    Ok(builder
        .density(b.density as f32)
        .restitution(b.restitution as f32)
        .friction(b.friction as f32)
        .user_data(index as u128))
}

/// A typical contact radius of a body, m (the radius of curvature Hertz contact sees).
fn contact_radius(s: &Shape) -> f64 {
    match s {
        Shape::Ball(r) => *r,
        Shape::Cuboid(h) => 0.5 * h.iter().copied().fold(f64::INFINITY, f64::min),
        Shape::Cylinder { radius, .. } => *radius,
        Shape::ConvexHull(p) | Shape::TriMesh { vertices: p, .. } => {
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for q in p {
                for c in 0..3 {
                    lo[c] = lo[c].min(q[c]);
                    hi[c] = hi[c].max(q[c]);
                }
            }
            0.25 * (0..3).map(|c| hi[c] - lo[c]).fold(f64::INFINITY, f64::min)
        }
    }
    .max(1e-4)
}

fn nearest_vertex(vertices: &[[f64; 3]], p: [f64; 3]) -> usize {
    let mut best = 0;
    let mut best_d = f64::INFINITY;
    for (i, v) in vertices.iter().enumerate() {
        let d = (v[0] - p[0]).powi(2) + (v[1] - p[1]).powi(2) + (v[2] - p[2]).powi(2);
        if d < best_d {
            best_d = d;
            best = i;
        }
    }
    best
}

/// Runs the scene. `progress` gets the simulated fraction now and then.
pub fn simulate(
    bodies: &[BodySpec],
    params: &SceneParams,
    progress: &dyn Fn(f64),
) -> Result<SceneOutput, SceneError> {
    let fs = params.sample_rate_hz;
    if !(params.duration_s > 0.0 && params.duration_s <= 3600.0) {
        return Err(SceneError::Setting(format!(
            "duration must be in (0, 3600] s, got {}",
            params.duration_s
        )));
    }
    if !(8000.0..=192_000.0).contains(&fs) {
        return Err(SceneError::Setting(format!(
            "sample rate must be within 8000–192000 Hz, got {fs}"
        )));
    }
    if !(30.0..=4000.0).contains(&params.steps_per_s) {
        return Err(SceneError::Setting(format!(
            "physics steps per second must be within 30–4000, got {}",
            params.steps_per_s
        )));
    }
    if !params
        .listener
        .iter()
        .chain(&params.gravity)
        .all(|v| v.is_finite())
    {
        return Err(SceneError::Setting(
            "listener and gravity must be finite".into(),
        ));
    }
    for b in bodies {
        check_body(b)?;
    }
    let dt = 1.0 / params.steps_per_s;
    let mut world = PhysicsWorld {
        gravity: v3(params.gravity),
        ..Default::default()
    };
    world.integration_parameters.dt = dt as f32;
    let mut handles = Vec::with_capacity(bodies.len());
    for (i, b) in bodies.iter().enumerate() {
        let rb = if b.fixed {
            RigidBodyBuilder::fixed()
        } else {
            RigidBodyBuilder::dynamic()
                .linvel(v3(b.linvel))
                .angvel(v3(b.angvel))
        }
        .translation(v3(b.position))
        .rotation(v3(b.rotation));
        let (h, _) = world.insert(rb, collider(b, i)?);
        handles.push(h);
    }
    let mut voices: Vec<Option<Voice>> = Vec::with_capacity(bodies.len());
    for b in bodies {
        voices.push(match &b.sound {
            Some(s) => {
                let modes: Vec<BankMode> = s
                    .modes
                    .iter()
                    .enumerate()
                    .map(|(j, &(f, d))| BankMode {
                        freq_hz: f,
                        damping_per_s: d,
                        gain: f64::from(s.gains[j]),
                    })
                    .collect();
                Some(Voice {
                    bank: ModalBank::new(fs, &modes, 1e-7)?,
                    modes: s.modes.len(),
                    gains: vec![0.0; s.modes.len()],
                    force: vec![0.0; FORCE_RING],
                    head: 0,
                    pending: 0,
                })
            }
            None => None,
        });
    }
    let mut players: Vec<Option<GrainPlayer>> = Vec::with_capacity(bodies.len());
    for b in bodies {
        players.push(match &b.grains {
            Some(g) => Some(
                GrainPlayer::new(g.dictionary.clone(), fs, g.params.clone()).map_err(|e| {
                    SceneError::Body {
                        name: b.name.clone(),
                        message: format!("grains: {e}"),
                    }
                })?,
            ),
            None => None,
        });
    }
    // Per body and step: the strongest continuous contact (kind, power W, speed m/s).
    let mut continuous: Vec<Option<(Contact, f64, f64)>> = vec![None; bodies.len()];
    let profile = fractal_profile(1 << 17, 1.0, params.seed);
    let total = (params.duration_s * fs).round() as usize;
    let n_channels = if params.stereo { 2 } else { 1 };
    let mut channels = vec![vec![0.0f32; total]; n_channels];
    let mut events = Vec::new();
    let mut stats = SceneStats::default();
    let mut active: HashMap<(u32, u32), PairState> = HashMap::new();
    let steps = (params.duration_s * params.steps_per_s).ceil() as usize;
    let mut buf = Vec::new();
    let mut step_force = Vec::new();
    let radii: Vec<f64> = bodies.iter().map(|b| contact_radius(&b.shape)).collect();
    let mut last_progress = 0.0;
    for step in 0..steps {
        let t_start = step as f64 * dt;
        let s0 = ((step as f64 * dt * fs).round() as usize).min(total);
        let s1 = (((step + 1) as f64 * dt * fs).round() as usize).min(total);
        let n = s1 - s0;
        let tp = std::time::Instant::now();
        // Poses and velocities before the step.
        let prev: Vec<(Pose, Vector, Vector, Vector)> = handles
            .iter()
            .map(|&h| {
                let rb = &world.bodies[h];
                (
                    *rb.position(),
                    rb.linvel(),
                    rb.angvel(),
                    rb.center_of_mass(),
                )
            })
            .collect();
        world.step();
        continuous.iter_mut().for_each(|c| *c = None);
        let mut now_active: HashMap<(u32, u32), PairState> = HashMap::new();
        for pair in world.narrow_phase.contact_pairs() {
            let PairContacts::Rigid(r) = &pair.contacts else {
                continue;
            };
            let mut impulse = 0.0f64;
            let mut point = [0.0f64; 3];
            let mut normal = Vector::ZERO;
            for m in r.solver_manifolds() {
                for p in &m.points {
                    let j = f64::from(p.data.impulse);
                    if j > 0.0 {
                        let c1 = &world.colliders[pair.collider1];
                        let wp = arr(c1.position().transform_point(p.local_p1));
                        for c in 0..3 {
                            point[c] += j * wp[c];
                        }
                        impulse += j;
                        normal = m.data.normal;
                    }
                }
            }
            if !(impulse > 0.0) {
                continue;
            }
            for c in &mut point {
                *c /= impulse;
            }
            let (c1, c2) = (
                &world.colliders[pair.collider1],
                &world.colliders[pair.collider2],
            );
            let (i1, i2) = (c1.user_data as usize, c2.user_data as usize);
            let key = (
                pair.collider1.into_raw_parts().0,
                pair.collider2.into_raw_parts().0,
            );
            let wp = v3(point);
            let vel_at = |i: usize, post: bool| -> Vector {
                if bodies[i].fixed {
                    return Vector::ZERO;
                }
                if post {
                    world.bodies[handles[i]].velocity_at_point(wp)
                } else {
                    let (_, lv, av, com) = prev[i];
                    lv + av.cross(wp - com)
                }
            };
            let (mut state, was_active) = match active.remove(&key) {
                Some(s) => (s, true),
                None => (
                    PairState {
                        offset_m: (key.0 as f64 * 7.31 + key.1 as f64 * 3.17) % 10.0,
                        ..PairState::default()
                    },
                    false,
                ),
            };
            let approach = f64::from((vel_at(i1, false) - vel_at(i2, false)).dot(normal));
            let names = [bodies[i1].name.clone(), bodies[i2].name.clone()];
            if !was_active {
                state.last_kind = Some(ContactKind::Impact);
                if approach > IMPACT_MIN_SPEED {
                    // The instant of contact: the gap at the previous poses over the approach.
                    let gap = distance(
                        &(prev[i1].0 * c1.position_wrt_parent().copied().unwrap_or(Pose::IDENTITY)),
                        c1.shape(),
                        &(prev[i2].0 * c2.position_wrt_parent().copied().unwrap_or(Pose::IDENTITY)),
                        c2.shape(),
                    )
                    .map_or(0.0, |d| f64::from(d.distance).max(0.0));
                    let frac = (gap / (approach * dt)).clamp(0.0, 1.0);
                    let t_contact = t_start + frac * dt;
                    let mass = |i: usize| {
                        if bodies[i].fixed {
                            f64::INFINITY
                        } else {
                            f64::from(world.bodies[handles[i]].mass())
                        }
                    };
                    let (m1, m2) = (mass(i1), mass(i2));
                    let m_eff = if m1.is_infinite() {
                        m2
                    } else if m2.is_infinite() {
                        m1
                    } else {
                        m1 * m2 / (m1 + m2)
                    };
                    let elastic = |i: usize| {
                        bodies[i].sound.as_ref().map_or(
                            resound_synth::excitation::Elastic {
                                youngs_modulus: 1e9,
                                poisson_ratio: 0.3,
                            },
                            |s| s.elastic,
                        )
                    };
                    let imp = Impact {
                        impactor_mass_kg: m_eff.max(1e-9),
                        impactor_radius_m: radii[i1].min(radii[i2]),
                        impactor: elastic(i1),
                        object: elastic(i2),
                        object_mass_kg: None,
                        speed_m_s: approach,
                    };
                    let sample = t_contact * fs;
                    let first = sample.floor();
                    let offset = (sample - first) / fs;
                    if let Ok(pulse) =
                        imp.force_pulse(ContactModel::Hertz, fs, offset.min(0.999_999 / fs))
                    {
                        // Rapier's impulse (restitution included) with Hertz's shape.
                        let j_pulse: f64 = pulse.iter().map(|&f| f64::from(f)).sum::<f64>() / fs;
                        let scale = if j_pulse > 0.0 {
                            impulse / j_pulse
                        } else {
                            0.0
                        };
                        let at_sample = (first as usize).saturating_sub(s0);
                        for &i in &[i1, i2] {
                            if let Some(p) = players[i].as_mut() {
                                p.impact(at_sample, impulse);
                            }
                        }
                        excite_pair(
                            &mut voices,
                            bodies,
                            [i1, i2],
                            &world,
                            &handles,
                            point,
                            &pulse,
                            scale,
                            at_sample,
                        );
                    }
                    stats.impacts += 1;
                    events.push(Event {
                        time_s: t_contact,
                        bodies: names.clone(),
                        kind: ContactKind::Impact,
                        force: impulse,
                        speed_m_s: approach,
                        point,
                    });
                }
            } else {
                // Persistent contact: sliding, rolling or resting.
                let normal_force = impulse / dt;
                let v_rel = vel_at(i1, true) - vel_at(i2, true);
                let v_t = v_rel - normal * v_rel.dot(normal);
                let slip = f64::from(v_t.length());
                let speed_of = |i: usize| {
                    if bodies[i].fixed {
                        0.0
                    } else {
                        let v = world.bodies[handles[i]].linvel();
                        f64::from((v - normal * v.dot(normal)).length())
                    }
                };
                let moving = speed_of(i1).max(speed_of(i2));
                let kind = if slip > SLIP_MIN_SPEED && slip > 0.1 * moving {
                    Some((ContactKind::Sliding, slip))
                } else if moving > MOVE_MIN_SPEED {
                    Some((ContactKind::Rolling, moving))
                } else {
                    None
                };
                // Force amplitudes far below a micronewton are inaudible: no excitation.
                let kind = kind.filter(|&(_, speed)| ROUGHNESS * normal_force * speed > 1e-6);
                if let Some((k, speed)) = kind {
                    let c = if k == ContactKind::Rolling {
                        Contact::Rolling
                    } else {
                        Contact::Sliding
                    };
                    let power = normal_force * speed;
                    for &i in &[i1, i2] {
                        if continuous[i].is_none_or(|(_, p, _)| p < power) {
                            continuous[i] = Some((c, power, speed));
                        }
                    }
                }
                let texture = bodies[i1].surface.as_ref().or(bodies[i2].surface.as_ref());
                if let (Some((ContactKind::Sliding, speed)), Some(surface)) = (kind, texture) {
                    // Traer's scraping force along the textured profile, with one sample of
                    // context on either side so steps join without clicks.
                    let start = state.path_m + state.offset_m;
                    let xs: Vec<f64> = (0..n + 2)
                        .map(|j| start + speed * (j as f64 - 1.0) / fs)
                        .collect();
                    let mu = 0.5 * (bodies[i1].friction + bodies[i2].friction);
                    let p = resound_synth::scrape::ScrapeParams {
                        probe_mass_kg: 1e-4,
                        friction: mu * normal_force,
                        gamma: 1.0,
                        tip_width_m: 2e-4,
                    };
                    let f = resound_synth::scrape::scrape_force(surface, &xs, fs, &p);
                    state.path_m += speed * n as f64 / fs;
                    excite_pair(
                        &mut voices,
                        bodies,
                        [i1, i2],
                        &world,
                        &handles,
                        point,
                        &f[1..=n],
                        1.0,
                        0,
                    );
                    stats.sliding_steps += 1;
                    let t = t_start + dt;
                    if state.last_kind != Some(ContactKind::Sliding)
                        || t - state.last_log_s >= LOG_INTERVAL_S
                    {
                        events.push(Event {
                            time_s: t,
                            bodies: names.clone(),
                            kind: ContactKind::Sliding,
                            force: normal_force,
                            speed_m_s: speed,
                            point,
                        });
                        state.last_log_s = t;
                    }
                    state.last_kind = Some(ContactKind::Sliding);
                } else if let Some((kind, speed)) = kind {
                    step_force.clear();
                    step_force.resize(n, 0.0f32);
                    let roller = if bodies[i1].fixed { i2 } else { i1 };
                    let roll_radius = radii[roller];
                    // Low-pass for rolling: one pole at 50 Hz + 300 Hz per m/s.
                    let fc = 50.0 + 300.0 * speed;
                    let a = (-std::f64::consts::TAU * fc / fs).exp();
                    // The rolling body's rotation modulates the force (a few Hz): its phase is
                    // interpolated across the step instead of a sine per sample.
                    let rot0 = (state.path_m / roll_radius).sin();
                    let rot1 = ((state.path_m + speed * n as f64 / fs) / roll_radius).sin();
                    for (k, f) in step_force.iter_mut().enumerate() {
                        state.path_m += speed / fs;
                        let x = f64::from(at(&profile, state.path_m + state.offset_m));
                        *f = match kind {
                            ContactKind::Sliding => (ROUGHNESS * normal_force * speed * x) as f32,
                            _ => {
                                state.lowpass[0] = a * state.lowpass[0] + (1.0 - a) * x;
                                state.lowpass[1] =
                                    a * state.lowpass[1] + (1.0 - a) * state.lowpass[0];
                                let rotation = rot0 + (rot1 - rot0) * k as f64 / n.max(1) as f64;
                                (ROUGHNESS / 3.0
                                    * normal_force
                                    * speed
                                    * 8.0
                                    * state.lowpass[1]
                                    * (1.0 + 0.5 * rotation)) as f32
                            }
                        };
                    }
                    excite_pair(
                        &mut voices,
                        bodies,
                        [i1, i2],
                        &world,
                        &handles,
                        point,
                        &step_force,
                        1.0,
                        0,
                    );
                    match kind {
                        ContactKind::Sliding => stats.sliding_steps += 1,
                        _ => stats.rolling_steps += 1,
                    }
                    let t = t_start + dt;
                    if state.last_kind != Some(kind) || t - state.last_log_s >= LOG_INTERVAL_S {
                        events.push(Event {
                            time_s: t,
                            bodies: names.clone(),
                            kind,
                            force: normal_force,
                            speed_m_s: speed,
                            point,
                        });
                        state.last_log_s = t;
                    }
                    state.last_kind = Some(kind);
                } else {
                    state.last_kind = Some(ContactKind::Impact);
                }
            }
            now_active.insert(key, state);
        }
        active = now_active;
        stats.physics_s += tp.elapsed().as_secs_f64();
        // Render this step and place it at the listener.
        let ta = std::time::Instant::now();
        let mut sounding = 0;
        for (i, v) in voices.iter_mut().enumerate() {
            let Some(v) = v else { continue };
            if v.pending == 0 && v.bank.is_silent() {
                v.head = (v.head + n) % FORCE_RING;
                continue;
            }
            v.pending = v.pending.saturating_sub(n);
            buf.clear();
            buf.resize(n, 0.0f32);
            let mut f = std::mem::take(&mut step_force);
            f.clear();
            for k in 0..n {
                let idx = (v.head + k) % FORCE_RING;
                f.push(v.force[idx]);
                v.force[idx] = 0.0;
            }
            v.head = (v.head + n) % FORCE_RING;
            v.bank.process(&f, &mut buf);
            step_force = f;
            if v.bank.is_silent() {
                continue;
            }
            sounding += 1;
            let pos = arr(world.bodies[handles[i]].translation());
            place(&mut channels, &buf, s0, pos, params);
        }
        for (i, p) in players.iter_mut().enumerate() {
            let Some(p) = p else { continue };
            p.set_contact(continuous[i]);
            if p.is_silent() {
                continue;
            }
            buf.clear();
            buf.resize(n, 0.0f32);
            p.process(&mut buf);
            sounding += 1;
            let pos = arr(world.bodies[handles[i]].translation());
            place(&mut channels, &buf, s0, pos, params);
        }
        stats.max_voices = stats.max_voices.max(sounding);
        stats.audio_s += ta.elapsed().as_secs_f64();
        stats.steps += 1;
        let frac = (step + 1) as f64 / steps as f64;
        if frac - last_progress >= 0.01 {
            progress(frac);
            last_progress = frac;
        }
    }
    Ok(SceneOutput {
        channels,
        events,
        stats,
    })
}

/// Mixes a source's block `buf` (starting at sample `s0`) at `pos` into the output: 1/r
/// attenuation, propagation delay, equal-power pan.
fn place(channels: &mut [Vec<f32>], buf: &[f32], s0: usize, pos: [f64; 3], params: &SceneParams) {
    let fs = params.sample_rate_hz;
    let listener = params.listener;
    let total = channels.first().map_or(0, Vec::len);
    let d = [
        pos[0] - listener[0],
        pos[1] - listener[1],
        pos[2] - listener[2],
    ];
    let r = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    let g = 1.0 / r.max(0.1);
    let delay = (r / SPEED_OF_SOUND * fs).round() as usize;
    let gains: [f64; 2] = if params.stereo {
        let p = (d[0] / r.max(1e-9)).clamp(-1.0, 1.0);
        [g * (0.5 * (1.0 - p)).sqrt(), g * (0.5 * (1.0 + p)).sqrt()]
    } else {
        [g, 0.0]
    };
    let start = s0 + delay;
    if start >= total {
        return;
    }
    let end = (start + buf.len()).min(total);
    for (c, ch) in channels.iter_mut().enumerate() {
        let gc = gains[c] as f32;
        for (o, &x) in ch[start..end].iter_mut().zip(buf) {
            *o += x * gc;
        }
    }
}

/// [`excite`] on both bodies of a contact.
fn excite_pair(
    voices: &mut [Option<Voice>],
    bodies: &[BodySpec],
    pair: [usize; 2],
    world: &PhysicsWorld,
    handles: &[RigidBodyHandle],
    point: [f64; 3],
    force: &[f32],
    scale: f64,
    at_sample: usize,
) {
    for i in pair {
        excite(
            &mut voices[i],
            bodies,
            i,
            world,
            handles[i],
            point,
            force,
            scale,
            at_sample,
        );
    }
}

/// Adds `force × scale` to body `i`'s force ring from `at_sample` on, with the gains of the
/// surface vertex nearest `point`.
#[allow(clippy::too_many_arguments)]
fn excite(
    voice: &mut Option<Voice>,
    bodies: &[BodySpec],
    i: usize,
    world: &PhysicsWorld,
    handle: RigidBodyHandle,
    point: [f64; 3],
    force: &[f32],
    scale: f64,
    at_sample: usize,
) {
    let (Some(v), Some(sound)) = (voice.as_mut(), bodies[i].sound.as_ref()) else {
        return;
    };
    let local = arr(world.bodies[handle]
        .position()
        .inverse_transform_point(v3(point)));
    let k = nearest_vertex(&sound.vertices, local);
    for (j, g) in v.gains.iter_mut().enumerate() {
        *g = f64::from(sound.gains[k * v.modes + j]);
    }
    v.bank.set_gains(&v.gains);
    let len = force.len().min(FORCE_RING.saturating_sub(at_sample));
    for (n, &f) in force[..len].iter().enumerate() {
        let idx = (v.head + at_sample + n) % FORCE_RING;
        v.force[idx] += (f64::from(f) * scale) as f32;
    }
    v.pending = v.pending.max(at_sample + len);
}
