//! Rebuilding recordings from their correlation patterns (Picard §4.1, §4.3).
//!
//! Grains are laid one after another. After a grain, the next is looked up in the pattern from
//! the end of that grain minus its falling taper (the Tukey overlap), within half the median
//! grain length; the candidate with the largest correlation (less 0.1 per half window of delay,
//! which decides between the near-equal matches of a steady sound in favour of the nearest) is
//! placed at its own time index by overlap-add, with the gain that matches its energy to the
//! original's there. Where no peak lies
//! in the window (a quiet stretch whose grains were dropped), the walk jumps to the next peak.
//!
//! *Time-scaling* by α maps output time `o` to source time `o/α`: the lookup starts at
//! `(end − taper)/α` and a candidate `Δ` after it is placed `α·Δ` after the previous grain's
//! overlap, so α > 1 reuses grains to fill the stretch and α < 1 skips some.
//! *Variation* (0…1, seeded) picks at random, weighted by correlation, among the candidates
//! within `variation` of the best one: similar, not identical.

use crate::{Dictionary, GrainError, Pattern, Peak};
use rand::rngs::SmallRng;
use rand::{Rng, SeedableRng};

/// Resynthesis settings.
#[derive(Clone, Debug, PartialEq)]
pub struct ResynthParams {
    /// Time-scale factor α (output length / original length).
    pub time_scale: f64,
    /// 0: the best grain every time; up to 1: random among those within this of the best.
    pub variation: f64,
    /// Seed of the variation.
    pub seed: u64,
}

impl Default for ResynthParams {
    fn default() -> Self {
        Self {
            time_scale: 1.0,
            variation: 0.0,
            seed: 1,
        }
    }
}

impl ResynthParams {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`GrainError::Param`] naming the absurd value.
    pub fn check(&self) -> Result<(), GrainError> {
        if !(self.time_scale >= 0.05 && self.time_scale <= 20.0) {
            return Err(GrainError::Param(format!(
                "time scale must be within 0.05–20, got {}",
                self.time_scale
            )));
        }
        if !(0.0..=1.0).contains(&self.variation) {
            return Err(GrainError::Param(format!(
                "variation must be within 0–1, got {}",
                self.variation
            )));
        }
        Ok(())
    }
}

/// Peaks weaker than this are not walked to: a quiet stretch whose grains were dropped is left
/// quiet rather than filled with a poor match that would overrun the next good one.
pub const WALK_MIN_CORR: f32 = 0.8;

/// The next grain of a pattern walk: candidates (|correlation| ≥ [`WALK_MIN_CORR`]) start in
/// `[look, look + half]`, or, when none does, in the same window from the next such peak on.
/// `None` past the last one.
pub fn pick<'a>(
    pattern: &'a Pattern,
    look: f64,
    half: f64,
    variation: f64,
    rng: &mut SmallRng,
) -> Option<&'a Peak> {
    let peaks = &pattern.peaks;
    let strong = |p: &&Peak| p.corr.abs() >= WALK_MIN_CORR;
    let lo = peaks.partition_point(|p| f64::from(p.time) < look);
    let first = peaks[lo..].iter().find(strong)?;
    let from = if f64::from(first.time) <= look + half {
        look
    } else {
        f64::from(first.time)
    };
    let cands = || {
        peaks[lo..]
            .iter()
            .take_while(move |p| f64::from(p.time) <= from + half)
            .filter(strong)
    };
    // Nearly equal correlations (a steady sound matches itself a period later) are decided
    // by proximity: 0.1 of correlation per half window of delay.
    let score = |p: &Peak| f64::from(p.corr.abs()) - 0.1 * (f64::from(p.time) - from) / half;
    let best = cands().max_by(|a, b| score(a).total_cmp(&score(b)))?;
    if variation <= 0.0 {
        return Some(best);
    }
    let floor = (1.0 - variation as f32) * best.corr.abs();
    let total: f32 = cands()
        .filter(|p| p.corr.abs() >= floor)
        .map(|p| p.corr.abs())
        .sum();
    let mut u = rng.random::<f32>() * total;
    for p in cands().filter(|p| p.corr.abs() >= floor) {
        u -= p.corr.abs();
        if u <= 0.0 {
            return Some(p);
        }
    }
    Some(best)
}

/// Rebuilds one pattern's signal.
///
/// # Errors
/// [`GrainError::Param`] for absurd settings.
pub fn resynthesize_pattern(
    dict: &Dictionary,
    pattern: &Pattern,
    p: &ResynthParams,
) -> Result<Vec<f32>, GrainError> {
    p.check()?;
    let alpha = p.time_scale;
    let half = (dict.median_len(pattern.part) as f64 / 2.0).max(1.0);
    let mut rng = SmallRng::seed_from_u64(p.seed);
    let mut out: Vec<f32> = Vec::new();
    // Output position where the next grain may start (the previous end minus its taper).
    let mut next = 0.0f64;
    loop {
        let look = next / alpha;
        if look >= f64::from(pattern.len) {
            break;
        }
        let Some(peak) = pick(pattern, look, half, p.variation, &mut rng) else {
            break;
        };
        let g = &dict.grains[peak.grain as usize];
        let at = (next + (f64::from(peak.time) - look) * alpha)
            .round()
            .max(0.0) as usize;
        let end = at + g.samples.len();
        if out.len() < end {
            out.resize(end, 0.0);
        }
        for (o, &v) in out[at..end].iter_mut().zip(&g.samples) {
            *o += peak.gain * v;
        }
        next = ((end - g.fade_out as usize) as f64).max(next + 1.0);
    }
    Ok(out)
}

/// Rebuilds a recording: the sum of its parts' resyntheses.
///
/// # Errors
/// [`GrainError::Param`] for absurd settings or an unknown recording.
pub fn resynthesize(
    dict: &Dictionary,
    recording: usize,
    p: &ResynthParams,
) -> Result<Vec<f32>, GrainError> {
    if recording >= dict.recordings.len() {
        return Err(GrainError::Param(format!(
            "recording {recording} does not exist (the dictionary has {})",
            dict.recordings.len()
        )));
    }
    let mut out: Vec<f32> = Vec::new();
    for (_, pat) in dict.patterns_of(recording) {
        let part = resynthesize_pattern(dict, pat, p)?;
        if out.len() < part.len() {
            out.resize(part.len(), 0.0);
        }
        for (o, v) in out.iter_mut().zip(part) {
            *o += v;
        }
    }
    Ok(out)
}
