//! A scene body's checks and its rapier collider.

use super::*;

/// Fastest initial speed of a body, m/s (three times the speed of sound).
pub(super) const MAX_SPEED_M_S: f64 = 1000.0;
/// Fastest initial spin of a body, rad/s.
pub(super) const MAX_SPIN_RAD_S: f64 = 1.0e4;
/// Largest rotation vector (axis × angle), rad: 16 turns; beyond, a unit mistake.
pub(super) const MAX_ROTATION_RAD: f64 = 100.0;
/// Largest body, m (a floor may be large; nothing struck is a kilometre across).
pub(super) const MAX_BODY_SIZE_M: f64 = 1000.0;
/// Farthest a body may start from the origin, m.
pub(super) const MAX_EXTENT_M: f64 = 1.0e4;

pub(super) fn v3(a: [f64; 3]) -> Vector {
    Vector::new(a[0] as f32, a[1] as f32, a[2] as f32)
}

pub(super) fn arr(v: Vector) -> [f64; 3] {
    [f64::from(v.x), f64::from(v.y), f64::from(v.z)]
}

pub(super) fn check_body(b: &BodySpec) -> Result<(), SceneError> {
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
    // The axis-angle goes through sin/cos in f32: 1e300 became NaN and the body vanished
    // from a scene that then exited 0, silent.
    if !(norm(&b.rotation) <= MAX_ROTATION_RAD) {
        return Err(err(format!(
            "rotation (axis × angle) must be at most {MAX_ROTATION_RAD} rad long, got {:?}",
            b.rotation
        )));
    }
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
    // rapier and the modal solve take a 1e6 m sphere without a word; no struck object is
    // larger than the extent a scene may span.
    let span = |p: &[[f64; 3]]| {
        (0..3)
            .map(|c| {
                let (lo, hi) = p.iter().fold((f64::MAX, f64::MIN), |(lo, hi), v| {
                    (lo.min(v[c]), hi.max(v[c]))
                });
                hi - lo
            })
            .fold(0.0, f64::max)
    };
    let size = match &b.shape {
        Shape::Ball(r) => 2.0 * r,
        Shape::Cuboid(h) => 2.0 * h.iter().copied().fold(0.0, f64::max),
        Shape::Cylinder {
            half_height,
            radius,
        } => 2.0 * half_height.max(*radius),
        Shape::ConvexHull(p) => span(p),
        Shape::TriMesh { vertices, .. } => span(vertices),
    };
    if !(size <= MAX_BODY_SIZE_M) {
        return Err(err(format!(
            "the body is {size:.3e} m across, more than {MAX_BODY_SIZE_M} m (a size in millimetres?)"
        )));
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

pub(super) fn shape_kind(s: &Shape) -> &'static str {
    match s {
        Shape::Ball(_) => "ball",
        Shape::Cuboid(_) => "cuboid",
        Shape::Cylinder { .. } => "cylinder",
        Shape::ConvexHull(_) => "convex hull",
        Shape::TriMesh { .. } => "triangle mesh",
    }
}

pub(super) fn collider(b: &BodySpec, index: usize) -> Result<ColliderBuilder, SceneError> {
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
pub(super) fn contact_radius(s: &Shape) -> f64 {
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

/// Body `b`'s collider and its world pose at the start (for checks before a world exists).
fn start_collider(b: &BodySpec, index: usize) -> Result<(Collider, Pose3), SceneError> {
    let c = collider(b, index)?.build();
    let body = RigidBodyBuilder::fixed()
        .translation(v3(b.position))
        .rotation(v3(b.rotation))
        .build();
    // A collider not yet attached keeps its pose relative to the body.
    let pose = *body.position() * *c.position();
    Ok((c, pose))
}

/// Bodies that start deep inside one another: the first pair whose shapes overlap by more
/// than a quarter of the smaller one's size at their starting poses, as an error naming both.
/// rapier would push such bodies apart violently (or leave them locked, silent), and
/// thousands placed at one point make every pair a contact: a scene of 4000 coincident
/// spheres was still building after a minute. Checked before any sound model is built.
/// Pairs of triangle meshes (their surfaces, not solids) are not compared.
///
/// # Errors
/// [`SceneError::Body`] naming the pair and the overlap.
pub fn check_start_overlaps(bodies: &[BodySpec]) -> Result<(), SceneError> {
    use rapier3d::parry::query;
    let mut shapes = Vec::with_capacity(bodies.len());
    for (i, b) in bodies.iter().enumerate() {
        // Each body's own checks first (a 2e6 m sphere is named for its size).
        check_body(b)?;
        let (c, pose) = start_collider(b, i)?;
        let aabb = c.shape().compute_aabb(&pose);
        let size = (aabb.maxs - aabb.mins).min_element();
        shapes.push((c, pose, aabb, size));
    }
    // Sweep along x: only pairs whose boxes overlap there are compared.
    let mut order: Vec<usize> = (0..bodies.len()).collect();
    order.sort_by(|&a, &b| shapes[a].2.mins.x.total_cmp(&shapes[b].2.mins.x));
    for (k, &i) in order.iter().enumerate() {
        for &j in &order[k + 1..] {
            if shapes[j].2.mins.x > shapes[i].2.maxs.x {
                break;
            }
            let ((ci, pi, ai, si), (cj, pj, aj, sj)) = (&shapes[i], &shapes[j]);
            if !ai.intersects(aj) || (bodies[i].fixed && bodies[j].fixed) {
                continue;
            }
            let limit = 0.25 * si.min(*sj);
            let Ok(Some(c)) = query::contact(pi, ci.shape(), pj, cj.shape(), 0.0) else {
                continue;
            };
            if -c.dist > limit {
                let (a, b) = (&bodies[i.min(j)].name, &bodies[i.max(j)].name);
                return Err(SceneError::Body {
                    name: b.clone(),
                    message: format!(
                        "it starts {:.3} m deep inside body {a:?} (more than a quarter of the \
                         smaller one's size): move one of them apart",
                        -c.dist
                    ),
                });
            }
        }
    }
    Ok(())
}

/// The first body whose solid holds `point` at its starting pose (a listener placed inside a
/// body hears nothing physical). Triangle meshes count as solids only when closed and
/// oriented, as parry decides.
///
/// # Errors
/// A body whose shape cannot be built.
pub fn body_containing(bodies: &[BodySpec], point: [f64; 3]) -> Result<Option<&str>, SceneError> {
    for (i, b) in bodies.iter().enumerate() {
        let (c, pose) = start_collider(b, i)?;
        let p = v3(point);
        if c.shape().contains_point(&pose, p) {
            return Ok(Some(&b.name));
        }
    }
    Ok(None)
}
