//! Voices: several sounding objects at once, with force scheduling and voice stealing.
//!
//! The fundsp-style contract: [`Engine::new`] allocates everything (voices, their banks at full
//! capacity, force rings); [`Engine::start`], [`Engine::excite`] and [`Engine::process`] never
//! allocate, lock or block, so they can run in an audio callback (tested with
//! `assert_no_alloc`).
//!
//! A voice is driven through up to [`EngineParams::inputs`] contact inputs, each with its own
//! gains ([`Engine::excite_at`]): forces at different points of one object that overlap in time
//! each sound through the gains of their own point.
//!
//! When every voice is busy, starting another steals the voice with the lowest priority: its
//! current level (Σ |mode amplitude|) times the caller's importance — the quietest sound goes,
//! as Raghuvanshi & Lin prioritise modes by their audible contribution.

use crate::bank::{BankMode, ModalBank, INPUTS};
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
    /// Pending force (N per sample) of each input, rings of the force capacity one after the
    /// other, starting at `head`.
    force: Vec<f32>,
    /// Length of one input's ring (the force capacity).
    cap: usize,
    head: usize,
    /// Samples of force still to come (the longest of the inputs').
    pending: usize,
    /// Samples of force still to come on each input.
    input_pending: [usize; INPUTS],
    /// The key (a contact point) each input's gains belong to ([`Engine::excite_at`]).
    keys: [u32; INPUTS],
    importance: f32,
    generation: u64,
    busy: bool,
    /// Attached for good ([`Engine::attach`]): never stolen, never freed when silent.
    pinned: bool,
    /// The caller's tag ([`Engine::process_voices`] hands it back with each block).
    tag: usize,
    /// Fading out over the next block (stolen by the voice budget), then silenced.
    fading: bool,
}

/// Renders a voice's block: through input 0 alone on the bank's single-input path (the common
/// case), else through every input that carries force.
fn render(bank: &mut ModalBank, forces: &[&[f32]; INPUTS], out: &mut [f32]) {
    if forces[1..].iter().all(|f| f.is_empty()) {
        match forces[0] {
            [] => bank.ring(out),
            x => bank.process(x, out),
        }
    } else {
        bank.process_inputs(forces, out);
    }
}

/// No contact point yet.
const NO_KEY: u32 = u32::MAX;

impl Voice {
    /// Drops every scheduled force.
    fn clear_force(&mut self) {
        let cap = self.cap;
        for (i, &p) in self.input_pending.iter().enumerate() {
            let Some(ring) = self.force.get_mut(i * cap..(i + 1) * cap) else {
                continue;
            };
            for k in 0..p.min(cap) {
                ring[(self.head + k) % cap] = 0.0;
            }
        }
        self.pending = 0;
        self.input_pending = [0; INPUTS];
        self.keys = [NO_KEY; INPUTS];
    }

    /// Adds `force × scale` to input `input`'s ring from `delay` samples on; what does not fit
    /// is cut off. Returns the samples scheduled.
    fn schedule(&mut self, input: usize, force: &[f32], scale: f64, delay: usize) -> usize {
        let cap = self.cap;
        let Some(ring) = self.force.get_mut(input * cap..(input + 1) * cap) else {
            return 0;
        };
        let len = force.len().min(cap.saturating_sub(delay));
        for (n, &f) in force[..len].iter().enumerate() {
            ring[(self.head + delay + n) % cap] += (f64::from(f) * scale) as f32;
        }
        self.input_pending[input] = self.input_pending[input].max(delay + len);
        self.pending = self.pending.max(delay + len);
        len
    }

    /// Moves the next `n` samples of each input that has force coming into `scratch` (input `i`
    /// at `i × stride`), clears them from the rings and advances the clock. Returns the forces
    /// (empty for an input with none).
    fn take<'a>(&mut self, n: usize, scratch: &'a mut [f32], stride: usize) -> [&'a [f32]; INPUTS] {
        let cap = self.cap;
        let mut forces: [&[f32]; INPUTS] = [&[]; INPUTS];
        let mut rest = scratch;
        for (i, f) in forces.iter_mut().enumerate() {
            let at = stride.min(rest.len());
            let (mine, next) = std::mem::take(&mut rest).split_at_mut(at);
            rest = next;
            if self.input_pending[i] == 0 {
                continue;
            }
            let Some(ring) = self.force.get_mut(i * cap..(i + 1) * cap) else {
                continue;
            };
            let x = &mut mine[..n];
            for (k, xk) in x.iter_mut().enumerate() {
                let j = (self.head + k) % cap;
                *xk = ring[j];
                ring[j] = 0.0;
            }
            self.input_pending[i] = self.input_pending[i].saturating_sub(n);
            *f = x;
        }
        self.head = (self.head + n) % cap;
        self.pending = self.pending.saturating_sub(n);
        forces
    }
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
    /// Contact inputs per voice, 1..=[`INPUTS`]: forces at this many points of one object can
    /// overlap in time, each through its own gains ([`Engine::excite_at`]). Each input holds a
    /// force ring of the force capacity.
    pub inputs: usize,
    /// Modes quieter than this (output amplitude) with no force coming are culled.
    pub cull_level: f32,
    /// Longest block [`Engine::process`] and [`Engine::process_voices`] render at once (longer
    /// requests are split), samples: the scratch allocated up front.
    pub max_block: usize,
}

impl Default for EngineParams {
    fn default() -> Self {
        Self {
            sample_rate_hz: 48_000.0,
            voices: 16,
            modes_per_voice: 256,
            force_capacity: 48_000,
            inputs: 1,
            cull_level: 1e-6,
            max_block: crate::MAX_BLOCK,
        }
    }
}

/// A polyphonic modal synthesizer.
#[derive(Debug)]
pub struct Engine {
    voices: Vec<Voice>,
    scratch: Vec<f32>,
    out: Vec<f32>,
    generation: u64,
    params: EngineParams,
    /// Most voices rendered at once ([`Engine::set_voice_budget`]).
    budget: usize,
    /// Scratch for ranking voices by level (allocated up front).
    rank: Vec<(f32, usize)>,
    /// Voices faded out by the budget so far.
    steals: u64,
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
        if !(1..=INPUTS).contains(&params.inputs) {
            return Err(SynthError::Parameter(format!(
                "inputs must be in 1..={INPUTS}, got {}",
                params.inputs
            )));
        }
        if params.max_block == 0 || params.max_block > 1 << 20 {
            return Err(SynthError::Parameter(format!(
                "max block must be in 1..=1048576 samples, got {}",
                params.max_block
            )));
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
                force: vec![0.0; params.force_capacity * params.inputs],
                cap: params.force_capacity,
                head: 0,
                pending: 0,
                input_pending: [0; INPUTS],
                keys: [NO_KEY; INPUTS],
                importance: 1.0,
                generation: 0,
                busy: false,
                pinned: false,
                tag: 0,
                fading: false,
            });
        }
        Ok(Self {
            voices,
            scratch: vec![0.0; params.max_block * params.inputs],
            out: vec![0.0; params.max_block],
            generation: 0,
            budget: usize::MAX,
            rank: Vec::with_capacity(params.voices),
            steals: 0,
            params,
        })
    }

    /// Settings.
    pub fn params(&self) -> &EngineParams {
        &self.params
    }

    /// Renders at most `budget` voices at once (overload): when more sound, the quietest
    /// (current level × importance) fade out over one block and fall silent, attached ones
    /// included (they wake at their next excitation). `usize::MAX`: no budget. Never allocates.
    pub fn set_voice_budget(&mut self, budget: usize) {
        self.budget = budget.max(1);
    }

    /// The voice budget.
    pub fn voice_budget(&self) -> usize {
        self.budget
    }

    /// Culls modes quieter than `level` (output amplitude) in every voice from now on.
    pub fn set_cull_level(&mut self, level: f32) {
        for v in &mut self.voices {
            v.bank.set_cull_level(level);
        }
    }

    /// Voices faded out by the budget so far.
    pub fn steals(&self) -> u64 {
        self.steals
    }

    /// Voices currently rendering (busy and not silent).
    pub fn sounding_voices(&self) -> usize {
        self.voices
            .iter()
            .filter(|v| v.busy && !(v.pending == 0 && v.bank.is_silent()))
            .count()
    }

    /// Marks the quietest sounding voices beyond the budget for a fade-out.
    fn enforce_budget(&mut self) {
        self.rank.clear();
        for (i, v) in self.voices.iter().enumerate() {
            if v.busy && !v.fading && !(v.pending == 0 && v.bank.is_silent()) {
                self.rank.push((v.bank.level() * v.importance, i));
            }
        }
        if self.rank.len() <= self.budget {
            return;
        }
        let cut = self.rank.len() - self.budget;
        // The `cut` quietest go (select_nth_unstable_by does not allocate).
        self.rank
            .select_nth_unstable_by(cut - 1, |a, b| a.0.total_cmp(&b.0));
        for &(_, i) in &self.rank[..cut] {
            self.voices[i].fading = true;
            self.steals += 1;
        }
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
                let mut best = None;
                let mut lowest = f32::INFINITY;
                for (i, v) in self.voices.iter().enumerate().filter(|(_, v)| !v.pinned) {
                    let p = v.bank.level() * v.importance;
                    if best.is_none() || p < lowest {
                        lowest = p;
                        best = Some(i);
                    }
                }
                // ok_or_else: the error's String must not be built (allocated) on success.
                best.ok_or_else(|| {
                    SynthError::Parameter("every voice is attached; none can be stolen".into())
                })?
            }
        };
        self.start_in(slot, modes, importance, slot, false)
    }

    /// Attaches an object for good (a scene body): a free voice that is never stolen and never
    /// freed when silent, so `excite` always reaches it. `tag` comes back with its blocks from
    /// [`Engine::process_voices`].
    ///
    /// # Errors
    /// No free voice; more modes than a voice holds.
    pub fn attach(&mut self, modes: &[BankMode], tag: usize) -> Result<VoiceId, SynthError> {
        let slot = self
            .voices
            .iter()
            .position(|v| !v.busy)
            .ok_or_else(|| SynthError::Parameter("no free voice to attach".into()))?;
        self.start_in(slot, modes, 1.0, tag, true)
    }

    fn start_in(
        &mut self,
        slot: usize,
        modes: &[BankMode],
        importance: f32,
        tag: usize,
        pinned: bool,
    ) -> Result<VoiceId, SynthError> {
        let v = &mut self.voices[slot];
        v.bank.configure(modes)?;
        v.head = 0;
        v.clear_force();
        v.importance = importance.max(0.0);
        self.generation += 1;
        v.generation = self.generation;
        v.busy = true;
        v.pinned = pinned;
        v.fading = false;
        v.tag = tag;
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

    /// Schedules `force` (N per sample) on voice `id` through input 0 (the gains the voice was
    /// started with, or [`Engine::set_gains`]'), starting `delay` samples after the start of
    /// the next block. Forces add up. Returns false if the voice is gone or the pulse does not
    /// fit the force capacity.
    pub fn excite(&mut self, id: VoiceId, force: &[f32], delay: usize) -> bool {
        if !self.is_alive(id) || delay + force.len() > self.params.force_capacity {
            return false;
        }
        self.voices[id.slot].schedule(0, force, 1.0, delay) == force.len()
    }

    /// Adds `force × scale` (N per sample; the product in f64) to voice `id` through input 0
    /// from `delay` samples after the start of the next block on; what does not fit the force
    /// capacity is cut off. Returns the samples scheduled (0 if the voice is gone).
    pub fn excite_scaled(&mut self, id: VoiceId, force: &[f32], scale: f64, delay: usize) -> usize {
        if !self.is_alive(id) {
            return 0;
        }
        self.voices[id.slot].schedule(0, force, scale, delay)
    }

    /// Adds `force × scale` (as [`Engine::excite_scaled`]) acting at contact point `key` (a
    /// vertex), whose per-mode `gains` (indexed as the voice's modes) it sounds through. The
    /// force takes the input that already carries `key`, else a free one, so forces at
    /// different points that overlap in time keep their own gains; when every input is busy
    /// with other points, the one whose force ends first takes the new point's gains (what is
    /// left of its force sounds through them). Returns the samples scheduled (0 if the voice
    /// is gone). Never allocates.
    pub fn excite_at(
        &mut self,
        id: VoiceId,
        key: u32,
        gains: &[f64],
        force: &[f32],
        scale: f64,
        delay: usize,
    ) -> usize {
        if !self.is_alive(id) {
            return 0;
        }
        let inputs = self.params.inputs;
        let v = &mut self.voices[id.slot];
        let busy = |i: &usize| v.input_pending[*i] > 0;
        let input = (0..inputs)
            .find(|i| busy(i) && v.keys[*i] == key)
            .or_else(|| (0..inputs).find(|i| !busy(i)))
            .or_else(|| (0..inputs).min_by_key(|&i| v.input_pending[i]))
            .unwrap_or(0);
        v.keys[input] = key;
        v.bank.set_input_gains(input, gains);
        v.schedule(input, force, scale, delay)
    }

    /// Gives voice `id` new modes (at most the voice's capacity), silent until its next
    /// excitation; forces already scheduled are dropped. False if the voice is gone or the
    /// modes do not fit. Never allocates.
    pub fn reconfigure(&mut self, id: VoiceId, modes: &[BankMode]) -> bool {
        if !self.is_alive(id) {
            return false;
        }
        let v = &mut self.voices[id.slot];
        if v.bank.configure(modes).is_err() {
            return false;
        }
        v.clear_force();
        v.fading = false;
        true
    }

    /// Sets a voice's contact damping, an added loss factor η (see
    /// [`crate::bank::ModalBank::set_extra_loss`]). Never allocates.
    pub fn set_extra_loss(&mut self, id: VoiceId, eta: f64) -> bool {
        if !self.is_alive(id) {
            return false;
        }
        self.voices[id.slot].bank.set_extra_loss(eta);
        true
    }

    /// Changes a voice's per-mode gains on input 0 (a moving contact; forces already
    /// scheduled on input 0 sound through them too — [`Engine::excite_at`] keeps each point's).
    pub fn set_gains(&mut self, id: VoiceId, gains: &[f64]) -> bool {
        if !self.is_alive(id) {
            return false;
        }
        self.voices[id.slot].bank.set_gains(gains);
        true
    }

    /// Renders the next block, adding into `out` (any length; internally in blocks of
    /// [`crate::MAX_BLOCK`]). Voices that have gone silent with no force pending are freed,
    /// except attached ones ([`Engine::attach`]), which wait for their next excitation.
    pub fn process(&mut self, out: &mut [f32]) {
        let max_block = self.params.max_block;
        for block in out.chunks_mut(max_block) {
            let n = block.len();
            for v in self.voices.iter_mut().filter(|v| v.busy) {
                // A silent attached voice waits for its next excitation (its force clock runs on).
                if v.pinned && v.pending == 0 && v.bank.is_silent() {
                    v.head = (v.head + n) % v.cap;
                    continue;
                }
                let forces = v.take(n, &mut self.scratch, max_block);
                render(&mut v.bank, &forces, block);
                if v.pending == 0 && v.bank.is_silent() && !v.pinned {
                    v.busy = false;
                }
            }
        }
    }

    /// Renders the next `n` samples voice by voice: each voice that sounds hands its block to
    /// `each(tag, offset, block)` (`offset` within the `n` samples; blocks of at most
    /// `max_block`), so the caller can place every source on its own (a spatializer). A voice
    /// with nothing pending that is silent is skipped (its force clock still advances); a
    /// voice that is silent after its block is not handed out. Unpinned voices that went
    /// silent are freed. Never allocates.
    pub fn process_voices(&mut self, n: usize, each: &mut dyn FnMut(usize, usize, &[f32])) {
        let max_block = self.params.max_block;
        let mut offset = 0;
        while offset < n {
            let len = (n - offset).min(max_block);
            if self.budget < self.voices.len() {
                self.enforce_budget();
            }
            for v in self.voices.iter_mut().filter(|v| v.busy) {
                if v.pending == 0 && v.bank.is_silent() {
                    v.head = (v.head + len) % v.cap;
                    if !v.pinned {
                        v.busy = false;
                    }
                    continue;
                }
                let forces = v.take(len, &mut self.scratch, max_block);
                let out = &mut self.out[..len];
                out.fill(0.0);
                render(&mut v.bank, &forces, out);
                if v.fading {
                    // Stolen: a linear fade over this block (no step), then silence.
                    let step = 1.0 / len as f32;
                    for (i, o) in out.iter_mut().enumerate() {
                        *o *= 1.0 - (i + 1) as f32 * step;
                    }
                    v.bank.reset();
                    v.clear_force();
                    v.fading = false;
                    if !v.pinned {
                        v.busy = false;
                    }
                    each(v.tag, offset, out);
                    continue;
                }
                if v.bank.is_silent() {
                    if !v.pinned && v.pending == 0 {
                        v.busy = false;
                    }
                    continue;
                }
                each(v.tag, offset, out);
            }
            offset += len;
        }
    }
}
