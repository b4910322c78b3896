//! The simulation loop: rapier steps, contact classification, excitation, rendering.

mod bodies;
mod tracker;
mod vertex_grid;

use bodies::*;
pub use bodies::{body_containing, check_start_overlaps};
use tracker::*;
use vertex_grid::*;

use crate::contact::{
    classify_persistent, contact_loss, impact_pulse, is_impact, is_leaving, loss_changed,
    radius_from_extents, scene_profile, ContactBody, ContactKind, PairContact, MAX_CONTACT_LOSS,
    SILENT_ELASTIC,
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
/// Longest propagation delay, s (sources beyond 343 m are held there).
const MAX_DELAY_S: f64 = 1.0;
/// Longest impact pulse the tracker makes, samples (queue sizing).
const FORCE_PULSE_SAMPLES: usize = 2048;

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
            if !loss_changed(eta, *sent) {
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
/// after. `progress` hears [`Stage::Simulating`](resound_core::progress::Stage) and the
/// simulated fraction now and then.
pub fn simulate(
    bodies: &[BodySpec],
    params: &SceneParams,
    progress: resound_core::progress::ProgressFn<'_>,
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
            progress(resound_core::progress::Progress::fraction(
                resound_core::progress::Stage::Simulating,
                frac,
            ));
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
