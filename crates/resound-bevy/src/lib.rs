//! Resound for Bevy: rigid bodies that sound when bevy_rapier3d makes them touch.
//!
//! Add [`ResoundPlugin`], give a rigid body a [`Sounding`] (its modes and gains: from a
//! library or estimated material and a modal model, see [`Sounding::from_material`]) and
//! mark one entity [`Listener`]. Each frame, after rapier's step, the plugin reads the contact
//! force events of sounding bodies and sends excitations to Resound's scene audio side
//! (`resound::synth::scene_audio`, the same allocation-free backend as `resound scene`):
//!
//! the very contact model of `resound scene` ([`resound::physics::contact`]), so a game sounds
//! like the same scene rendered offline:
//!
//! - a pair that starts touching is an **impact**: Hertz's force pulse for the two bodies'
//!   elasticity ([`Sounding::elastic`]), reduced mass (rapier's mass properties) and contact
//!   radius (from the collider), carrying the solver's impulse of the frame (contact force ×
//!   frame time), at the approach speed of the frame before;
//! - a pair that stays in touch **slides** or **rolls** by the slip of its contact points
//!   (taken at the contact radius from each centre, along the contact normal), with the
//!   scene's sliding and rolling forces over the frame;
//! - a pair whose points fly apart after an impact is its rebound and does neither;
//! - a pair in touch **damps** each sounding body by the pair's contact loss factor
//!   ([`Sounding::contact_loss`]) times the share of its weight it carries, as offline — and
//!   keeps damping it while rapier has it asleep on its support;
//! - a pair at rest, and a body in free fall, send no force: silence once the modes decay.
//!
//! Sources are placed at their bodies' positions every frame and heard from the listener with
//! 1/r attenuation, the propagation delay and an equal-power pan. Headless (no device: tests,
//! offline renders), the plugin renders each frame's samples itself into [`ResoundOutput`];
//! with `capture: false` a device callback can take the audio side from [`ResoundAudio`].

use bevy::prelude::*;
use bevy_rapier3d::prelude::*;
use resound::physics::contact::{
    classify_persistent, contact_loss, impact_pulse, is_impact, is_leaving, loss_changed,
    radius_from_extents, scene_profile, ContactBody, ContactKind, PairContact, MAX_CONTACT_LOSS,
    SILENT_ELASTIC,
};
use resound::synth::radiation::Radiator;
use resound::synth::scene_audio::{
    scene_audio, Cue, CueSender, SceneAudio, SceneAudioParams, Source,
};
use std::collections::{HashMap, HashSet};

/// The plugin's settings.
#[derive(Clone, Debug)]
pub struct ResoundPlugin {
    /// Output sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Two channels instead of one.
    pub stereo: bool,
    /// Render each frame's samples into [`ResoundOutput`] (headless).
    pub capture: bool,
    /// Seed of the rough profile sliding and rolling contacts read (a scene's `seed`).
    pub seed: u64,
    /// With a device (`capture: false`): each frame's cues take effect this many samples after
    /// the audio clock (at least a device block and a frame's jitter), samples.
    pub latency_samples: u64,
    /// Spare sources for bodies that get a [`Sounding`] after start-up (spawned objects); a
    /// despawned body's source is reused.
    pub spare_sources: usize,
    /// Modes a spare source holds (a later [`Sounding`] with more keeps its loudest this many).
    pub spare_modes: usize,
}

impl Default for ResoundPlugin {
    fn default() -> Self {
        Self {
            sample_rate_hz: 48_000.0,
            stereo: true,
            capture: true,
            seed: 1,
            latency_samples: 2048,
            spare_sources: 32,
            spare_modes: 64,
        }
    }
}

/// How a rigid body sounds: its modes and their gains at the struck point.
#[derive(Component, Clone, Debug)]
pub struct Sounding {
    /// Damped frequency (Hz) and decay rate (1/s) of each mode.
    pub modes: Vec<(f64, f64)>,
    /// Output amplitude per N·s of each mode.
    pub gains: Vec<f32>,
    /// How the modes radiate: the model's acoustic transfer (body frame) and each mode's index
    /// in it ([`Sounding::radiating`]). `None`: every mode radiates alike (1/r).
    pub radiation: Option<resound::physics::BodyRadiation>,
    /// Elastic constants for Hertz contact (a scene body's: the material's E at the model's ν).
    pub elastic: resound::synth::excitation::Elastic,
    /// Contact damping: the loss factor η the body takes on across a contact that carries its
    /// whole weight (the scene's `contact_damping`; [`resound::physics::DEFAULT_CONTACT_LOSS`]
    /// unless set), shared with the other body as in an offline scene
    /// ([`resound::physics::contact::contact_loss`]). 0: it rings on however it rests.
    pub contact_loss: f64,
}

impl Sounding {
    /// The modes of `model` in `material` (α, β, γ, σ: from the library or estimated from a
    /// recording) at `sample_rate_hz`, with the gains at surface vertex `vertex`.
    pub fn from_material(
        model: &resound::core::ModalModel,
        material: &resound::core::SoundMaterial,
        vertex: usize,
        sample_rate_hz: f64,
    ) -> Self {
        let poisson = model.material.poisson_ratio;
        let s = resound::scene::body_sound(model, material, poisson, sample_rate_hz, None);
        Self::at_vertex(s, vertex)
    }

    /// A scene body's sound ([`resound::scene::build_scene`]) heard at one surface vertex (the
    /// plugin's contacts excite one): a game body that sounds like the scene file's.
    pub fn at_vertex(s: resound::physics::BodySound, vertex: usize) -> Self {
        let m = s.modes.len();
        let k = vertex.min(s.vertices.len().saturating_sub(1));
        Self {
            gains: s
                .gains
                .get(k * m..(k + 1) * m)
                .map_or(Vec::new(), <[f32]>::to_vec),
            modes: s.modes,
            radiation: s.radiation,
            elastic: s.elastic,
            contact_loss: s.contact_loss,
        }
    }

    /// [`Sounding::from_material`] whose modes radiate by `model`'s acoustic transfer (as a
    /// scene's `radiation = true`): each mode's level and directivity at the [`Listener`] as
    /// seen from the body's pose, updated when that direction turns by more than 1° or the
    /// distance changes by more than 2 %. A model without a transfer (`resound modal
    /// --transfer`) gets one fitted now (seconds). Levels become pressure-like (ω|p|r/ρc²).
    ///
    /// # Errors
    /// A surface the transfer fit cannot use.
    pub fn radiating(
        model: &resound::core::ModalModel,
        material: &resound::core::SoundMaterial,
        vertex: usize,
        sample_rate_hz: f64,
    ) -> resound::Result<Self> {
        let (t, _) = resound::radiation::transfer_of(model)?;
        let poisson = model.material.poisson_ratio;
        let s = resound::scene::body_sound(
            model,
            material,
            poisson,
            sample_rate_hz,
            Some(std::sync::Arc::new(t.into_owned())),
        );
        Ok(Self::at_vertex(s, vertex))
    }

    /// The radiation of the modes `keep` (indices into `modes`) at a listener, if this
    /// sounding radiates and its radiation is consistent.
    fn radiator(&self, keep: &[usize]) -> Option<Radiator> {
        let r = self.radiation.as_ref()?;
        let modes: Option<Vec<(usize, f64)>> = keep
            .iter()
            .map(|&k| Some((*r.modes.get(k)?, self.modes.get(k)?.0)))
            .collect();
        Radiator::new(std::sync::Arc::clone(&r.transfer), &modes?)
    }
}

/// The listener seen from a body at `t` (its frame), m.
fn in_body_frame(t: &Transform, listener: Vec3) -> [f64; 3] {
    (t.rotation.inverse() * (listener - t.translation))
        .to_array()
        .map(f64::from)
}

impl Sounding {
    /// The modes of `model` in the material `reference` names, with the gains at surface
    /// vertex `vertex`: a library entry (`library`: a library file, `None` the default one),
    /// a material file (`.json`), `preset:NAME` or a built-in name, as `resound scene` reads
    /// them.
    ///
    /// # Errors
    /// Unknown references, unreadable files or libraries, invalid materials.
    pub fn from_reference(
        model: &resound::core::ModalModel,
        reference: &str,
        library: Option<&std::path::Path>,
        vertex: usize,
        sample_rate_hz: f64,
    ) -> resound::Result<Self> {
        let lib = resound::material::read_library(library)?;
        let material = resound::material::resolve_material(
            reference,
            std::path::Path::new("."),
            lib.as_ref(),
        )?;
        Ok(Self::from_material(
            model,
            &material,
            vertex,
            sample_rate_hz,
        ))
    }

    /// One draw (`seed`) of mode statistics (fitted with `resound stats fit` or imported from
    /// PyImpact): the modes of a struck object of that kind, with no mesh. The gains are the
    /// statistics' amplitudes per reference impulse; with no material, contacts take the
    /// elasticity of a silent scene body ([`resound::physics::contact::SILENT_ELASTIC`]).
    ///
    /// # Errors
    /// Statistics that cannot be sampled.
    pub fn from_statistics(
        stats: &resound::stats::ModeStatistics,
        seed: u64,
    ) -> resound::Result<Self> {
        let modes = stats.sample(seed)?;
        let bank = resound::synth::render::bank_modes(&modes);
        Ok(Self {
            modes: bank.iter().map(|m| (m.freq_hz, m.damping_per_s)).collect(),
            gains: bank
                .iter()
                .map(|m| (m.gain / resound::synth::render::REFERENCE_IMPULSE_N_S) as f32)
                .collect(),
            radiation: None,
            elastic: resound::physics::contact::SILENT_ELASTIC,
            contact_loss: resound::physics::DEFAULT_CONTACT_LOSS,
        })
    }
}

/// The entity whose position the sound is heard from (the first one found; read every frame).
#[derive(Component, Clone, Copy, Debug, Default)]
pub struct Listener;

/// The sound rendered so far (headless, `capture: true`): one or two channels.
#[derive(Resource, Clone, Debug, Default)]
pub struct ResoundOutput {
    /// Channels at `sample_rate_hz`.
    pub channels: Vec<Vec<f32>>,
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Impacts sent, with their frame's start time (s) and the bodies.
    pub impacts: Vec<(f64, Entity, Entity)>,
    /// Each impact's approach speed (m/s) and impulse (N·s), as a scene's event log has them.
    pub impact_figures: Vec<(f64, f64)>,
    /// Frame-steps of sliding and of rolling (a scene's `sliding_steps`, `rolling_steps`).
    pub sliding_steps: usize,
    /// Frame-steps of rolling.
    pub rolling_steps: usize,
}

/// The plugin's link to the audio side (a resource; the mutex makes the queue ends `Sync`
/// for Bevy and is only ever taken through `&mut`, so it never locks).
#[derive(Resource)]
pub struct ResoundAudio(pub std::sync::Mutex<AudioLink>);

/// The sending end and, headless, the audio side.
pub struct AudioLink {
    tx: CueSender,
    /// The audio side (taken by a device callback when `capture` is off).
    pub audio: Option<SceneAudio>,
    source_of: HashMap<Entity, u32>,
    /// Sources free for bodies that start sounding later, with the modes each holds.
    free: Vec<(u32, usize)>,
    /// Modes each source holds.
    capacity: Vec<usize>,
    /// Bodies that found no free source (reported once each).
    unheard: HashSet<Entity>,
    /// Pairs in touch at the last frame, with their contact state (profile position) and
    /// normal force (N).
    touching: HashMap<(Entity, Entity), (PairContact, f64)>,
    /// Last frame's map, emptied (its capacity reused).
    spare: HashMap<(Entity, Entity), (PairContact, f64)>,
    /// This frame's pairs: impulse (N·s), the strongest force's direction and magnitude.
    frame: HashMap<(Entity, Entity), (f64, Vec3, f32, u32)>,
    /// Each body's velocity at the end of the last frame (the approach of a new contact).
    before: HashMap<Entity, Velocity>,
    /// Per radiating source, its modes' radiation at the listener.
    radiators: HashMap<u32, Radiator>,
    clock: u64,
    profile: resound::synth::contact::Profile,
    force: Vec<f32>,
    /// Each source's contact loss factor this frame, and the one last sent.
    loss: Vec<f64>,
    sent_loss: Vec<f64>,
}

#[derive(Resource, Clone)]
struct Settings(ResoundPlugin);

/// The PostStartup system set that builds the audio side: a system that takes the audio side
/// to a device runs `.after(StartSet)`.
#[derive(SystemSet, Debug, Clone, PartialEq, Eq, Hash)]
pub struct StartSet;

impl Plugin for ResoundPlugin {
    fn build(&self, app: &mut App) {
        app.insert_resource(Settings(self.clone()))
            .insert_resource(ResoundOutput {
                sample_rate_hz: self.sample_rate_hz,
                ..Default::default()
            })
            .add_systems(PostStartup, start.in_set(StartSet))
            .add_systems(PostUpdate, excite.after(PhysicsSet::Writeback));
    }
}

/// Builds the audio side from every sounding body and asks rapier for their contact forces.
fn start(
    mut commands: Commands,
    settings: Res<Settings>,
    bodies: Query<(Entity, &Sounding, &Transform)>,
    listener: Query<&Transform, With<Listener>>,
) {
    let s = &settings.0;
    let heard_at = listener.iter().next().map_or(Vec3::ZERO, |t| t.translation);
    let listener = heard_at.to_array().map(f64::from);
    let mut sources = Vec::new();
    let mut source_of = HashMap::new();
    let mut radiators = HashMap::new();
    for (e, snd, t) in &bodies {
        let i = sources.len() as u32;
        source_of.insert(e, i);
        let all: Vec<usize> = (0..snd.modes.len()).collect();
        let mut radiation = Vec::new();
        if let Some(mut r) = snd.radiator(&all) {
            if let Some(f) = r.update(in_body_frame(t, heard_at)) {
                radiation = f.to_vec();
            }
            radiators.insert(i, r);
        }
        sources.push(Source {
            modes: snd.modes.clone(),
            gains: snd.gains.clone(),
            grains: None,
            position: t.translation.to_array().map(f64::from),
            radiation,
        });
        listen(&mut commands, e);
    }
    // Spare sources: silent until a Sound cue gives them a later body's modes.
    let spare = s.spare_modes.max(1);
    let mut free = Vec::new();
    for _ in 0..s.spare_sources {
        free.push((sources.len() as u32, spare));
        sources.push(Source {
            modes: vec![(1000.0, 1000.0); spare],
            gains: vec![0.0; spare],
            grains: None,
            position: [0.0; 3],
            radiation: Vec::new(),
        });
    }
    free.reverse();
    let capacity: Vec<usize> = sources.iter().map(|s| s.modes.len()).collect();
    let n_sources = capacity.len();
    let params = SceneAudioParams {
        sample_rate_hz: s.sample_rate_hz,
        stereo: s.stereo,
        listener,
        max_delay_s: 1.0,
        max_block: 8192,
        force_capacity: 1 << 15,
        cull_level: 1e-7,
        cue_capacity: 1 << 14,
        sample_capacity: 1 << 20,
        governor: None,
        air: Some(resound::synth::air::Air::default()),
        reflection: None,
        ambisonics: false,
    };
    match scene_audio(&params, sources) {
        Ok((tx, audio)) => {
            let fs = s.sample_rate_hz;
            commands.insert_resource(ResoundAudio(std::sync::Mutex::new(AudioLink {
                tx,
                audio: Some(audio),
                source_of,
                free,
                capacity,
                unheard: HashSet::new(),
                touching: HashMap::new(),
                spare: HashMap::new(),
                frame: HashMap::new(),
                before: HashMap::new(),
                radiators,
                clock: 0,
                profile: scene_profile(s.seed),
                force: vec![0.0; (fs / 10.0) as usize],
                loss: vec![0.0; n_sources],
                sent_loss: vec![0.0; n_sources],
            })));
        }
        Err(e) => eprintln!("resound: no audio: {e}"),
    }
}

/// Asks rapier for a sounding body's contact forces, velocity and mass (keeping a velocity it
/// was given).
fn listen(commands: &mut Commands, e: Entity) {
    commands
        .entity(e)
        .insert((
            ActiveEvents::CONTACT_FORCE_EVENTS,
            ContactForceEventThreshold(0.0),
        ))
        .insert_if_new((Velocity::default(), ReadMassProperties::default()));
}

/// The loudest `n` of a sounding's modes (by gain), in their order: their indices.
fn loudest(snd: &Sounding, n: usize) -> Vec<usize> {
    let m = snd.modes.len().min(snd.gains.len());
    let mut idx: Vec<usize> = (0..m).collect();
    if m > n {
        idx.sort_by(|&a, &b| snd.gains[b].abs().total_cmp(&snd.gains[a].abs()));
        idx.truncate(n);
        idx.sort_unstable();
    }
    idx
}

/// After rapier's step: bodies that started or stopped sounding, the listener, impacts and
/// rubbing from the contact forces, positions, and (headless) the frame's samples.
#[allow(clippy::too_many_arguments)]
fn excite(
    mut commands: Commands,
    settings: Res<Settings>,
    time: Res<Time>,
    state: Option<ResMut<ResoundAudio>>,
    mut output: ResMut<ResoundOutput>,
    mut forces: MessageReader<ContactForceEvent>,
    timestep: Option<Res<TimestepMode>>,
    bodies: Query<BodyParts>,
    unmeasured: Query<Entity, (With<RigidBody>, Without<Velocity>)>,
    added: Query<(Entity, &Sounding), Added<Sounding>>,
    mut removed: RemovedComponents<Sounding>,
    listener: Query<&Transform, With<Listener>>,
    rapier: Query<&RapierConfiguration>,
    sleeping: Query<&Sleeping>,
) {
    let Some(mut state) = state else {
        forces.clear();
        return;
    };
    let s = &settings.0;
    let fs = s.sample_rate_hz;
    // rapier advances a fixed step every frame, whatever the frame's clock says (Bevy's first
    // frame has no delta): the sound keeps the physics' time, else impacts land early.
    let dt = match timestep.as_deref() {
        Some(TimestepMode::Fixed { dt, .. }) => f64::from(*dt),
        _ => time.delta_secs_f64(),
    };
    let n_samples = (dt * fs).round() as usize;
    if n_samples == 0 {
        forces.clear();
        return;
    }
    let Ok(st) = state.0.get_mut() else {
        return;
    };
    // Headless, the frames are the clock; with a device, the audio side's clock plus the
    // latency (the frame's sound lands at one steady delay after it).
    let start = if s.capture {
        st.clock
    } else {
        st.tx.rendered() + s.latency_samples
    };
    st.tx.step(start);
    // A body that lost its Sounding (or was despawned) frees its source, silenced.
    for e in removed.read() {
        if let Some(i) = st.source_of.remove(&e) {
            st.radiators.remove(&i);
            st.tx.sound(i as usize, &[], &[]);
            let cap = st.capacity[i as usize];
            st.free.push((i, cap));
        }
    }
    for (e, snd) in &added {
        if st.source_of.contains_key(&e) {
            continue;
        }
        // The free source holding the most modes.
        let Some(k) = (0..st.free.len()).max_by_key(|&k| st.free[k].1) else {
            if st.unheard.insert(e) {
                eprintln!(
                    "resound: no spare source left for {e:?}; it stays silent (raise spare_sources)"
                );
            }
            continue;
        };
        let (i, cap) = st.free.swap_remove(k);
        let keep = loudest(snd, cap);
        let modes: Vec<(f64, f64)> = keep.iter().map(|&k| snd.modes[k]).collect();
        let gains: Vec<f32> = keep.iter().map(|&k| snd.gains[k]).collect();
        st.tx.sound(i as usize, &modes, &gains);
        // Its factors are sent below, before any force (the new modes cleared the old ones).
        match snd.radiator(&keep) {
            Some(r) => st.radiators.insert(i, r),
            None => st.radiators.remove(&i),
        };
        st.source_of.insert(e, i);
        listen(&mut commands, e);
    }
    let heard_at = listener.iter().next().map(|t| t.translation);
    if let Some(p) = heard_at {
        st.tx.send(Cue::Listener {
            position: p.to_array(),
        });
    }
    // Radiation: each radiating body's factors when the listener, seen from it, has turned or
    // moved enough (before the forces, which they scale).
    let link = &mut *st;
    for (e, &i) in &link.source_of {
        let (Some(r), Ok((_, t, ..))) = (link.radiators.get_mut(&i), bodies.get(*e)) else {
            continue;
        };
        if let Some(f) = r.update(in_body_frame(t, heard_at.unwrap_or(Vec3::ZERO))) {
            if !link.tx.radiation(i as usize, f) {
                r.invalidate();
            }
        }
    }
    for (&e, &i) in &st.source_of {
        if let Ok((_, t, ..)) = bodies.get(e) {
            st.tx.send(Cue::Place {
                source: i,
                position: t.translation.to_array(),
            });
        }
    }
    let link = &mut *st;
    // rapier reports each substep's contact forces: a pair's impulse over the frame is their
    // sum times the substep, its mean normal force that over the frame.
    let substeps = match timestep.as_deref() {
        Some(
            TimestepMode::Fixed { substeps, .. }
            | TimestepMode::Variable { substeps, .. }
            | TimestepMode::Interpolated { substeps, .. },
        ) => (*substeps).max(1),
        None => 1,
    };
    let dt_sub = dt / substeps as f64;
    let mut frame = std::mem::take(&mut link.frame);
    frame.clear();
    for f in forces.read() {
        let key = if f.collider1 < f.collider2 {
            (f.collider1, f.collider2)
        } else {
            (f.collider2, f.collider1)
        };
        let j = f64::from(f.total_force_magnitude) * dt_sub;
        let e = frame.entry(key).or_insert((0.0, Vec3::ZERO, 0.0, 0));
        e.0 += j;
        e.3 += 1;
        if f.max_force_magnitude >= e.2 {
            e.2 = f.max_force_magnitude;
            e.1 = f.max_force_direction;
            if e.1 == Vec3::ZERO {
                e.1 = f.total_force;
            }
        }
    }
    let mut now = std::mem::take(&mut link.spare);
    now.clear();
    link.loss.iter_mut().for_each(|l| *l = 0.0);
    let gravity = rapier
        .iter()
        .next()
        .map_or(9.81, |c| f64::from(c.gravity.length()));
    for (&key, &(impulse, direction, _, reports)) in &frame {
        let (Some(a), Some(b)) = (contact_side(&bodies, key.0), contact_side(&bodies, key.1))
        else {
            continue;
        };
        // The force while in touch: over the substeps the pair was reported in (a body that
        // falls asleep mid-frame is reported in the first few only).
        let normal_force = impulse / (f64::from(reports.clamp(1, substeps as u32)) * dt_sub);
        // The contact normal, from the first body towards the second.
        let mut n = direction.normalize_or_zero();
        if n.dot(b.position - a.position) < 0.0 {
            n = -n;
        }
        let targets = [key.0, key.1].map(|e| link.source_of.get(&e).copied());
        let (mut pair, first) = match link.touching.remove(&key) {
            Some((p, _)) => (p, false),
            None => (PairContact::new(pair_offset(key)), true),
        };
        if first {
            let before = |e: Entity, now: Vec3| link.before.get(&e).map_or(now, |v| v.linear);
            let (b0, b1) = (before(key.0, a.linvel), before(key.1, b.linvel));
            let approach = f64::from((b0 - b1).dot(n));
            // The impulse from the pair's momentum change over the frame (the solver's force
            // reports, summed over substeps, also carry position correction); the reported
            // one where a mass is unknown.
            let m_eff = if a.contact.mass_kg.is_infinite() {
                b.contact.mass_kg
            } else if b.contact.mass_kg.is_infinite() {
                a.contact.mass_kg
            } else {
                a.contact.mass_kg * b.contact.mass_kg / (a.contact.mass_kg + b.contact.mass_kg)
            };
            let dv = f64::from(((b0 - b1) - (a.linvel - b.linvel)).dot(n));
            let impulse = if m_eff.is_finite() && dv > 0.0 {
                m_eff * dv
            } else {
                impulse
            };
            if is_impact(approach) {
                if let Some((pulse, scale, at)) =
                    impact_pulse([a.contact, b.contact], approach, impulse, 0.0, fs)
                {
                    for i in targets.into_iter().flatten() {
                        link.tx.force(i as usize, 0, &pulse, scale, at);
                    }
                    output.impacts.push((link.clock as f64 / fs, key.0, key.1));
                    output.impact_figures.push((approach, impulse));
                }
            }
        } else if is_leaving(f64::from((a.linvel - b.linvel).dot(n))) {
            // An impact's rebound: neither damps nor rubs.
        } else {
            // Contact damping, as offline: each sounding side takes on a share of the pair's
            // loss factor.
            add_loss(&mut link.loss, targets, [&a, &b], normal_force, gravity);
            // The contact points' velocities, each at its contact radius along the normal.
            let at_contact = |s: &Side, r: Vec3| s.linvel + s.angvel.cross(r);
            let va = at_contact(&a, n * a.contact.radius_m as f32);
            let vb = at_contact(&b, -n * b.contact.radius_m as f32);
            let rel = va - vb;
            let slip = f64::from((rel - n * rel.dot(n)).length());
            let tangential = |s: &Side| {
                if s.contact.mass_kg.is_infinite() {
                    0.0
                } else {
                    f64::from((s.linvel - n * s.linvel.dot(n)).length())
                }
            };
            let moving = tangential(&a).max(tangential(&b));
            if let Some((kind, speed)) = classify_persistent(slip, moving, normal_force) {
                let roller = if a.contact.mass_kg.is_infinite() {
                    &b
                } else {
                    &a
                };
                link.force.resize(n_samples, 0.0);
                pair.continuous(
                    kind,
                    &link.profile,
                    normal_force,
                    speed,
                    roller.contact.radius_m,
                    fs,
                    &mut link.force[..n_samples],
                );
                for i in targets.into_iter().flatten() {
                    link.tx
                        .force(i as usize, 0, &link.force[..n_samples], 1.0, 0);
                }
                match kind {
                    ContactKind::Sliding => output.sliding_steps += 1,
                    _ => output.rolling_steps += 1,
                }
            }
        }
        now.insert(key, (pair, normal_force));
    }
    // rapier reports no forces for a body asleep, though it still rests where it lay: a pair
    // whose moving bodies all sleep stays in touch and keeps damping them.
    // (rapier zeroes a sleeping body's velocity, which bevy_rapier writes back.)
    let asleep = |e: Entity| {
        contact_side(&bodies, e).is_some_and(|s| {
            s.contact.mass_kg.is_infinite() || (s.linvel == Vec3::ZERO && s.angvel == Vec3::ZERO)
        }) || sleeping.get(e).is_ok_and(|s| s.sleeping)
    };
    for (key, (pair, normal_force)) in link.touching.drain() {
        if !(asleep(key.0) && asleep(key.1)) {
            continue;
        }
        let (Some(a), Some(b)) = (contact_side(&bodies, key.0), contact_side(&bodies, key.1))
        else {
            continue;
        };
        let targets = [key.0, key.1].map(|e| link.source_of.get(&e).copied());
        add_loss(&mut link.loss, targets, [&a, &b], normal_force, gravity);
        now.insert(key, (pair, normal_force));
    }
    link.spare = std::mem::replace(&mut link.touching, now);
    link.frame = frame;
    // Contact damping sent as the offline scene sends it; an immovable body is held by its
    // mounting and keeps its own loss factor.
    for (&e, &i) in &link.source_of {
        let (Some(side), Some(&eta), Some(sent)) = (
            contact_side(&bodies, e),
            link.loss.get(i as usize),
            link.sent_loss.get_mut(i as usize),
        ) else {
            continue;
        };
        let eta = if side.contact.mass_kg.is_infinite() {
            side.loss
        } else {
            eta
        }
        .min(MAX_CONTACT_LOSS);
        if loss_changed(eta, *sent)
            && link.tx.send(Cue::Damping {
                source: i,
                loss_factor: eta as f32,
            })
        {
            *sent = eta;
        }
    }
    // Every rigid body reports its velocity and mass from the next frame on: a body without a
    // Sounding still brings its approach speed and mass to a contact.
    for e in &unmeasured {
        commands
            .entity(e)
            .insert_if_new((Velocity::default(), ReadMassProperties::default()));
    }
    link.before.clear();
    for (e, _, v, ..) in &bodies {
        if let Some(v) = v {
            link.before.insert(e, *v);
        }
    }
    if s.capture {
        if let Some(audio) = st.audio.as_mut() {
            let channels = audio.channels();
            if output.channels.len() != channels {
                output.channels = vec![Vec::new(); channels];
            }
            let start = output.channels[0].len();
            for c in &mut output.channels {
                c.resize(start + n_samples, 0.0);
            }
            match output.channels.as_mut_slice() {
                [a] => audio.process(&mut [&mut a[start..]]),
                [a, b] => audio.process(&mut [&mut a[start..], &mut b[start..]]),
                _ => {}
            }
        }
    }
    st.clock += n_samples as u64;
}

/// What the plugin reads of a body in contact.
type BodyParts = (
    Entity,
    &'static Transform,
    Option<&'static Velocity>,
    Option<&'static ReadMassProperties>,
    Option<&'static RigidBody>,
    Option<&'static Collider>,
    Option<&'static ColliderMassProperties>,
    Option<&'static Sounding>,
);

/// Adds a pair's contact damping ([`contact_loss`]) to each sounding side's loss factor
/// (`targets`: the sides' sources).
fn add_loss(
    loss: &mut [f64],
    targets: [Option<u32>; 2],
    sides: [&Side; 2],
    normal_force: f64,
    gravity: f64,
) {
    for (k, t) in targets.iter().enumerate() {
        let (me, other) = (sides[k], sides[1 - k]);
        if let Some(l) = t.and_then(|i| loss.get_mut(i as usize)) {
            let weight = me.contact.mass_kg * gravity;
            *l += contact_loss(me.loss, other.loss, normal_force, weight);
        }
    }
}

/// One side of a contact: what the shared contact model needs, and its motion.
struct Side {
    contact: ContactBody,
    /// Its own contact loss factor ([`Sounding::contact_loss`]).
    loss: f64,
    position: Vec3,
    linvel: Vec3,
    angvel: Vec3,
}

fn contact_side(bodies: &Query<BodyParts>, e: Entity) -> Option<Side> {
    let (_, t, v, mass, rb, collider, props, snd) = bodies.get(e).ok()?;
    // A collider without a rigid body is static in rapier.
    let dynamic = matches!(rb, Some(RigidBody::Dynamic));
    // rapier's mass, else the collider's (a body spawned this frame has none reported yet);
    // a body with neither is taken as immovable.
    let from_collider = || {
        let c = collider?;
        let m = match props.copied().unwrap_or_default() {
            ColliderMassProperties::Density(d) => c.raw.mass_properties(d).mass(),
            ColliderMassProperties::Mass(m) => m,
            ColliderMassProperties::MassProperties(p) => p.mass,
        };
        (m > 0.0).then_some(f64::from(m))
    };
    let mass_kg = match (dynamic, mass) {
        (false, _) => f64::INFINITY,
        (true, Some(m)) if m.get().mass > 0.0 => f64::from(m.get().mass),
        (true, _) => from_collider().unwrap_or(f64::INFINITY),
    };
    let radius_m = collider.map_or(0.01, |c| match c.as_ball() {
        Some(b) => f64::from(b.radius()).max(1e-4),
        None => {
            let e = c.raw.compute_local_aabb().extents();
            radius_from_extents([e.x, e.y, e.z].map(f64::from))
        }
    });
    let v = v.copied().unwrap_or_default();
    Some(Side {
        contact: ContactBody {
            mass_kg,
            radius_m,
            elastic: snd.map_or(SILENT_ELASTIC, |s| s.elastic),
        },
        loss: snd.map_or(resound::physics::DEFAULT_CONTACT_LOSS, |s| s.contact_loss),
        position: t.translation,
        linvel: v.linear,
        angvel: v.angular,
    })
}

/// Where a pair starts along the rough profile (pairs do not rub in unison), m.
fn pair_offset(key: (Entity, Entity)) -> f64 {
    (key.0.index_u32() as f64 * 7.31 + key.1.index_u32() as f64 * 3.17) % 10.0
}

/// A headless scene for examples and tests: a fixed table and `heights.len()` bars of the
/// given sound dropped from those heights (m), heard from 0.5 m above the table.
pub mod drop_scene {
    use super::*;
    use std::time::Duration;

    /// Frames per second of the headless app.
    pub const FPS: f64 = 60.0;

    /// Half extents of the dropped bars, m.
    pub const BAR: [f32; 3] = [0.05, 0.015, 0.0025];

    /// An app with MinimalPlugins (no window, no device), rapier at a fixed 1/60 s per frame
    /// (4 substeps), the plugin, a table and the bars.
    pub fn app(sound: &Sounding, heights: &[f32]) -> App {
        let mut app = App::new();
        app.add_plugins((
            MinimalPlugins,
            TransformPlugin,
            RapierPhysicsPlugin::<NoUserData>::default(),
            ResoundPlugin::default(),
        ))
        .insert_resource(TimestepMode::Fixed {
            dt: (1.0 / FPS) as f32,
            substeps: 4,
        })
        .insert_resource(bevy::time::TimeUpdateStrategy::ManualDuration(
            Duration::from_secs_f64(1.0 / FPS),
        ));
        let world = app.world_mut();
        world.spawn((
            Transform::from_xyz(0.0, -0.05, 0.0),
            RigidBody::Fixed,
            Collider::cuboid(1.0, 0.05, 1.0),
            Restitution::coefficient(0.3),
        ));
        world.spawn((Transform::from_xyz(0.0, 0.5, 0.3), Listener));
        for (i, &h) in heights.iter().enumerate() {
            spawn_bar(world, sound, -0.3 + 0.3 * i as f32, h);
        }
        app.finish();
        app
    }

    /// Spawns a bar of `sound` with its lowest face `h` m above the table at `x` (m), before
    /// or while the app runs.
    pub fn spawn_bar(world: &mut World, sound: &Sounding, x: f32, h: f32) -> Entity {
        world
            .spawn((
                Transform::from_xyz(x, h + BAR[1], 0.0),
                RigidBody::Dynamic,
                Collider::cuboid(BAR[0], BAR[1], BAR[2]),
                ColliderMassProperties::Density(2700.0),
                Restitution::coefficient(0.3),
                sound.clone(),
            ))
            .id()
    }

    /// The headless example: the material of `recording` (first strike, 100 Hz high-pass) is
    /// estimated on a stand-in aluminium bar of the dropped bars' size; three bars of it fall
    /// onto the table for 2 s; the sound (peak at −1 dB) goes to `out` (24-bit WAV). Returns
    /// the material and the output.
    pub fn estimate_and_drop(
        recording: &std::path::Path,
        out: &std::path::Path,
    ) -> resound::Result<(resound::core::SoundMaterial, ResoundOutput)> {
        use resound::material::{estimate_material, EstimateMaterialParams};
        let params = resound::signal::AnalyzeParams {
            highpass_hz: Some(100.0),
            strike: Some(0),
            ..Default::default()
        };
        let (_, analysis) = resound::recording::analyze_file(
            recording,
            &resound::recording::RecordingParams::default(),
            &params,
        )?;
        let size = BAR.map(|h| 2.0 * f64::from(h));
        let bar = resound::fem::primitive::bar(size);
        let aluminium = resound::core::Material::preset("aluminium")?;
        let model = resound::modal::ModalBuilder::surface(&bar, &aluminium)
            .modes(40)
            .solve()?
            .model;
        let hit = model.hit([0.3 * size[0], 0.5 * size[1], 0.5 * size[2]])?;
        let (material, _) = estimate_material(
            &analysis,
            &model,
            &hit,
            &EstimateMaterialParams::default(),
            &|_| {},
        )?;
        let sound = Sounding::from_material(&model, &material, 0, 48_000.0);
        let mut app = app(&sound, &[0.2, 0.35, 0.5]);
        let output = run(&mut app, 2.0);
        let peak = output
            .channels
            .iter()
            .flat_map(|c| c.iter())
            .fold(0.0f32, |m, v| m.max(v.abs()));
        if !(peak > 0.0 && peak.is_finite()) {
            return Err(resound::Error::Invalid(format!(
                "the scene is silent or not finite (peak {peak})"
            )));
        }
        let g = 0.891 / peak;
        let levelled: Vec<Vec<f32>> = output
            .channels
            .iter()
            .map(|c| c.iter().map(|v| v * g).collect())
            .collect();
        let refs: Vec<&[f32]> = levelled.iter().map(|c| c.as_slice()).collect();
        resound::io::write_wav_channels(
            out,
            &refs,
            output.sample_rate_hz as u32,
            resound::io::WavFormat::Pcm24,
        )?;
        Ok((material, output))
    }

    /// Runs `app` for `seconds` and returns what the plugin rendered.
    pub fn run(app: &mut App, seconds: f64) -> ResoundOutput {
        for _ in 0..(seconds * FPS).round() as usize {
            app.update();
        }
        app.world().resource::<ResoundOutput>().clone()
    }
}
