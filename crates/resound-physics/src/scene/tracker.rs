//! Rapier's contact pairs after each step, through the shared contact model
//! ([`crate::contact`]), into excitations, contact damping and the event log.

use super::*;

/// Continuous contacts are logged at most this often, s.
pub(super) const LOG_INTERVAL_S: f64 = 0.05;

/// What the contact tracker found in one physics step.
pub(super) struct StepContacts {
    /// Forces for the sound engine, in the order they were found.
    pub(super) excitations: Vec<Excitation>,
    /// Force buffers of earlier steps, for reuse (continuous contacts make one per step).
    pub(super) spare_forces: Vec<Vec<f32>>,
    /// The event log (kept for the whole run).
    pub(super) events: Vec<Event>,
    /// Per body: the strongest continuous contact of the step (kind, power W, speed m/s).
    pub(super) continuous: Vec<Option<(Contact, f64, f64)>>,
    /// Impacts for grain players: (body, samples into the step, impulse N·s).
    pub(super) grain_impacts: Vec<(usize, usize, f64)>,
    /// Per body: the contact loss factor of the step's persisting contacts (see
    /// [`contact_loss`]).
    pub(super) loss: Vec<f64>,
    /// Running figures.
    pub(super) stats: SceneStats,
}

impl StepContacts {
    /// An empty force buffer, reusing an earlier step's.
    pub(super) fn force_buffer(&mut self) -> Vec<f32> {
        let mut f = self.spare_forces.pop().unwrap_or_default();
        f.clear();
        f
    }

    /// Empties the step's excitations, keeping their buffers.
    pub(super) fn clear_excitations(&mut self) {
        let spare = &mut self.spare_forces;
        spare.extend(self.excitations.drain(..).map(|e| e.force));
    }

    /// The same force on both bodies of a contact.
    pub(super) fn excite_both(
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

/// Classifies rapier's contact pairs after each step — impacts (timed within the step, shaped
/// by Hertz, carrying the solver impulse), sliding, rolling, resting — and turns them into
/// [`Excitation`]s with the shared contact model ([`crate::contact`]).
pub(super) struct ContactTracker {
    pub(super) active: HashMap<(u32, u32), PairContact>,
    pub(super) spare: HashMap<(u32, u32), PairContact>,
    pub(super) profile: Profile,
    pub(super) radii: Vec<f64>,
    pub(super) dt: f64,
    pub(super) fs: f64,
}

impl ContactTracker {
    /// Looks at the contacts after the step that began at `t_start` (sample `s0`, `n` samples
    /// long), with `prev` the bodies' poses and velocities before it.
    pub(super) fn step(
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
                // Persistent contact: sliding, rolling or resting (or an impact's rebound,
                // which does neither).
                let normal_force = impulse / dt;
                // Leaving: the bodies' centres part along the normal (a point's velocity on a
                // spinning body would mistake the contact point's offset for motion).
                let centre = |i: usize| {
                    if bodies[i].fixed {
                        Vector::ZERO
                    } else {
                        world.bodies[handles[i]].linvel()
                    }
                };
                if is_leaving(f64::from((centre(i1) - centre(i2)).dot(normal))) {
                    now_active.insert(key, state);
                    continue;
                }
                let g = f64::from(world.gravity.length());
                for (i, j) in [(i1, i2), (i2, i1)] {
                    let weight = if bodies[i].fixed {
                        f64::INFINITY
                    } else {
                        f64::from(world.bodies[handles[i]].mass()) * g
                    };
                    let own = |x: &BodySpec| {
                        x.sound
                            .as_ref()
                            .map_or(crate::DEFAULT_CONTACT_LOSS, |s| s.contact_loss)
                    };
                    out.loss[i] +=
                        contact_loss(own(&bodies[i]), own(&bodies[j]), normal_force, weight);
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
