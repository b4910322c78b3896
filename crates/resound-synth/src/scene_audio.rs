//! The audio side of a scene, offline and live alike: sounding bodies as attached voices of
//! one [`Engine`], recorded-grain players, and the [`Spatializer`], fed by the physics side
//! through two lock-free queues.
//!
//! - [`scene_audio`] builds a [`SceneAudio`] (the backend: an audio callback or the offline
//!   renderer) and a [`CueSender`] (the physics thread or game loop). Everything is allocated
//!   there; [`SceneAudio::process`] never allocates, locks or blocks (tested with
//!   `assert_no_alloc`).
//! - The physics side sends each step's [`Cue`]s after a [`Cue::Step`] that says at which
//!   sample of the output they take effect: body positions, forces (their samples go through a
//!   second queue of `f32`, so no cue owns memory the callback would have to free), grain
//!   impacts and continuous contacts. The backend renders up to each step's start, applies its
//!   cues, and renders on, so the output does not depend on how the device cuts it into
//!   blocks — only voice culling and the voice budget act on rendered blocks.
//! - A step whose cues arrive after its start sample (the physics fell behind) is applied at
//!   once, its forces shifted by the lateness, and counted in [`AudioStats::late_steps`].
//! - Overload ([`Governor`], live only): the callback times itself against its block's
//!   deadline; above a share of it, it first raises the modes' cull level tenfold (modes are
//!   dropped by audibility), then halves the voices it renders (the quietest fade out over a
//!   block: voice stealing by loudness); well below it, it steps back.

use crate::air::Air;
use crate::bank::BankMode;
use crate::engine::{Engine, EngineParams, VoiceId};
use crate::spatial::{FloorReflection, Spatializer};
use crate::SynthError;
use resound_grains::player::GrainPlayer;
use resound_grains::Contact;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// One sounding body.
#[derive(Debug)]
pub struct Source {
    /// Damped frequency (Hz) and decay rate (1/s) of each mode (may be empty: grains only).
    pub modes: Vec<(f64, f64)>,
    /// Gain (output amplitude per N·s) of each mode at each surface vertex, vertex-major.
    pub gains: Vec<f32>,
    /// A recorded-grain player, besides or instead of the modes.
    pub grains: Option<GrainPlayer>,
    /// Where it starts, m.
    pub position: [f64; 3],
    /// Each mode's radiation factor at the listener as it starts (one per mode, see
    /// [`Cue::Radiation`]; empty: every mode radiates alike). Later factors come as cues.
    pub radiation: Vec<f32>,
}

/// Settings of [`scene_audio`].
#[derive(Clone, Debug, PartialEq)]
pub struct SceneAudioParams {
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Two channels (left/right along x) instead of one.
    pub stereo: bool,
    /// Listener position, m.
    pub listener: [f64; 3],
    /// Longest propagation delay, s.
    pub max_delay_s: f64,
    /// Longest stretch rendered at once, samples (at least a physics step and a device block).
    pub max_block: usize,
    /// Force ring per voice, samples (the longest force scheduled ahead).
    pub force_capacity: usize,
    /// Modes quieter than this (output amplitude) with no force coming are culled.
    pub cull_level: f32,
    /// Cues the queue holds.
    pub cue_capacity: usize,
    /// Force samples the queue holds.
    pub sample_capacity: usize,
    /// Overload handling (live); `None` renders everything, whatever it costs (offline).
    pub governor: Option<Governor>,
    /// Air absorption (ISO 9613-1) of each mode over its distance to the listener, applied
    /// as it is excited; `None`: none.
    pub air: Option<Air>,
    /// A floor reflection (an image source per body); `None`: free field.
    pub reflection: Option<FloorReflection>,
    /// Four channels of first-order ambisonics (AmbiX) instead of `stereo`'s one or two.
    pub ambisonics: bool,
}

/// When the live callback degrades (shares of its block's deadline).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Governor {
    /// Above this share a callback steps up the degradation.
    pub high: f64,
    /// Below this share for `calm_callbacks` callbacks in a row it steps back.
    pub low: f64,
    /// See `low`.
    pub calm_callbacks: u32,
}

impl Default for Governor {
    fn default() -> Self {
        Self {
            high: 0.7,
            low: 0.35,
            calm_callbacks: 200,
        }
    }
}

/// What the physics side tells the audio side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Cue {
    /// The cues that follow (up to the next `Step`) take effect at output sample `start`.
    Step {
        /// Output sample.
        start: u64,
    },
    /// A body is now here (m).
    Place {
        /// Source index (as given to [`scene_audio`]).
        source: u32,
        /// Position, m.
        position: [f32; 3],
    },
    /// `len` force samples (N per sample, times `scale`; they are in the sample queue) on a
    /// body at surface vertex `vertex`, from `delay` samples after the step's start.
    Force {
        /// Source index.
        source: u32,
        /// Surface vertex whose gains apply.
        vertex: u32,
        /// Samples in the sample queue.
        len: u32,
        /// Samples after the step's start.
        delay: u32,
        /// Scale of the samples.
        scale: f64,
    },
    /// An impact for a body's grain player, its force peak `delay` samples after the step's
    /// start.
    GrainImpact {
        /// Source index.
        source: u32,
        /// Samples after the step's start.
        delay: u32,
        /// Impulse, N·s.
        impulse_n_s: f64,
    },
    /// A body's continuous contact from the step on: kind, power (W), speed (m/s).
    GrainContact {
        /// Source index.
        source: u32,
        /// The contact, or none.
        contact: Option<(Contact, f64, f64)>,
    },
    /// The listener is now here (m).
    Listener {
        /// Position, m.
        position: [f32; 3],
    },
    /// A body's contact damping from now on: the added loss factor η of its modes (each
    /// decays `π f η` 1/s faster; 0: free, its material's damping only).
    Damping {
        /// Source index.
        source: u32,
        /// Loss factor η.
        loss_factor: f32,
    },
    /// A source takes new modes: `modes` triples (frequency Hz, decay rate 1/s, gain per N·s
    /// at one point) in the sample queue; at most the modes the source was built with (its
    /// voice's capacity). Zero modes silence it. See [`CueSender::sound`].
    Sound {
        /// Source index.
        source: u32,
        /// Modes (triples in the sample queue).
        modes: u32,
    },
    /// A source's radiation factors from now on: `modes` values (one per mode, in its
    /// order) in the sample queue, each scaling that mode's gains as forces enter
    /// ([`crate::radiation`]). Zero modes: no radiation model (every mode radiates alike).
    /// See [`CueSender::radiation`].
    Radiation {
        /// Source index.
        source: u32,
        /// Factors in the sample queue.
        modes: u32,
    },
}

/// Counters shared by both sides (relaxed atomics: statistics only).
#[derive(Debug, Default)]
pub struct AudioStats {
    /// Calls of [`SceneAudio::process`].
    pub callbacks: AtomicU64,
    /// Samples rendered (the audio clock).
    pub rendered: AtomicU64,
    /// Cues applied.
    pub cues: AtomicU64,
    /// Cues the queues had no room for (the sender counts them).
    pub dropped: AtomicU64,
    /// Cues naming no source, or forces whose samples were missing.
    pub rejected: AtomicU64,
    /// Steps whose cues came after their start sample.
    pub late_steps: AtomicU64,
    /// Callbacks that took longer than their block lasts (the clock or driver counts them).
    pub xruns: AtomicU64,
    /// Most voices rendering at once.
    pub max_sounding: AtomicU64,
    /// Voices faded out by the overload budget.
    pub steals: AtomicU64,
    /// Current degradation level (0: none).
    pub degradation: AtomicU64,
}

impl AudioStats {
    fn bump(c: &AtomicU64) {
        c.fetch_add(1, Ordering::Relaxed);
    }

    /// Reads a counter.
    pub fn get(c: &AtomicU64) -> u64 {
        c.load(Ordering::Relaxed)
    }
}

/// The physics side's end of the queues.
pub struct CueSender {
    cues: rtrb::Producer<Cue>,
    samples: rtrb::Producer<f32>,
    stats: Arc<AudioStats>,
}

impl CueSender {
    /// Sends a cue; false (counted as dropped) when the queue is full. Never blocks.
    pub fn send(&mut self, cue: Cue) -> bool {
        if self.cues.push(cue).is_ok() {
            true
        } else {
            AudioStats::bump(&self.stats.dropped);
            false
        }
    }

    /// Sends a step's start.
    pub fn step(&mut self, start: u64) -> bool {
        self.send(Cue::Step { start })
    }

    /// Writes `n` samples of a cue that follows them, when there is room for both the samples
    /// and the cue; false (counted as dropped, nothing written) otherwise.
    fn write_samples(&mut self, n: usize, values: impl Iterator<Item = f32>) -> bool {
        if self.cues.slots() == 0 || self.samples.slots() < n {
            AudioStats::bump(&self.stats.dropped);
            return false;
        }
        match self.samples.write_chunk_uninit(n) {
            Ok(chunk) => {
                chunk.fill_from_iter(values);
                true
            }
            Err(_) => {
                AudioStats::bump(&self.stats.dropped);
                false
            }
        }
    }

    /// Sends a force (its samples first, then its cue); false (dropped) when either queue is
    /// full.
    pub fn force(
        &mut self,
        source: usize,
        vertex: usize,
        force: &[f32],
        scale: f64,
        delay: usize,
    ) -> bool {
        if !self.write_samples(force.len(), force.iter().copied()) {
            return false;
        }
        self.send(Cue::Force {
            source: source as u32,
            vertex: vertex as u32,
            len: force.len() as u32,
            delay: delay as u32,
            scale,
        })
    }

    /// Gives `source` new modes `(frequency Hz, decay rate 1/s)` with `gains` (per N·s at one
    /// point): a body that starts sounding after the audio side was built (a spawned game
    /// object) takes a spare source. False (dropped) when a queue is full.
    pub fn sound(&mut self, source: usize, modes: &[(f64, f64)], gains: &[f32]) -> bool {
        let m = modes.len().min(gains.len());
        let triples = modes
            .iter()
            .zip(gains)
            .flat_map(|(&(f, d), &g)| [f as f32, d as f32, g]);
        if !self.write_samples(3 * m, triples) {
            return false;
        }
        self.send(Cue::Sound {
            source: source as u32,
            modes: m as u32,
        })
    }

    /// Gives `source` per-mode radiation factors (one per mode; empty: none), as
    /// [`crate::radiation::Radiator::update`] computes them. False (dropped) when a queue is
    /// full.
    pub fn radiation(&mut self, source: usize, factors: &[f32]) -> bool {
        if !self.write_samples(factors.len(), factors.iter().copied()) {
            return false;
        }
        self.send(Cue::Radiation {
            source: source as u32,
            modes: factors.len() as u32,
        })
    }

    /// Samples the backend has rendered (its clock).
    pub fn rendered(&self) -> u64 {
        AudioStats::get(&self.stats.rendered)
    }

    /// Free cue slots.
    pub fn free_cues(&self) -> usize {
        self.cues.slots()
    }

    /// The shared counters.
    pub fn stats(&self) -> &Arc<AudioStats> {
        &self.stats
    }
}

/// The audio side: renders the scene's sound block by block (see the module docs).
pub struct SceneAudio {
    engine: Engine,
    voices: Vec<Option<VoiceId>>,
    tables: Vec<Vec<f32>>,
    /// Per source, each mode's air absorption, nepers per metre (capacity: a voice's modes).
    air_np: Vec<Vec<f32>>,
    air: Option<Air>,
    /// Per source, each mode's radiation factor (capacity: a voice's modes; empty: none).
    radiation: Vec<Vec<f32>>,
    modes: Vec<usize>,
    gains: Vec<f64>,
    players: Vec<Option<GrainPlayer>>,
    positions: Vec<[f64; 3]>,
    spatializer: Spatializer,
    cues: rtrb::Consumer<Cue>,
    samples: rtrb::Consumer<f32>,
    stats: Arc<AudioStats>,
    scratch: Vec<f32>,
    /// Modes of a `Sound` cue (capacity: a voice's modes).
    bank: Vec<BankMode>,
    max_block: usize,
    sample_rate_hz: f64,
    clock: u64,
    /// Lateness of the current step's cues, samples.
    late: u64,
    governor: Option<Governor>,
    level: u32,
    calm: u32,
    base_cull: f32,
}

/// Builds the audio side for `sources` and the physics side's sender.
///
/// # Errors
/// [`SynthError::Parameter`] for unusable settings or a source whose gain table does not
/// match its modes.
pub fn scene_audio(
    params: &SceneAudioParams,
    sources: Vec<Source>,
) -> Result<(CueSender, SceneAudio), SynthError> {
    if sources.len() > u32::MAX as usize || params.cue_capacity == 0 {
        return Err(SynthError::Parameter(
            "scene audio: too many sources or no cue queue".into(),
        ));
    }
    let modal = sources.iter().filter(|s| !s.modes.is_empty()).count();
    let mut engine = Engine::new(EngineParams {
        sample_rate_hz: params.sample_rate_hz,
        voices: modal.max(1),
        modes_per_voice: sources
            .iter()
            .map(|s| s.modes.len())
            .max()
            .unwrap_or(0)
            .max(1),
        force_capacity: params.force_capacity,
        inputs: crate::bank::INPUTS,
        cull_level: params.cull_level,
        max_block: params.max_block,
    })?;
    let mut voices = Vec::with_capacity(sources.len());
    let mut tables = Vec::with_capacity(sources.len());
    let mut air_np = Vec::with_capacity(sources.len());
    let mut modes = Vec::with_capacity(sources.len());
    if params.air.is_some_and(|a| !a.is_valid()) {
        return Err(SynthError::Parameter(format!(
            "air: temperature −40…60 °C, humidity 0–100 %, pressure 50–110 kPa; got {:?}",
            params.air
        )));
    }
    let modes_cap = sources
        .iter()
        .map(|s| s.modes.len())
        .max()
        .unwrap_or(0)
        .max(1);
    let mut players = Vec::with_capacity(sources.len());
    let mut radiation = Vec::with_capacity(sources.len());
    let mut positions = Vec::with_capacity(sources.len());
    for (i, s) in sources.into_iter().enumerate() {
        let m = s.modes.len();
        if m > 0 && (s.gains.is_empty() || s.gains.len() % m != 0) {
            return Err(SynthError::Parameter(format!(
                "source {i}: {} gains are not a whole number of vertices × {m} modes",
                s.gains.len()
            )));
        }
        voices.push(if m > 0 {
            let bank: Vec<BankMode> = s
                .modes
                .iter()
                .enumerate()
                .map(|(j, &(f, d))| BankMode {
                    freq_hz: f,
                    damping_per_s: d,
                    gain: f64::from(s.gains[j]),
                })
                .collect();
            Some(engine.attach(&bank, i)?)
        } else {
            None
        });
        let mut np = Vec::with_capacity(modes_cap);
        np.extend(
            s.modes
                .iter()
                .map(|&(f, _)| air_nepers_per_m(params.air, f)),
        );
        air_np.push(np);
        if !s.radiation.is_empty() && s.radiation.len() != m {
            return Err(SynthError::Parameter(format!(
                "source {i}: {} radiation factors for {m} modes",
                s.radiation.len()
            )));
        }
        let mut rad = Vec::with_capacity(modes_cap);
        rad.extend(s.radiation.iter().map(|&f| sane_factor(f)));
        radiation.push(rad);
        modes.push(m);
        tables.push(s.gains);
        players.push(s.grains);
        positions.push(s.position);
    }
    let mut spatializer = Spatializer::new(
        params.sample_rate_hz,
        params.stereo,
        params.listener,
        params.max_delay_s,
        params.max_block,
    )?;
    if params.ambisonics {
        spatializer = spatializer.into_ambisonics();
    }
    // Voices as sources 0..n, grain players as n..2n (each glides on its own).
    spatializer.track_sources(2 * positions.len());
    if !spatializer.set_reflection(params.reflection) {
        return Err(SynthError::Parameter(format!(
            "floor reflection: a finite height and a coefficient in [0, 1], got {:?}",
            params.reflection
        )));
    }
    let (ctx, crx) = rtrb::RingBuffer::new(params.cue_capacity);
    let (stx, srx) = rtrb::RingBuffer::new(params.sample_capacity.max(1));
    let stats = Arc::new(AudioStats::default());
    let modes_per_voice = engine.params().modes_per_voice;
    let gains = vec![0.0; modes_per_voice];
    Ok((
        CueSender {
            cues: ctx,
            samples: stx,
            stats: Arc::clone(&stats),
        },
        SceneAudio {
            engine,
            voices,
            tables,
            air_np,
            air: params.air,
            radiation,
            modes,
            gains,
            players,
            positions,
            spatializer,
            cues: crx,
            samples: srx,
            stats,
            scratch: vec![0.0; params.max_block],
            bank: Vec::with_capacity(modes_per_voice),
            max_block: params.max_block,
            sample_rate_hz: params.sample_rate_hz,
            clock: 0,
            late: 0,
            governor: params.governor,
            level: 0,
            calm: 0,
            base_cull: params.cull_level,
        },
    ))
}

impl SceneAudio {
    /// Output channels (1 or 2).
    pub fn channels(&self) -> usize {
        self.spatializer.channels()
    }

    /// Samples rendered so far.
    pub fn clock(&self) -> u64 {
        self.clock
    }

    /// The shared counters.
    pub fn stats(&self) -> &Arc<AudioStats> {
        &self.stats
    }

    /// The engine (to inspect voices).
    pub fn engine(&self) -> &Engine {
        &self.engine
    }

    /// Renders the next `out[0].len()` samples, adding them into `out` (one slice per
    /// channel, all of one length). Never allocates, locks or blocks.
    pub fn process(&mut self, out: &mut [&mut [f32]]) {
        let t0 = self.governor.map(|_| Instant::now());
        let n = out.first().map_or(0, |o| o.len());
        let mut done = 0;
        while done < n {
            let pos = self.clock;
            self.apply_due(pos);
            let mut end = pos + (n - done).min(self.max_block) as u64;
            if let Ok(&Cue::Step { start }) = self.cues.peek() {
                if start > pos && start < end {
                    end = start;
                }
            }
            let len = (end - pos) as usize;
            self.render(out, done, len);
            done += len;
            self.clock = end;
        }
        self.stats.rendered.store(self.clock, Ordering::Relaxed);
        AudioStats::bump(&self.stats.callbacks);
        if let (Some(g), Some(t0)) = (self.governor, t0) {
            let share = t0.elapsed().as_secs_f64() / (n.max(1) as f64 / self.sample_rate_hz);
            self.govern(g, share);
        }
    }

    /// Applies every cue due at output sample `pos`.
    fn apply_due(&mut self, pos: u64) {
        loop {
            let cue = match self.cues.peek() {
                Ok(&Cue::Step { start }) if start > pos => return,
                Ok(&c) => c,
                Err(_) => return,
            };
            let _ = self.cues.pop();
            match cue {
                Cue::Step { start } => {
                    self.late = pos - start;
                    if self.late > 0 {
                        AudioStats::bump(&self.stats.late_steps);
                    }
                }
                c => {
                    let ok = self.apply(c);
                    AudioStats::bump(if ok {
                        &self.stats.cues
                    } else {
                        &self.stats.rejected
                    });
                }
            }
        }
    }

    fn apply(&mut self, cue: Cue) -> bool {
        let late = self.late as usize;
        match cue {
            Cue::Step { .. } => true,
            Cue::Place { source, position } => match self.positions.get_mut(source as usize) {
                Some(p) => {
                    *p = position.map(f64::from);
                    true
                }
                None => false,
            },
            Cue::Force {
                source,
                vertex,
                len,
                delay,
                scale,
            } => {
                let len = len as usize;
                let Ok(chunk) = self.samples.read_chunk(len) else {
                    return false;
                };
                let i = source as usize;
                let id = self.voices.get(i).copied().flatten();
                let ok = match id {
                    Some(id) if self.modes[i] > 0 => {
                        let m = self.modes[i];
                        let table = &self.tables[i];
                        let k = (vertex as usize).min(table.len() / m - 1);
                        for (g, &t) in self.gains[..m].iter_mut().zip(&table[k * m..(k + 1) * m]) {
                            *g = f64::from(t);
                        }
                        if self.air.is_some() {
                            let (p, l) = (self.positions[i], self.spatializer.listener());
                            let r = ((p[0] - l[0]).powi(2)
                                + (p[1] - l[1]).powi(2)
                                + (p[2] - l[2]).powi(2))
                            .sqrt();
                            for (g, &a) in self.gains[..m].iter_mut().zip(&self.air_np[i]) {
                                *g *= (-f64::from(a) * r).exp();
                            }
                        }
                        if !self.radiation[i].is_empty() {
                            for (g, &f) in self.gains[..m].iter_mut().zip(&self.radiation[i]) {
                                *g *= f64::from(f);
                            }
                        }
                        // Each contact point keeps its own gains while its force sounds.
                        let (a, b) = chunk.as_slices();
                        let d = (delay as usize).saturating_sub(late);
                        let g = &self.gains[..m];
                        self.engine.excite_at(id, vertex, g, a, scale, d);
                        if !b.is_empty() {
                            self.engine.excite_at(id, vertex, g, b, scale, d + a.len());
                        }
                        true
                    }
                    _ => false,
                };
                chunk.commit_all();
                ok
            }
            Cue::Listener { position } => self.spatializer.set_listener(position.map(f64::from)),
            Cue::Damping {
                source,
                loss_factor,
            } => match self.voices.get(source as usize).copied().flatten() {
                Some(id) if loss_factor.is_finite() && loss_factor >= 0.0 => {
                    self.engine.set_extra_loss(id, f64::from(loss_factor))
                }
                _ => false,
            },
            Cue::Sound { source, modes } => {
                let m = modes as usize;
                let Ok(chunk) = self.samples.read_chunk(3 * m) else {
                    return false;
                };
                let i = source as usize;
                let ok = match self.voices.get(i).copied().flatten() {
                    Some(id)
                        if m <= self.engine.params().modes_per_voice
                            && m <= self.tables[i].capacity() =>
                    {
                        let (a, b) = chunk.as_slices();
                        let mut values = a.iter().chain(b).copied();
                        self.bank.clear();
                        self.tables[i].clear();
                        self.air_np[i].clear();
                        while let (Some(f), Some(d), Some(g)) =
                            (values.next(), values.next(), values.next())
                        {
                            if self.air_np[i].len() < self.air_np[i].capacity() {
                                self.air_np[i].push(air_nepers_per_m(self.air, f64::from(f)));
                            }
                            self.bank.push(BankMode {
                                freq_hz: f64::from(f),
                                damping_per_s: f64::from(d),
                                gain: f64::from(g),
                            });
                            self.tables[i].push(g);
                        }
                        self.modes[i] = m;
                        // New modes: the old factors belong to other modes.
                        self.radiation[i].clear();
                        self.engine.reconfigure(id, &self.bank)
                    }
                    _ => false,
                };
                chunk.commit_all();
                ok
            }
            Cue::Radiation { source, modes } => {
                let m = modes as usize;
                let Ok(chunk) = self.samples.read_chunk(m) else {
                    return false;
                };
                let i = source as usize;
                let ok = match self.radiation.get_mut(i) {
                    Some(r) if (m == 0 || m == self.modes[i]) && m <= r.capacity() => {
                        let (a, b) = chunk.as_slices();
                        r.clear();
                        r.extend(a.iter().chain(b).map(|&f| sane_factor(f)));
                        true
                    }
                    _ => false,
                };
                chunk.commit_all();
                ok
            }
            Cue::GrainImpact {
                source,
                delay,
                impulse_n_s,
            } => match self.players.get_mut(source as usize) {
                Some(Some(p)) => {
                    p.impact((delay as usize).saturating_sub(late), impulse_n_s);
                    true
                }
                _ => false,
            },
            Cue::GrainContact { source, contact } => match self.players.get_mut(source as usize) {
                Some(Some(p)) => {
                    p.set_contact(contact);
                    true
                }
                _ => false,
            },
        }
    }

    fn render(&mut self, out: &mut [&mut [f32]], at: usize, len: usize) {
        let positions = &self.positions;
        let n_sources = positions.len();
        let spatializer = &mut self.spatializer;
        let mut sounding = 0u64;
        self.engine
            .process_voices(len, &mut |source, offset, block| {
                sounding += 1;
                spatializer.place_source(source, block, offset, positions[source]);
            });
        for (i, p) in self.players.iter_mut().enumerate() {
            let Some(p) = p else { continue };
            if p.is_silent() {
                continue;
            }
            let block = &mut self.scratch[..len];
            block.fill(0.0);
            p.process(block);
            sounding += 1;
            spatializer.place_source(n_sources + i, block, 0, positions[i]);
        }
        match out {
            [a] => spatializer.render(&mut [&mut a[at..at + len]]),
            [a, b, c, d, ..] => spatializer.render(&mut [
                &mut a[at..at + len],
                &mut b[at..at + len],
                &mut c[at..at + len],
                &mut d[at..at + len],
            ]),
            [a, b, ..] => spatializer.render(&mut [&mut a[at..at + len], &mut b[at..at + len]]),
            [] => {}
        }
        self.stats
            .max_sounding
            .fetch_max(sounding, Ordering::Relaxed);
    }

    /// Steps the degradation up or down after a callback that took `share` of its deadline.
    fn govern(&mut self, g: Governor, share: f64) {
        let before = self.level;
        if share > g.high && self.level < 8 {
            self.level += 1;
            self.calm = 0;
        } else if share < g.low && self.level > 0 {
            self.calm += 1;
            if self.calm >= g.calm_callbacks {
                self.level -= 1;
                self.calm = 0;
            }
        } else {
            self.calm = 0;
        }
        if self.level != before {
            // Levels 1–3 raise the cull level tenfold each; from 4 on, the voice budget halves.
            let cull_steps = self.level.min(3) as i32;
            self.engine
                .set_cull_level(self.base_cull * 10f32.powi(cull_steps));
            let voices = self.voices.iter().filter(|v| v.is_some()).count().max(1);
            let budget = if self.level <= 3 {
                usize::MAX
            } else {
                (voices >> (self.level - 3)).max(1)
            };
            self.engine.set_voice_budget(budget);
            self.stats
                .degradation
                .store(u64::from(self.level), Ordering::Relaxed);
        }
        self.stats
            .steals
            .store(self.engine.steals(), Ordering::Relaxed);
    }
}

/// A mode's air absorption at `freq_hz`, nepers (of amplitude) per metre; 0 without air.
fn air_nepers_per_m(air: Option<Air>, freq_hz: f64) -> f32 {
    air.map_or(0.0, |a| {
        (a.attenuation_db_per_m(freq_hz) * std::f64::consts::LN_10 / 20.0) as f32
    })
}

/// A radiation factor as the audio side uses it: non-finite or negative factors (which no
/// transfer gives) silence the mode rather than poison the bank.
fn sane_factor(f: f32) -> f32 {
    if f.is_finite() && f >= 0.0 {
        f
    } else {
        0.0
    }
}
