//! Voices: several sounding objects at once, with force scheduling and voice stealing.
//!
//! The fundsp-style contract: [`Engine::new`] allocates everything (voices, their banks at full
//! capacity, force rings); [`Engine::start`], [`Engine::excite`] and [`Engine::process`] never
//! allocate, lock or block, so they can run in an audio callback (tested with
//! `assert_no_alloc`).
//!
//! When every voice is busy, starting another steals the voice with the lowest priority: its
//! current level (Σ |mode amplitude|) times the caller's importance — the quietest sound goes,
//! as Raghuvanshi & Lin prioritise modes by their audible contribution.

use crate::bank::{BankMode, ModalBank};
use crate::SynthError;

/// Identifies a started voice; stale once the voice is stolen or ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct VoiceId {
    slot: usize,
    generation: u64,
}

#[derive(Debug)]
struct Voice {
    bank: ModalBank,
    /// Pending force (N per sample), a ring starting at `head`.
    force: Vec<f32>,
    head: usize,
    pending: usize,
    importance: f32,
    generation: u64,
    busy: bool,
}

/// Settings of [`Engine::new`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EngineParams {
    /// Sample rate, Hz.
    pub sample_rate_hz: f64,
    /// Voices (objects sounding at once).
    pub voices: usize,
    /// Modes per voice at most.
    pub modes_per_voice: usize,
    /// Longest force pulse that can be scheduled ahead, samples.
    pub force_capacity: usize,
    /// Modes quieter than this (output amplitude) with no force coming are culled.
    pub cull_level: f32,
}

impl Default for EngineParams {
    fn default() -> Self {
        Self {
            sample_rate_hz: 48_000.0,
            voices: 16,
            modes_per_voice: 256,
            force_capacity: 48_000,
            cull_level: 1e-6,
        }
    }
}

/// A polyphonic modal synthesizer.
#[derive(Debug)]
pub struct Engine {
    voices: Vec<Voice>,
    scratch: Vec<f32>,
    generation: u64,
    params: EngineParams,
}

impl Engine {
    /// Allocates all voices.
    pub fn new(params: EngineParams) -> Result<Self, SynthError> {
        if params.voices == 0 || params.voices > 4096 {
            return Err(SynthError::Parameter(format!(
                "voices must be in 1..=4096, got {}",
                params.voices
            )));
        }
        if params.force_capacity == 0 {
            return Err(SynthError::Parameter("force capacity must be > 0".into()));
        }
        // One by one: a clone would not keep the banks' capacity.
        let mut voices = Vec::with_capacity(params.voices);
        for _ in 0..params.voices {
            voices.push(Voice {
                bank: ModalBank::with_capacity(
                    params.sample_rate_hz,
                    params.modes_per_voice,
                    params.cull_level,
                )?,
                force: vec![0.0; params.force_capacity],
                head: 0,
                pending: 0,
                importance: 1.0,
                generation: 0,
                busy: false,
            });
        }
        Ok(Self {
            voices,
            scratch: vec![0.0; crate::MAX_BLOCK],
            generation: 0,
            params,
        })
    }

    /// Settings.
    pub fn params(&self) -> &EngineParams {
        &self.params
    }

    /// Voices currently sounding.
    pub fn busy_voices(&self) -> usize {
        self.voices.iter().filter(|v| v.busy).count()
    }

    /// Starts a voice for an object with `modes` (gains per N·s at the contact); a free voice
    /// if any, else the one with the lowest priority is stolen. `importance` weights priority.
    pub fn start(&mut self, modes: &[BankMode], importance: f32) -> Result<VoiceId, SynthError> {
        let slot = match self.voices.iter().position(|v| !v.busy) {
            Some(s) => s,
            None => {
                let mut best = 0;
                let mut lowest = f32::INFINITY;
                for (i, v) in self.voices.iter().enumerate() {
                    let p = v.bank.level() * v.importance;
                    if p < lowest {
                        lowest = p;
                        best = i;
                    }
                }
                best
            }
        };
        let v = &mut self.voices[slot];
        v.bank.configure(modes)?;
        v.head = 0;
        v.pending = 0;
        v.force.iter_mut().for_each(|f| *f = 0.0);
        v.importance = importance.max(0.0);
        self.generation += 1;
        v.generation = self.generation;
        v.busy = true;
        Ok(VoiceId {
            slot,
            generation: self.generation,
        })
    }

    /// Whether `id` still refers to a sounding voice.
    pub fn is_alive(&self, id: VoiceId) -> bool {
        let v = &self.voices[id.slot];
        v.busy && v.generation == id.generation
    }

    /// Schedules `force` (N per sample) on voice `id`, starting `delay` samples after the start
    /// of the next block. Forces add up. Returns false if the voice is gone or the pulse does not
    /// fit the force capacity.
    pub fn excite(&mut self, id: VoiceId, force: &[f32], delay: usize) -> bool {
        if !self.is_alive(id) {
            return false;
        }
        let v = &mut self.voices[id.slot];
        let cap = v.force.len();
        if delay + force.len() > cap {
            return false;
        }
        for (i, &f) in force.iter().enumerate() {
            let k = (v.head + delay + i) % cap;
            v.force[k] += f;
        }
        v.pending = v.pending.max(delay + force.len());
        true
    }

    /// Changes a voice's per-mode gains (a moving contact).
    pub fn set_gains(&mut self, id: VoiceId, gains: &[f64]) -> bool {
        if !self.is_alive(id) {
            return false;
        }
        self.voices[id.slot].bank.set_gains(gains);
        true
    }

    /// Renders the next block, adding into `out` (any length; internally in blocks of
    /// [`crate::MAX_BLOCK`]). Voices that have gone silent with no force pending are freed.
    pub fn process(&mut self, out: &mut [f32]) {
        for block in out.chunks_mut(crate::MAX_BLOCK) {
            let n = block.len();
            for v in self.voices.iter_mut().filter(|v| v.busy) {
                let cap = v.force.len();
                let x = &mut self.scratch[..n];
                for (i, xi) in x.iter_mut().enumerate() {
                    let k = (v.head + i) % cap;
                    *xi = v.force[k];
                    v.force[k] = 0.0;
                }
                v.head = (v.head + n) % cap;
                v.pending = v.pending.saturating_sub(n);
                v.bank.process(x, block);
                if v.pending == 0 && v.bank.is_silent() {
                    v.busy = false;
                }
            }
        }
    }
}
