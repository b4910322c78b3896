//! The simulation loop: rapier steps, contact classification, excitation, rendering.

use crate::contact::{
    classify_persistent, impact_pulse, is_impact, radius_from_extents, scene_profile, ContactBody,
    ContactKind, PairContact, SILENT_ELASTIC,
};
use crate::{BodySpec, SceneError, SceneParams, Shape};
use rapier3d::parry::query::distance;
use rapier3d::prelude::*;
use resound_grains::player::GrainPlayer;
use resound_grains::Contact;
use resound_synth::contact::Profile;
use resound_synth::radiation::Radiator;
use resound_synth::scene_audio::{
    scene_audio, AudioStats, Cue, CueSender, SceneAudio, SceneAudioParams, Source,
};
use serde::Serialize;
use std::collections::HashMap;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Force ring per body, samples.
const FORCE_RING: usize = 1 << 14;
/// Fastest initial speed of a body, m/s (three times the speed of sound).
const MAX_SPEED_M_S: f64 = 1000.0;
/// Fastest initial spin of a body, rad/s.
const MAX_SPIN_RAD_S: f64 = 1.0e4;
/// Farthest a body may start from the origin, m.
const MAX_EXTENT_M: f64 = 1.0e4;
/// Longest propagation delay, s (sources beyond 343 m are held there).
const MAX_DELAY_S: f64 = 1.0;
/// Longest impact pulse the tracker makes, samples (queue sizing).
const FORCE_PULSE_SAMPLES: usize = 2048;
/// Continuous contacts are logged at most this often, s.
const LOG_INTERVAL_S: f64 = 0.05;

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
    /// One or two channels (four: ambisonics).
    pub channels: Vec<Vec<f32>>,
    /// The event log.
    pub events: Vec<Event>,
    /// Figures.
    pub stats: SceneStats,
}

/// What the contact tracker sends the sound engine each step: the two bodies of a contact
/// excited at one point by the same force profile (an impact's Hertz pulse, or a step of
/// sliding, rolling or scraping).
#[derive(Clone, Debug, PartialEq)]
pub struct Excitation {
    /// Indices of the two bodies in contact; both are excited.
    pub bodies: [usize; 2],
    /// Contact point, world frame, m.
    pub point: [f64; 3],
    /// Contact normal (from the first body to the second), world frame.
    pub normal: [f64; 3],
    /// Kind of contact.
    pub kind: ContactKind,
    /// Force, N per sample (times `scale`).
    pub force: Vec<f32>,
    /// Scale applied to `force` (an impact: the solver impulse over the pulse's own).
    pub scale: f64,
    /// Samples after the start of the step at which the force begins.
    pub delay: usize,
    /// Time of the excitation, s.
    pub time_s: f64,
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
    // rapier works in f32 and silently stops integrating absurd states (a ball thrown at
    // 1e30 m/s just fell straight down): refuse what no contact-sound scene needs.
    let norm = |a: &[f64; 3]| a.iter().map(|v| v * v).sum::<f64>().sqrt();
    if norm(&b.linvel) > MAX_SPEED_M_S
        || norm(&b.angvel) > MAX_SPIN_RAD_S
        || norm(&b.position) > MAX_EXTENT_M
    {
        return Err(err(format!(
            "velocity must be at most {MAX_SPEED_M_S} m/s, angular velocity at most {MAX_SPIN_RAD_S} rad/s and the position within {MAX_EXTENT_M} m of the origin (got |v| = {:.3e} m/s, |ω| = {:.3e} rad/s, |x| = {:.3e} m)",
            norm(&b.linvel),
            norm(&b.angvel),
            norm(&b.position)
        )));
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
        Shape::Cuboid(h) => radius_from_extents(h.map(|x| 2.0 * x)),
        Shape::Cylinder { radius, .. } => *radius,
        Shape::ConvexHull(p) | Shape::TriMesh { vertices: p, .. } => {
            let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
            for q in p {
                for c in 0..3 {
                    lo[c] = lo[c].min(q[c]);
                    hi[c] = hi[c].max(q[c]);
                }
            }
            radius_from_extents([0, 1, 2].map(|c| hi[c] - lo[c]))
        }
    }
    .max(1e-4)
}

/// Surface vertices of a body binned in a uniform grid (CSR), for the nearest vertex to a
/// contact point in about constant time: refined surfaces have thousands of vertices, and a
/// linear scan per contact and step dominated busy scenes.
struct VertexGrid {
    lo: [f64; 3],
    cell: f64,
    dims: [usize; 3],
    start: Vec<u32>,
    items: Vec<u32>,
}

impl VertexGrid {
    fn new(vertices: &[[f64; 3]]) -> Self {
        let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
        for v in vertices {
            for c in 0..3 {
                lo[c] = lo[c].min(v[c]);
                hi[c] = hi[c].max(v[c]);
            }
        }
        let diag = (0..3).map(|c| (hi[c] - lo[c]).powi(2)).sum::<f64>().sqrt();
        // A surface of n vertices: about √n cells along its diagonal hold a few vertices each.
        let cell = (diag / (vertices.len().max(1) as f64).sqrt()).max(1e-9);
        let dims = [0, 1, 2].map(|c| (((hi[c] - lo[c]) / cell).floor() as usize + 1).min(1024));
        let n_cells = dims[0] * dims[1] * dims[2];
        let mut grid = Self {
            lo,
            cell,
            dims,
            start: vec![0; n_cells + 1],
            items: vec![0; vertices.len()],
        };
        let cells: Vec<usize> = vertices
            .iter()
            .map(|&v| grid.index(grid.cell_of(v)))
            .collect();
        for &k in &cells {
            grid.start[k + 1] += 1;
        }
        for k in 0..n_cells {
            grid.start[k + 1] += grid.start[k];
        }
        let mut fill = grid.start.clone();
        for (i, &k) in cells.iter().enumerate() {
            grid.items[fill[k] as usize] = i as u32;
            fill[k] += 1;
        }
        grid
    }

    fn cell_of(&self, p: [f64; 3]) -> [usize; 3] {
        [0, 1, 2].map(|c| {
            (((p[c] - self.lo[c]) / self.cell).floor().max(0.0) as usize).min(self.dims[c] - 1)
        })
    }

    fn index(&self, c: [usize; 3]) -> usize {
        c[0] + self.dims[0] * (c[1] + self.dims[1] * c[2])
    }

    /// The vertex nearest `p` (the lowest index among equals, as a linear scan would give).
    fn nearest(&self, vertices: &[[f64; 3]], p: [f64; 3]) -> usize {
        let c = self.cell_of(p);
        let mut best = (f64::INFINITY, 0usize);
        let visit = |best: &mut (f64, usize), x: usize, y: usize, z: usize| {
            let k = self.index([x, y, z]);
            for &i in &self.items[self.start[k] as usize..self.start[k + 1] as usize] {
                let v = vertices[i as usize];
                let dd = (v[0] - p[0]).powi(2) + (v[1] - p[1]).powi(2) + (v[2] - p[2]).powi(2);
                if dd < best.0 || (dd == best.0 && (i as usize) < best.1) {
                    *best = (dd, i as usize);
                }
            }
        };
        let max_r = self.dims.iter().copied().max().unwrap_or(1);
        for r in 0..=max_r {
            let lo = [0, 1, 2].map(|k| c[k].saturating_sub(r));
            let hi = [0, 1, 2].map(|k| (c[k] + r).min(self.dims[k] - 1));
            for z in lo[2]..=hi[2] {
                for y in lo[1]..=hi[1] {
                    // The shell's cells only: a whole row on its faces, else the row's ends.
                    if r == 0 || z.abs_diff(c[2]) == r || y.abs_diff(c[1]) == r {
                        for x in lo[0]..=hi[0] {
                            visit(&mut best, x, y, z);
                        }
                    } else {
                        if c[0] >= r {
                            visit(&mut best, c[0] - r, y, z);
                        }
                        if c[0] + r < self.dims[0] {
                            visit(&mut best, c[0] + r, y, z);
                        }
                    }
                }
            }
            // Anything in the next shell is at least r cells away.
            if best.0.is_finite() && (r as f64 * self.cell).powi(2) > best.0 {
                break;
            }
        }
        best.1
    }
}

/// What the contact tracker found in one physics step.
struct StepContacts {
    /// Forces for the sound engine, in the order they were found.
    excitations: Vec<Excitation>,
    /// Force buffers of earlier steps, for reuse (continuous contacts make one per step).
    spare_forces: Vec<Vec<f32>>,
    /// The event log (kept for the whole run).
    events: Vec<Event>,
    /// Per body: the strongest continuous contact of the step (kind, power W, speed m/s).
    continuous: Vec<Option<(Contact, f64, f64)>>,
    /// Impacts for grain players: (body, samples into the step, impulse N·s).
    grain_impacts: Vec<(usize, usize, f64)>,
    /// Per body: the contact loss factor of the step's persisting contacts (see
    /// [`contact_loss`]).
    loss: Vec<f64>,
    /// Running figures.
    stats: SceneStats,
}

impl StepContacts {
    /// An empty force buffer, reusing an earlier step's.
    fn force_buffer(&mut self) -> Vec<f32> {
        let mut f = self.spare_forces.pop().unwrap_or_default();
        f.clear();
        f
    }

    /// Empties the step's excitations, keeping their buffers.
    fn clear_excitations(&mut self) {
        let spare = &mut self.spare_forces;
        spare.extend(self.excitations.drain(..).map(|e| e.force));
    }

    /// The same force on both bodies of a contact.
    fn excite_both(
        &mut self,
        pair: [usize; 2],
        point: [f64; 3],
        normal: [f64; 3],
        kind: ContactKind,
        force: Vec<f32>,
        scale: f64,
        delay: usize,
        time_s: f64,
    ) {
        self.excitations.push(Excitation {
            bodies: pair,
            point,
            normal,
            kind,
            force,
            scale,
            delay,
            time_s,
        });
    }
}

/// Most contact loss factor a body takes on, however many contacts it has.
pub const MAX_CONTACT_LOSS: f64 = 0.2;

/// The loss factor body `a` takes on from a persisting contact with `b` carrying
/// `normal_force` (N), `a` weighing `weight` (N): the pair's loss factor (the mean of the two
/// bodies', [`crate::DEFAULT_CONTACT_LOSS`] for a silent one) times the share of `a`'s weight
/// the contact carries (at most 1). An immovable body (infinite weight) takes on none; in
/// zero gravity any pressing contact counts fully.
fn contact_loss(a: &BodySpec, b: &BodySpec, normal_force: f64, weight: f64) -> f64 {
    let own = |x: &BodySpec| {
        x.sound
            .as_ref()
            .map_or(crate::DEFAULT_CONTACT_LOSS, |s| s.contact_loss)
    };
    if !(normal_force > 0.0) || weight.is_infinite() {
        return 0.0;
    }
    let share = if weight > 0.0 {
        (normal_force / weight).min(1.0)
    } else {
        1.0
    };
    0.5 * (own(a) + own(b)) * share
}

/// Classifies rapier's contact pairs after each step — impacts (timed within the step, shaped
/// by Hertz, carrying the solver impulse), sliding, rolling, resting — and turns them into
/// [`Excitation`]s with the shared contact model ([`crate::contact`]).
struct ContactTracker {
    active: HashMap<(u32, u32), PairContact>,
    spare: HashMap<(u32, u32), PairContact>,
    profile: Profile,
    radii: Vec<f64>,
    dt: f64,
    fs: f64,
}

impl ContactTracker {
    /// Looks at the contacts after the step that began at `t_start` (sample `s0`, `n` samples
    /// long), with `prev` the bodies' poses and velocities before it.
    fn step(
        &mut self,
        world: &PhysicsWorld,
        bodies: &[BodySpec],
        handles: &[RigidBodyHandle],
        prev: &[(Pose, Vector, Vector, Vector)],
        t_start: f64,
        s0: usize,
        n: usize,
        out: &mut StepContacts,
    ) {
        let (dt, fs) = (self.dt, self.fs);
        out.continuous.iter_mut().for_each(|c| *c = None);
        out.loss.iter_mut().for_each(|l| *l = 0.0);
        // Last step's map, emptied: its capacity is reused.
        let mut now_active = std::mem::take(&mut self.spare);
        now_active.clear();
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
            let (mut state, was_active) = match self.active.remove(&key) {
                Some(s) => (s, true),
                None => (
                    PairContact::new((key.0 as f64 * 7.31 + key.1 as f64 * 3.17) % 10.0),
                    false,
                ),
            };
            let approach = f64::from((vel_at(i1, false) - vel_at(i2, false)).dot(normal));
            // Only logged contacts need the names (an allocation each).
            let names = || [bodies[i1].name.clone(), bodies[i2].name.clone()];
            if !was_active {
                state.last_kind = Some(ContactKind::Impact);
                if is_impact(approach) {
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
                    let side = |i: usize| ContactBody {
                        mass_kg: if bodies[i].fixed {
                            f64::INFINITY
                        } else {
                            f64::from(world.bodies[handles[i]].mass())
                        },
                        radius_m: self.radii[i],
                        elastic: bodies[i]
                            .sound
                            .as_ref()
                            .map_or(SILENT_ELASTIC, |s| s.elastic),
                    };
                    if let Some((pulse, scale, at_sample)) = impact_pulse(
                        [side(i1), side(i2)],
                        approach,
                        impulse,
                        t_contact * fs - s0 as f64,
                        fs,
                    ) {
                        for i in [i1, i2] {
                            out.grain_impacts.push((i, at_sample, impulse));
                        }
                        out.excite_both(
                            [i1, i2],
                            point,
                            arr(normal),
                            ContactKind::Impact,
                            pulse,
                            scale,
                            at_sample,
                            t_contact,
                        );
                    }
                    out.stats.impacts += 1;
                    out.events.push(Event {
                        time_s: t_contact,
                        bodies: names(),
                        kind: ContactKind::Impact,
                        force: impulse,
                        speed_m_s: approach,
                        point,
                    });
                }
            } else {
                // Persistent contact: sliding, rolling or resting.
                let normal_force = impulse / dt;
                let g = f64::from(world.gravity.length());
                for (i, j) in [(i1, i2), (i2, i1)] {
                    let weight = if bodies[i].fixed {
                        f64::INFINITY
                    } else {
                        f64::from(world.bodies[handles[i]].mass()) * g
                    };
                    out.loss[i] += contact_loss(&bodies[i], &bodies[j], normal_force, weight);
                }
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
                let kind = classify_persistent(slip, moving, normal_force);
                if let Some((k, speed)) = kind {
                    let c = if k == ContactKind::Rolling {
                        Contact::Rolling
                    } else {
                        Contact::Sliding
                    };
                    let power = normal_force * speed;
                    for &i in &[i1, i2] {
                        if out.continuous[i].is_none_or(|(_, p, _)| p < power) {
                            out.continuous[i] = Some((c, power, speed));
                        }
                    }
                }
                let texture = bodies[i1].surface.as_ref().or(bodies[i2].surface.as_ref());
                if let (Some((ContactKind::Sliding, speed)), Some(surface)) = (kind, texture) {
                    // Traer's scraping force along the textured profile.
                    let mu = 0.5 * (bodies[i1].friction + bodies[i2].friction);
                    let f = state
                        .force
                        .scraping(surface, normal_force, speed, mu, fs, n);
                    out.excite_both(
                        [i1, i2],
                        point,
                        arr(normal),
                        ContactKind::Sliding,
                        f,
                        1.0,
                        0,
                        t_start,
                    );
                    out.stats.sliding_steps += 1;
                    let t = t_start + dt;
                    if state.last_kind != Some(ContactKind::Sliding)
                        || t - state.last_log_s >= LOG_INTERVAL_S
                    {
                        out.events.push(Event {
                            time_s: t,
                            bodies: names(),
                            kind: ContactKind::Sliding,
                            force: normal_force,
                            speed_m_s: speed,
                            point,
                        });
                        state.last_log_s = t;
                    }
                    state.last_kind = Some(ContactKind::Sliding);
                } else if let Some((kind, speed)) = kind {
                    let mut step_force = out.force_buffer();
                    step_force.resize(n, 0.0f32);
                    let roller = if bodies[i1].fixed { i2 } else { i1 };
                    state.continuous(
                        kind,
                        &self.profile,
                        normal_force,
                        speed,
                        self.radii[roller],
                        fs,
                        &mut step_force,
                    );
                    out.excite_both(
                        [i1, i2],
                        point,
                        arr(normal),
                        kind,
                        step_force,
                        1.0,
                        0,
                        t_start,
                    );
                    match kind {
                        ContactKind::Sliding => out.stats.sliding_steps += 1,
                        _ => out.stats.rolling_steps += 1,
                    }
                    let t = t_start + dt;
                    if state.last_kind != Some(kind) || t - state.last_log_s >= LOG_INTERVAL_S {
                        out.events.push(Event {
                            time_s: t,
                            bodies: names(),
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
        self.spare = std::mem::replace(&mut self.active, now_active);
    }
}

/// The physics side of a scene: rapier's world, the contact tracker, and what it needs to
/// turn contacts into [`Cue`]s for the audio side ([`resound_synth::scene_audio`]). Offline
/// ([`simulate`]) and live ([`crate::live`]) drive it the same way: [`ScenePhysics::step`] once
/// per physics step, the audio side rendering the step's samples.
pub struct ScenePhysics {
    world: PhysicsWorld,
    bodies: Vec<BodySpec>,
    handles: Vec<RigidBodyHandle>,
    tracker: ContactTracker,
    out: StepContacts,
    grids: Vec<Option<VertexGrid>>,
    moving: Vec<usize>,
    grain_bodies: Vec<usize>,
    step: usize,
    dt: f64,
    fs: f64,
    total: usize,
    steps: usize,
    /// Added to every step's start sample (the live latency).
    offset: u64,
    /// Wall time of the most recent step (physics and contact handling), s.
    last_step_s: f64,
    /// The contact loss factor last sent for each body.
    sent_loss: Vec<f64>,
    /// Per body with an acoustic transfer, its radiation at the listener.
    radiators: Vec<Option<Radiator>>,
    /// Listener, world frame, m.
    listener: [f64; 3],
}

/// The audio side's sources and settings for a scene's bodies (see [`ScenePhysics::new`]).
pub struct SceneSources {
    /// One per body, in the bodies' order (silent bodies too: no modes, no grains).
    pub sources: Vec<Source>,
    /// Settings for [`scene_audio`] (offline: no overload governor).
    pub params: SceneAudioParams,
}

impl ScenePhysics {
    /// Checks the scene, builds rapier's world, and hands the bodies' sound (modes, gain
    /// tables, grain players) to the audio side. `block` is the longest stretch the audio side
    /// will be asked to render at once (a device's block; 0 offline).
    pub fn new(
        bodies: &[BodySpec],
        params: &SceneParams,
        block: usize,
    ) -> Result<(Self, SceneSources), SceneError> {
        let fs = params.sample_rate_hz;
        if !(params.duration_s > 0.0 && params.duration_s <= 3600.0) {
            return Err(SceneError::Setting(format!(
                "duration must be in (0, 3600] s, got {}",
                params.duration_s
            )));
        }
        if !resound_core::limits::sample_rate_ok(fs) {
            return Err(SceneError::Setting(
                resound_core::limits::sample_rate_message(fs),
            ));
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
        if block > 1 << 16 {
            return Err(SceneError::Setting(format!(
                "audio blocks must be at most 65536 samples, got {block}"
            )));
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
        let mut sources = Vec::with_capacity(bodies.len());
        let mut kept = Vec::with_capacity(bodies.len());
        for (i, b) in bodies.iter().enumerate() {
            let grains = match &b.grains {
                Some(g) => Some(
                    GrainPlayer::new(g.dictionary.clone(), fs, g.params.clone()).map_err(|e| {
                        SceneError::Body {
                            name: b.name.clone(),
                            message: format!("grains: {e}"),
                        }
                    })?,
                ),
                None => None,
            };
            // The gain tables go to the audio side; the physics side keeps the vertices.
            let mut body = b.clone();
            let (modes, gains) = match body.sound.as_mut() {
                Some(s) => (s.modes.clone(), std::mem::take(&mut s.gains)),
                None => (Vec::new(), Vec::new()),
            };
            sources.push(Source {
                modes,
                gains,
                grains,
                position: arr(world.bodies[handles[i]].translation()),
                radiation: Vec::new(),
            });
            kept.push(body);
        }
        let mut radiators = Vec::with_capacity(kept.len());
        for b in &kept {
            radiators.push(match b.sound.as_ref() {
                Some(s) => match &s.radiation {
                    Some(r) => {
                        if r.modes.len() != s.modes.len() {
                            return Err(SceneError::Body {
                                name: b.name.clone(),
                                message: format!(
                                    "radiation names {} modes for {} sounding modes",
                                    r.modes.len(),
                                    s.modes.len()
                                ),
                            });
                        }
                        let modes: Vec<(usize, f64)> = r
                            .modes
                            .iter()
                            .zip(&s.modes)
                            .map(|(&j, &(f, _))| (j, f))
                            .collect();
                        Some(
                            Radiator::new(std::sync::Arc::clone(&r.transfer), &modes).ok_or_else(
                                || SceneError::Body {
                                    name: b.name.clone(),
                                    message: "radiation names a mode its transfer lacks, or a \
                                              mode of no positive frequency"
                                        .into(),
                                },
                            )?,
                        )
                    }
                    None => None,
                },
                None => None,
            });
        }
        // Each radiating body starts with its factors at the listener from its first pose, so
        // no force ever reaches the audio side before them (a dropped cue later only leaves
        // the previous factors in place).
        for (i, r) in radiators.iter_mut().enumerate() {
            let Some(r) = r else { continue };
            let local = arr(world.bodies[handles[i]]
                .position()
                .inverse_transform_point(v3(params.listener)));
            if let Some(f) = r.update(local) {
                sources[i].radiation = f.to_vec();
            }
        }
        let step_samples = (fs / params.steps_per_s).ceil() as usize + 1;
        let max_block = step_samples.max(block).max(1);
        let grids = kept
            .iter()
            .map(|b| b.sound.as_ref().map(|s| VertexGrid::new(&s.vertices)))
            .collect();
        let moving = (0..kept.len())
            .filter(|&i| !kept[i].fixed && (kept[i].sound.is_some() || kept[i].grains.is_some()))
            .collect();
        let grain_bodies = (0..kept.len())
            .filter(|&i| kept[i].grains.is_some())
            .collect();
        let tracker = ContactTracker {
            active: HashMap::new(),
            spare: HashMap::new(),
            profile: scene_profile(params.seed),
            radii: kept.iter().map(|b| contact_radius(&b.shape)).collect(),
            dt,
            fs,
        };
        let total = (params.duration_s * fs).round() as usize;
        let steps = (params.duration_s * params.steps_per_s).ceil() as usize;
        let n_bodies = kept.len();
        // Cues of one step: a position per body, two forces per contact, grain cues.
        let cue_capacity = (64 * n_bodies + 4096).next_power_of_two();
        let audio = SceneAudioParams {
            sample_rate_hz: fs,
            stereo: params.stereo,
            listener: params.listener,
            max_delay_s: MAX_DELAY_S,
            max_block,
            force_capacity: FORCE_RING,
            cull_level: 1e-7,
            cue_capacity,
            sample_capacity: (16 * n_bodies * (step_samples + FORCE_PULSE_SAMPLES)).max(1 << 18),
            governor: None,
            air: params.air,
            reflection: params.reflection,
            ambisonics: params.ambisonics,
        };
        Ok((
            Self {
                world,
                bodies: kept,
                handles,
                tracker,
                out: StepContacts {
                    excitations: Vec::new(),
                    spare_forces: Vec::new(),
                    events: Vec::new(),
                    continuous: vec![None; n_bodies],
                    grain_impacts: Vec::new(),
                    loss: vec![0.0; n_bodies],
                    stats: SceneStats::default(),
                },
                grids,
                moving,
                grain_bodies,
                step: 0,
                dt,
                fs,
                total,
                steps,
                offset: 0,
                last_step_s: 0.0,
                sent_loss: vec![0.0; n_bodies],
                radiators,
                listener: params.listener,
            },
            SceneSources {
                sources,
                params: audio,
            },
        ))
    }

    /// Delays every cue by `samples` (live: the scheduled contact-to-sound latency).
    pub fn set_offset(&mut self, samples: u64) {
        self.offset = samples;
    }

    /// Physics steps of the scene's duration.
    pub fn steps(&self) -> usize {
        self.steps
    }

    /// Steps done.
    pub fn steps_done(&self) -> usize {
        self.step
    }

    /// Output samples of the scene's duration.
    pub fn total_samples(&self) -> usize {
        self.total
    }

    /// The output samples `[s0, s1)` step `k` covers (before the offset).
    pub fn step_span(&self, k: usize) -> (usize, usize) {
        let s0 = ((k as f64 * self.dt * self.fs).round() as usize).min(self.total);
        let s1 = (((k + 1) as f64 * self.dt * self.fs).round() as usize).min(self.total);
        (s0, s1)
    }

    /// Wall time of the most recent step, s.
    pub fn last_step_s(&self) -> f64 {
        self.last_step_s
    }

    /// Runs the next physics step and sends its cues (they take effect at the step's start
    /// sample plus the offset). Returns the step's output samples `[s0, s1)` (no offset).
    pub fn step(&mut self, tx: &mut CueSender) -> (usize, usize) {
        let step = self.step;
        let dt = self.dt;
        let t_start = step as f64 * dt;
        let (s0, s1) = self.step_span(step);
        let n = s1 - s0;
        let tp = std::time::Instant::now();
        // Poses and velocities before the step.
        let prev: Vec<(Pose, Vector, Vector, Vector)> = self
            .handles
            .iter()
            .map(|&h| {
                let rb = &self.world.bodies[h];
                (
                    *rb.position(),
                    rb.linvel(),
                    rb.angvel(),
                    rb.center_of_mass(),
                )
            })
            .collect();
        self.world.step();
        self.out.clear_excitations();
        self.out.grain_impacts.clear();
        self.tracker.step(
            &self.world,
            &self.bodies,
            &self.handles,
            &prev,
            t_start,
            s0,
            n,
            &mut self.out,
        );
        // The step's cues, in the order the offline renderer always applied them.
        tx.step(s0 as u64 + self.offset);
        for &i in &self.moving {
            let p = self.world.bodies[self.handles[i]].translation();
            tx.send(Cue::Place {
                source: i as u32,
                position: [p.x, p.y, p.z],
            });
        }
        // Radiation: each body's factors at the listener, sent when the listener, seen from
        // the body, has turned or moved enough (before the forces, which they scale).
        let listener = v3(self.listener);
        for (i, r) in self.radiators.iter_mut().enumerate() {
            let Some(r) = r else { continue };
            let local = arr(self.world.bodies[self.handles[i]]
                .position()
                .inverse_transform_point(listener));
            if let Some(f) = r.update(local) {
                if !tx.radiation(i, f) {
                    r.invalidate();
                }
            }
        }
        for &(i, at_sample, impulse) in &self.out.grain_impacts {
            if self.bodies[i].grains.is_some() {
                tx.send(Cue::GrainImpact {
                    source: i as u32,
                    delay: at_sample as u32,
                    impulse_n_s: impulse,
                });
            }
        }
        for e in &self.out.excitations {
            for body in e.bodies {
                let Some(sound) = self.bodies[body].sound.as_ref() else {
                    continue;
                };
                let local = arr(self.world.bodies[self.handles[body]]
                    .position()
                    .inverse_transform_point(v3(e.point)));
                let k = self.grids[body]
                    .as_ref()
                    .map_or(0, |g| g.nearest(&sound.vertices, local));
                tx.force(body, k, &e.force, e.scale, e.delay);
            }
        }
        // Contact damping: sent when it starts, ends, or changes by a tenth (rapier's resting
        // forces jitter from step to step; each change recomputes the body's poles).
        // An immovable body (a table, a floor) is held by its mounting as if it rested on it
        // with its whole weight: it keeps its own loss factor.
        for (i, (&eta, sent)) in self.out.loss.iter().zip(&mut self.sent_loss).enumerate() {
            let Some(sound) = self.bodies[i].sound.as_ref() else {
                continue;
            };
            let eta = if self.bodies[i].fixed {
                sound.contact_loss
            } else {
                eta
            }
            .min(MAX_CONTACT_LOSS);
            if (eta > 0.0) == (*sent > 0.0) && (eta - *sent).abs() <= 0.1 * *sent {
                continue;
            }
            if tx.send(Cue::Damping {
                source: i as u32,
                loss_factor: eta as f32,
            }) {
                *sent = eta;
            }
        }
        for &i in &self.grain_bodies {
            tx.send(Cue::GrainContact {
                source: i as u32,
                contact: self.out.continuous[i],
            });
        }
        self.last_step_s = tp.elapsed().as_secs_f64();
        self.out.stats.physics_s += self.last_step_s;
        self.out.stats.steps += 1;
        self.step += 1;
        (s0, s1)
    }

    /// A body's position now, m.
    pub fn position(&self, body: usize) -> [f64; 3] {
        arr(self.world.bodies[self.handles[body]].translation())
    }

    /// Dynamic bodies rapier has not put to sleep.
    pub fn awake_bodies(&self) -> usize {
        self.world
            .bodies
            .iter()
            .filter(|(_, rb)| rb.is_dynamic() && !rb.is_sleeping())
            .count()
    }

    /// The event log so far.
    pub fn events(&self) -> &[Event] {
        &self.out.events
    }

    /// Figures so far (the audio side's are filled in by the driver).
    pub fn stats(&self) -> &SceneStats {
        &self.out.stats
    }

    /// The event log and figures, ending the run.
    pub fn finish(self) -> (Vec<Event>, SceneStats) {
        (self.out.events, self.out.stats)
    }
}

/// Runs the scene offline: each physics step's cues go through the same queues and the same
/// audio side ([`resound_synth::scene_audio::SceneAudio`]) a live run uses, and the step's samples are rendered right
/// after. `progress` gets the simulated fraction now and then.
pub fn simulate(
    bodies: &[BodySpec],
    params: &SceneParams,
    progress: &dyn Fn(f64),
) -> Result<SceneOutput, SceneError> {
    let (mut physics, mut sources) = ScenePhysics::new(bodies, params, 0)?;
    // With a second core the audio side renders step k while the physics computes step k + 1
    // (the queues hold both); the cues and their order are the same, so the samples are the
    // same as rendering in turn.
    let pipelined = std::thread::available_parallelism().map_or(1, usize::from) > 1;
    if pipelined {
        sources.params.cue_capacity =
            (sources.params.cue_capacity * PIPELINE_AHEAD).next_power_of_two();
        sources.params.sample_capacity *= PIPELINE_AHEAD;
    }
    let (mut tx, mut audio) = scene_audio(&sources.params, sources.sources)?;
    let total = physics.total_samples();
    let mut channels = vec![vec![0.0f32; total]; audio.channels()];
    let steps = physics.steps();
    let spans: Vec<(usize, usize)> = (0..steps).map(|k| physics.step_span(k)).collect();
    let render = |audio: &mut SceneAudio, channels: &mut [Vec<f32>], (s0, s1): (usize, usize)| {
        let ta = std::time::Instant::now();
        match channels {
            [a] => audio.process(&mut [&mut a[s0..s1]]),
            [a, b] => audio.process(&mut [&mut a[s0..s1], &mut b[s0..s1]]),
            [a, b, c, d] => audio.process(&mut [
                &mut a[s0..s1],
                &mut b[s0..s1],
                &mut c[s0..s1],
                &mut d[s0..s1],
            ]),
            _ => {}
        }
        ta.elapsed().as_secs_f64()
    };
    let mut last_progress = 0.0;
    let mut report = |step: usize| {
        let frac = (step + 1) as f64 / steps as f64;
        if frac - last_progress >= 0.01 {
            progress(frac);
            last_progress = frac;
        }
    };
    let audio_s = if pipelined {
        let sent = AtomicUsize::new(0);
        let rendered = AtomicUsize::new(0);
        std::thread::scope(|scope| {
            let audio_thread = scope.spawn(|| {
                let mut audio_s = 0.0;
                for (k, &span) in spans.iter().enumerate() {
                    while sent.load(Ordering::Acquire) <= k {
                        std::thread::park_timeout(std::time::Duration::from_micros(200));
                    }
                    audio_s += render(&mut audio, &mut channels, span);
                    rendered.store(k + 1, Ordering::Release);
                }
                audio_s
            });
            for step in 0..steps {
                while step >= rendered.load(Ordering::Acquire) + PIPELINE_AHEAD {
                    std::thread::yield_now();
                }
                physics.step(&mut tx);
                sent.store(step + 1, Ordering::Release);
                audio_thread.thread().unpark();
                report(step);
            }
            audio_thread.join().unwrap_or(0.0)
        })
    } else {
        let mut audio_s = 0.0;
        for step in 0..steps {
            physics.step(&mut tx);
            audio_s += render(&mut audio, &mut channels, spans[step]);
            report(step);
        }
        audio_s
    };
    let dropped = AudioStats::get(&audio.stats().dropped);
    if dropped > 0 {
        return Err(SceneError::Setting(format!(
            "{dropped} excitations did not fit the audio queues (too many contacts in one step)"
        )));
    }
    let max_voices = AudioStats::get(&audio.stats().max_sounding) as usize;
    let (events, mut stats) = physics.finish();
    stats.audio_s = audio_s;
    stats.max_voices = max_voices;
    Ok(SceneOutput {
        channels,
        events,
        stats,
    })
}

/// Steps in the queues at once in an offline run on two cores: the one being rendered and the
/// one being simulated.
const PIPELINE_AHEAD: usize = 2;

#[cfg(test)]
mod tests {
    use super::VertexGrid;

    #[test]
    fn the_grid_finds_the_same_vertex_as_a_scan() {
        let mut rng = 12345u64;
        let mut next = || {
            rng = rng
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (rng >> 11) as f64 / (1u64 << 53) as f64
        };
        let v: Vec<[f64; 3]> = (0..3000)
            .map(|_| [next() * 0.3, next() * 0.02, next() * 0.01])
            .collect();
        let g = VertexGrid::new(&v);
        for _ in 0..2000 {
            // Points inside, near and far outside the cloud.
            let p = [
                next() * 0.6 - 0.15,
                next() * 0.1 - 0.04,
                next() * 0.1 - 0.05,
            ];
            let scan = (0..v.len())
                .min_by(|&a, &b| {
                    let d = |i: usize| (0..3).map(|c| (v[i][c] - p[c]).powi(2)).sum::<f64>();
                    d(a).total_cmp(&d(b)).then(a.cmp(&b))
                })
                .unwrap();
            assert_eq!(g.nearest(&v, p), scan, "{p:?}");
        }
    }
}
