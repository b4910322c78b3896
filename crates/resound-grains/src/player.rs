//! Grains retargeted to contacts (Picard §4.2), in real time and without allocating.
//!
//! - **Impacts** start a *phrase* at the force peak: an onset grain of an impulsive recording
//!   (chosen at random, weighted by its power), continued along that recording's pattern like
//!   [`crate::resynth`] does, until the walk reaches the next onset (the next event of the
//!   recording) or two seconds. Its level is `gain · J / J_ref` (impulse over 0.1 N·s), the
//!   onset grain normalized to the dictionary's median onset level.
//! - **Continuous contacts** (rolling, sliding) run two *streams* while they last: the
//!   sinusoidal and the transient part of a recording of that contact (a rolling recording for
//!   rolling, sliding for sliding, any continuous one when the dictionary has none of the kind),
//!   each walking its pattern and looping at its end. Grains follow one another at their own
//!   pace, whatever the physics step. Each grain starts at the level `gain · P / P_ref`, P the
//!   contact power (normal force × relative speed, P_ref = 1 W). Sinusoidal grains are
//!   frequency-scaled by `(v / v_ref)^0.5` (clamped to 0.5–2, v_ref = 1 m/s) — faster is higher;
//!   transient grains are played as recorded.
//! - When a contact ends no new grain starts; the grains under way play out.

use crate::resynth::pick;
use crate::{Contact, Dictionary, GrainError, Part};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};
use std::sync::Arc;

/// Most grains sounding at once per player (more are skipped).
pub const MAX_PLAYING: usize = 96;
/// Most impact phrases at once per player (more are skipped).
pub const MAX_PHRASES: usize = 16;

/// Retargeting settings.
#[derive(Clone, Debug, PartialEq)]
pub struct PlayerParams {
    /// Overall gain.
    pub gain: f64,
    /// Impulse of an impact that plays at the recorded level, N·s.
    pub reference_impulse_n_s: f64,
    /// Contact power that plays continuous grains at the recorded level, W.
    pub reference_power_w: f64,
    /// Sliding/rolling speed at which sinusoidal grains keep their pitch, m/s.
    pub reference_speed_m_s: f64,
    /// Exponent of the pitch factor `(v / v_ref)^e`.
    pub rate_exponent: f64,
    /// Grain choice variation (see [`crate::resynth::ResynthParams::variation`]).
    pub variation: f64,
    /// Longest impact phrase, s.
    pub max_phrase_s: f64,
    /// Seed.
    pub seed: u64,
}

impl Default for PlayerParams {
    fn default() -> Self {
        Self {
            gain: 1.0,
            reference_impulse_n_s: 0.1,
            reference_power_w: 1.0,
            reference_speed_m_s: 1.0,
            rate_exponent: 0.5,
            variation: 0.3,
            max_phrase_s: 2.0,
            seed: 1,
        }
    }
}

#[derive(Clone, Copy, Debug)]
struct Playing {
    grain: u32,
    /// Source position at the start of the next block (negative: not started yet).
    pos: f64,
    /// Source samples per output sample.
    rate: f64,
    gain: f32,
}

#[derive(Clone, Copy, Debug)]
struct Walk {
    pattern: usize,
    /// Source time where the next grain is looked up.
    look: f64,
    /// Output samples from the start of the next block until the next grain may start.
    wait: f64,
    amplitude: f32,
    rate: f64,
    first: bool,
    /// Output samples played so far.
    played: f64,
    /// A grain to start with (an impact's onset grain).
    start: Option<u32>,
}

/// Plays a dictionary's grains for one body's contacts.
pub struct GrainPlayer {
    dict: Arc<Dictionary>,
    params: PlayerParams,
    /// Source samples per output sample at the recorded pitch.
    base_rate: f64,
    rng: SmallRng,
    playing: Vec<Playing>,
    phrases: Vec<Walk>,
    /// Onset grains for impacts, with cumulative power weights and normalizing gains.
    onsets: Vec<(u32, f64, f32)>,
    /// Pattern of each grain's own recording part.
    own_pattern: Vec<usize>,
    /// Half the median grain length per part (source samples): impulsive, sinusoidal, transient.
    half: [f64; 3],
    /// Continuous streams (sinusoidal, transient) while a contact lasts.
    streams: [Option<Walk>; 2],
    contact: Option<(Contact, f32, f64)>,
}

impl std::fmt::Debug for GrainPlayer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "GrainPlayer({} grains, {} playing)",
            self.dict.grains.len(),
            self.playing.len()
        )
    }
}

use crate::player_part_index as part_index;

impl GrainPlayer {
    /// A player at output rate `sample_rate_hz` (grains at another rate are resampled on the
    /// fly).
    ///
    /// # Errors
    /// [`GrainError::Dictionary`] for an inconsistent dictionary, [`GrainError::Param`] for
    /// absurd settings.
    pub fn new(
        dict: Arc<Dictionary>,
        sample_rate_hz: f64,
        params: PlayerParams,
    ) -> Result<Self, GrainError> {
        dict.validate()?;
        let pos = |v: f64| v.is_finite() && v > 0.0;
        if !(pos(sample_rate_hz)
            && params.gain.is_finite()
            && params.gain >= 0.0
            && pos(params.reference_impulse_n_s)
            && pos(params.reference_power_w)
            && pos(params.reference_speed_m_s)
            && params.rate_exponent.is_finite()
            && (0.0..=1.0).contains(&params.variation)
            && pos(params.max_phrase_s))
        {
            return Err(GrainError::Param(format!(
                "unusable grain player settings {params:?} at {sample_rate_hz} Hz"
            )));
        }
        let mut own_pattern = vec![usize::MAX; dict.grains.len()];
        for (i, g) in dict.grains.iter().enumerate() {
            if let Some((k, _)) = dict
                .patterns
                .iter()
                .enumerate()
                .find(|(_, p)| p.recording == g.recording && p.part == g.part)
            {
                own_pattern[i] = k;
            }
        }
        let rms = |g: &crate::Grain| {
            (g.samples.iter().map(|&v| f64::from(v).powi(2)).sum::<f64>() / g.samples.len() as f64)
                .sqrt()
        };
        let mut onsets: Vec<(u32, f64, f32)> = Vec::new();
        for part in [Part::Impulsive, Part::Transient] {
            onsets = dict
                .grains_of(part)
                .filter(|(i, g)| g.onset && own_pattern[*i] != usize::MAX && rms(g) > 0.0)
                .map(|(i, g)| (i as u32, rms(g), 0.0))
                .collect();
            if !onsets.is_empty() {
                break;
            }
        }
        let mut levels: Vec<f64> = onsets.iter().map(|o| o.1).collect();
        levels.sort_by(f64::total_cmp);
        let median = levels.get(levels.len() / 2).copied().unwrap_or(1.0);
        let mut acc = 0.0;
        for o in &mut onsets {
            o.2 = (median / o.1) as f32;
            acc += o.1 * o.1;
            o.1 = acc;
        }
        let half = [Part::Impulsive, Part::Sinusoidal, Part::Transient]
            .map(|p| (dict.median_len(p) as f64 / 2.0).max(1.0));
        Ok(Self {
            base_rate: dict.sample_rate_hz / sample_rate_hz,
            rng: SmallRng::seed_from_u64(params.seed),
            playing: Vec::with_capacity(MAX_PLAYING),
            phrases: Vec::with_capacity(MAX_PHRASES),
            onsets,
            own_pattern,
            half,
            streams: [None, None],
            contact: None,
            params,
            dict,
        })
    }

    /// An impact of impulse `impulse_n_s` whose force peaks `at_sample` samples into the next
    /// block.
    pub fn impact(&mut self, at_sample: usize, impulse_n_s: f64) {
        let Some(total) = self.onsets.last().map(|o| o.1) else {
            return;
        };
        if self.phrases.len() >= MAX_PHRASES || !(impulse_n_s > 0.0) {
            return;
        }
        let u = self.rng.random::<f64>() * total;
        let k = self
            .onsets
            .partition_point(|o| o.1 < u)
            .min(self.onsets.len() - 1);
        let (g, _, norm) = self.onsets[k];
        let grain = &self.dict.grains[g as usize];
        self.phrases.push(Walk {
            pattern: self.own_pattern[g as usize],
            look: f64::from(grain.start),
            // The attack (after the fade-in) lands on the force peak.
            wait: (at_sample as f64 - f64::from(grain.fade_in) / self.base_rate).max(0.0),
            amplitude: (self.params.gain * impulse_n_s / self.params.reference_impulse_n_s) as f32
                * norm,
            rate: self.base_rate,
            first: true,
            played: 0.0,
            start: Some(g),
        });
    }

    /// The continuous contact during the next block: its kind, power (W) and speed (m/s), or
    /// `None` when there is none.
    pub fn set_contact(&mut self, contact: Option<(Contact, f64, f64)>) {
        let Some((kind, power, speed)) = contact else {
            self.contact = None;
            self.streams = [None, None];
            return;
        };
        let amplitude = (self.params.gain * power.max(0.0) / self.params.reference_power_w) as f32;
        let pitch = (speed.max(0.0) / self.params.reference_speed_m_s)
            .powf(self.params.rate_exponent)
            .clamp(0.5, 2.0);
        let changed = self.contact.is_none_or(|c| c.0 != kind);
        self.contact = Some((kind, amplitude, pitch));
        for (s, part) in [Part::Sinusoidal, Part::Transient].into_iter().enumerate() {
            let rate = if part == Part::Sinusoidal {
                self.base_rate * pitch
            } else {
                self.base_rate
            };
            if changed || self.streams[s].is_none() {
                self.streams[s] = self.choose_pattern(kind, part).map(|pattern| Walk {
                    pattern,
                    look: 0.0,
                    wait: 0.0,
                    amplitude,
                    rate,
                    first: true,
                    played: 0.0,
                    start: None,
                });
                // Start somewhere inside the recording.
                if let Some(w) = &mut self.streams[s] {
                    let len = f64::from(self.dict.patterns[w.pattern].len);
                    w.look = self.rng.random::<f64>() * len * 0.5;
                }
            }
            if let Some(w) = &mut self.streams[s] {
                w.amplitude = amplitude;
                w.rate = rate;
            }
        }
    }

    fn choose_pattern(&mut self, kind: Contact, part: Part) -> Option<usize> {
        let dict = &self.dict;
        let matching = |exact: bool| {
            dict.patterns.iter().enumerate().filter(move |(_, p)| {
                let c = dict.recordings[p.recording as usize].contact;
                p.part == part
                    && !p.peaks.is_empty()
                    && if exact { c == kind } else { c.is_continuous() }
            })
        };
        let count = matching(true).count();
        let (exact, count) = if count > 0 {
            (true, count)
        } else {
            (false, matching(false).count())
        };
        if count == 0 {
            return None;
        }
        let k = self.rng.random_range(0..count);
        matching(exact).nth(k).map(|(i, _)| i)
    }

    /// Whether nothing is playing or about to.
    pub fn is_silent(&self) -> bool {
        self.playing.is_empty()
            && self.phrases.is_empty()
            && self.streams.iter().all(Option::is_none)
    }

    /// Adds the next `out.len()` samples to `out`.
    pub fn process(&mut self, out: &mut [f32]) {
        let n = out.len() as f64;
        let fs_src = self.dict.sample_rate_hz;
        let max_phrase = self.params.max_phrase_s * fs_src / self.base_rate;
        let variation = self.params.variation;
        let mut i = 0;
        while i < self.phrases.len() {
            let alive = advance(
                &self.dict,
                &mut self.phrases[i],
                n,
                &mut self.playing,
                &mut self.rng,
                variation,
                &self.half,
                Some(max_phrase),
            );
            if alive {
                i += 1;
            } else {
                self.phrases.swap_remove(i);
            }
        }
        for s in 0..2 {
            if let Some(w) = &mut self.streams[s] {
                if !advance(
                    &self.dict,
                    w,
                    n,
                    &mut self.playing,
                    &mut self.rng,
                    variation,
                    &self.half,
                    None,
                ) {
                    self.streams[s] = None;
                }
            }
        }
        let mut k = 0;
        while k < self.playing.len() {
            let p = &mut self.playing[k];
            let g = &self.dict.grains[p.grain as usize].samples;
            let len = g.len();
            let mut done = false;
            for (j, o) in out.iter_mut().enumerate() {
                let s = p.pos + j as f64 * p.rate;
                if s < 0.0 {
                    continue;
                }
                let i0 = s as usize;
                if i0 >= len {
                    done = true;
                    break;
                }
                let frac = (s - i0 as f64) as f32;
                let a = g[i0];
                let b = if i0 + 1 < len { g[i0 + 1] } else { 0.0 };
                *o += p.gain * (a + frac * (b - a));
            }
            p.pos += n * p.rate;
            if done || p.pos >= len as f64 {
                self.playing.swap_remove(k);
            } else {
                k += 1;
            }
        }
    }
}

/// Starts the walk's grains that begin within the next `n` output samples; false when it ends.
#[allow(clippy::too_many_arguments)]
fn advance(
    dict: &Dictionary,
    w: &mut Walk,
    n: f64,
    playing: &mut Vec<Playing>,
    rng: &mut SmallRng,
    variation: f64,
    half: &[f64; 3],
    phrase_limit: Option<f64>,
) -> bool {
    let pattern = &dict.patterns[w.pattern];
    let h = half[part_index(pattern.part)];
    let mut guard = 0;
    while w.wait < n {
        guard += 1;
        if guard > 10_000 {
            return false;
        }
        let forced = w.start.take().map(|g| crate::Peak {
            grain: g,
            time: dict.grains[g as usize].start,
            corr: 1.0,
            gain: 1.0,
        });
        let peak = match forced.or_else(|| pick(pattern, w.look, h, variation, rng).copied()) {
            Some(p) => p,
            None if phrase_limit.is_none() && w.look > 0.0 => {
                // Continuous streams loop.
                w.look = 0.0;
                continue;
            }
            None => return false,
        };
        let g = &dict.grains[peak.grain as usize];
        if let Some(limit) = phrase_limit {
            if (!w.first && g.onset) || w.played > limit {
                return false;
            }
        }
        let delay = w.wait + (f64::from(peak.time) - w.look) / w.rate;
        if playing.len() < MAX_PLAYING {
            playing.push(Playing {
                grain: peak.grain,
                pos: -delay * w.rate,
                rate: w.rate,
                gain: peak.gain * w.amplitude,
            });
        }
        let step = (g.samples.len() - g.fade_out as usize).max(1) as f64;
        w.look = f64::from(peak.time) + step;
        w.wait = delay + step / w.rate;
        w.played += step / w.rate;
        w.first = false;
    }
    w.wait -= n;
    true
}
