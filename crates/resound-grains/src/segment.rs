//! Grains: cut a signal at the rising inflection points of its spectral flux (Picard §3.2).
//!
//! - *Spectral flux* (Dixon 2006, Picard's ref. 8): the half-wave rectified frame-to-frame
//!   increase of the log-compressed magnitude spectrum, `Σ_k max(0, L_m(k) − L_{m−1}(k))`,
//!   `L = ln(1 + λ|X|)`, Hann frames of about 12 ms every quarter frame, smoothed [1 2 1].
//! - *Rising inflection points*: where the flux grows fastest (local maxima of its first
//!   difference). These are the onsets: the flux rises as a new event enters the frame. Each is
//!   placed to the sample by the largest increase of signal energy from the 1.5 ms before it to
//!   the 1.5 ms after it (a ratio would be fooled by the beating tail of the previous event), from half a frame before the inflection to three quarters after it.
//! - *Selection*: inflections stronger than `onset_strength` of the strongest (and 3× the median)
//!   are boundaries, strongest first, at least `min_grain_s` apart; segments still longer than
//!   `max_grain_s` are split at their strongest weaker inflection (or in the middle).
//! - *Windowing*: a Tukey window, taper ratio r (0.02), on each grain. The taper at a boundary is
//!   shared by the two grains that meet there (r/2 of the shorter one, raised cosine): the tapers
//!   are complementary, so the grains of a signal overlap-add back to the signal exactly. At an
//!   onset the shared taper ends at the onset (it lies in the previous event's tail), so an
//!   onset grain keeps its attack whole; elsewhere it is centred on the boundary.
//! - Grains whose power is `min_db` below the loudest grain of the signal are dropped.

use crate::GrainError;
use realfft::RealFftPlanner;

/// Segmentation settings.
#[derive(Clone, Debug, PartialEq)]
pub struct SegmentParams {
    /// Spectral-flux frame, s (rounded up to a power of two in samples).
    pub window_s: f64,
    /// Shortest grain, s.
    pub min_grain_s: f64,
    /// Longest grain, s.
    pub max_grain_s: f64,
    /// Tukey taper ratio r.
    pub taper: f64,
    /// An inflection is an onset when its slope is at least this fraction of the steepest one.
    pub onset_strength: f64,
    /// Grains this far under the loudest grain of their signal are dropped, dB.
    pub min_db: f64,
}

impl Default for SegmentParams {
    fn default() -> Self {
        Self {
            window_s: 0.0116,
            min_grain_s: 0.007,
            max_grain_s: 0.07,
            taper: 0.02,
            onset_strength: 0.1,
            min_db: -50.0,
        }
    }
}

impl SegmentParams {
    /// Checks the settings.
    ///
    /// # Errors
    /// [`GrainError::Param`] naming the absurd value.
    pub fn check(&self) -> Result<(), GrainError> {
        let e = |m: String| Err(GrainError::Param(m));
        if !(self.window_s > 0.0 && self.window_s <= 0.2) {
            return e(format!(
                "flux window must be in (0, 0.2] s, got {}",
                self.window_s
            ));
        }
        let lengths_ok = self.min_grain_s >= 0.001
            && self.max_grain_s >= 2.0 * self.min_grain_s
            && self.max_grain_s <= 2.0;
        if !lengths_ok {
            return e(format!(
                "grain lengths must satisfy 1 ms ≤ min ≤ max/2, max ≤ 2 s (got {} s, {} s)",
                self.min_grain_s, self.max_grain_s
            ));
        }
        if !(0.0..=0.5).contains(&self.taper) {
            return e(format!(
                "taper ratio must be in [0, 0.5], got {}",
                self.taper
            ));
        }
        if !(0.0..1.0).contains(&self.onset_strength) {
            return e(format!(
                "onset strength must be in [0, 1), got {}",
                self.onset_strength
            ));
        }
        if !(self.min_db <= 0.0 && self.min_db >= -200.0) {
            return e(format!(
                "energy threshold must be in [−200, 0] dB, got {}",
                self.min_db
            ));
        }
        Ok(())
    }
}

/// The spectral flux of `x`, one value per frame `m` centred on sample `m · hop`, and the hop.
pub fn spectral_flux(x: &[f32], sample_rate_hz: f64, window_s: f64) -> (Vec<f64>, usize) {
    let w = ((window_s * sample_rate_hz) as usize)
        .next_power_of_two()
        .max(64);
    let hop = w / 4;
    let frames = x.len().div_ceil(hop) + 1;
    let fft = RealFftPlanner::<f32>::new().plan_fft_forward(w);
    let window: Vec<f32> = resound_signal::stft::hann(w)
        .into_iter()
        .map(|v| v as f32)
        .collect();
    let bins = w / 2 + 1;
    let mut frame = fft.make_input_vec();
    let mut spec = fft.make_output_vec();
    let mut scratch = fft.make_scratch_vec();
    let mut mags = vec![0.0f32; frames * bins];
    for m in 0..frames {
        let start = (m * hop) as isize - (w / 2) as isize;
        for (i, f) in frame.iter_mut().enumerate() {
            let j = start + i as isize;
            *f = if j >= 0 && (j as usize) < x.len() {
                x[j as usize] * window[i]
            } else {
                0.0
            };
        }
        // Lengths are right by construction.
        let _ = fft.process_with_scratch(&mut frame, &mut spec, &mut scratch);
        for (o, c) in mags[m * bins..(m + 1) * bins].iter_mut().zip(&spec) {
            *o = c.norm();
        }
    }
    let top = mags.iter().copied().fold(0.0f32, f32::max);
    let lambda = if top > 0.0 { 1e4 / top } else { 0.0 };
    for v in &mut mags {
        *v = (1.0 + lambda * *v).ln();
    }
    let mut flux = vec![0.0f64; frames];
    for m in 1..frames {
        let (a, b) = (
            &mags[(m - 1) * bins..m * bins],
            &mags[m * bins..(m + 1) * bins],
        );
        flux[m] = a
            .iter()
            .zip(b)
            .map(|(&p, &q)| f64::from((q - p).max(0.0)))
            .sum();
    }
    (flux, hop)
}

/// Grain boundaries of `x` (ascending, starting with 0, not including `x.len()`).
pub fn boundaries(x: &[f32], sample_rate_hz: f64, p: &SegmentParams) -> Vec<usize> {
    boundaries_and_onsets(x, sample_rate_hz, p).0
}

/// Grain boundaries and whether each is an onset (a strong inflection, or the signal's start)
/// rather than a split of a long segment.
pub fn boundaries_and_onsets(
    x: &[f32],
    sample_rate_hz: f64,
    p: &SegmentParams,
) -> (Vec<usize>, Vec<bool>) {
    let n = x.len();
    let min_len = ((p.min_grain_s * sample_rate_hz) as usize).max(1);
    let max_len = ((p.max_grain_s * sample_rate_hz) as usize).max(2 * min_len);
    if n <= min_len {
        return (vec![0], vec![true]);
    }
    let (flux, hop) = spectral_flux(x, sample_rate_hz, p.window_s);
    let m = flux.len();
    let smooth: Vec<f64> = (0..m)
        .map(|i| {
            let a = flux[i.saturating_sub(1)];
            let c = flux[(i + 1).min(m - 1)];
            0.25 * (a + 2.0 * flux[i] + c)
        })
        .collect();
    let slope: Vec<f64> = (0..m)
        .map(|i| {
            if i == 0 {
                0.0
            } else {
                smooth[i] - smooth[i - 1]
            }
        })
        .collect();
    // Energy prefix sums for placing onsets to the sample.
    let mut energy = vec![0.0f64; n + 1];
    for (i, &v) in x.iter().enumerate() {
        energy[i + 1] = energy[i] + f64::from(v).powi(2);
    }
    let half = ((0.0015 * sample_rate_hz) as usize).max(8);
    let refine = |center: usize| -> usize {
        let lo = center.saturating_sub(2 * hop).max(half);
        // The flux already rises when an onset enters the right half of a frame.
        let hi = (center + 3 * hop).min(n.saturating_sub(half));
        let mut best = (center.min(n - 1), f64::NEG_INFINITY);
        for t in lo..hi {
            let after = energy[t + half] - energy[t];
            let before = energy[t] - energy[t - half];
            let r = after - before;
            if r > best.1 {
                best = (t, r);
            }
        }
        best.0
    };
    // Rising inflection points: local maxima of the slope.
    let mut candidates: Vec<(f64, usize)> = Vec::new();
    for i in 1..m.saturating_sub(1) {
        if slope[i] > 0.0 && slope[i] >= slope[i - 1] && slope[i] > slope[i + 1] {
            let center = ((i as f64 - 0.5) * hop as f64).max(0.0) as usize;
            if center + 2 * hop >= n {
                // The frame sees the signal's end: a cut, not an onset.
                continue;
            }
            candidates.push((slope[i], refine(center.min(n - 1))));
        }
    }
    candidates.sort_by(|a, b| b.0.total_cmp(&a.0));
    let top = candidates.first().map_or(0.0, |c| c.0);
    let mut strengths: Vec<f64> = candidates.iter().map(|c| c.0).collect();
    strengths.sort_by(f64::total_cmp);
    let median = strengths.get(strengths.len() / 2).copied().unwrap_or(0.0);
    let strong = (p.onset_strength * top).max(3.0 * median);
    let mut bounds: Vec<usize> = vec![0];
    let fits = |bounds: &[usize], b: usize| {
        b >= min_len && b + min_len <= n && bounds.iter().all(|&q| q.abs_diff(b) >= min_len)
    };
    for &(s, b) in &candidates {
        if s >= strong && fits(&bounds, b) {
            bounds.push(b);
        }
    }
    bounds.sort_unstable();
    // Split segments longer than the longest grain.
    let mut out = Vec::with_capacity(bounds.len());
    let mut ends: Vec<usize> = bounds.iter().skip(1).copied().chain([n]).collect();
    ends.reverse();
    let mut start = 0;
    let mut onset = Vec::with_capacity(bounds.len());
    while let Some(end) = ends.pop() {
        if end - start <= max_len {
            out.push(start);
            onset.push(bounds.binary_search(&start).is_ok());
            start = end;
            continue;
        }
        let cut = candidates
            .iter()
            .filter(|&&(_, b)| b >= start + min_len && b + min_len <= end)
            .max_by(|a, b| a.0.total_cmp(&b.0))
            .map_or(start + (end - start) / 2, |c| c.1);
        ends.push(end);
        ends.push(cut);
    }
    (out, onset)
}

/// The Tukey-style window of a grain of `len` samples at sample `i`.
pub fn taper(i: usize, len: usize, fade_in: usize, fade_out: usize) -> f64 {
    let pi = std::f64::consts::PI;
    if i < fade_in {
        0.5 - 0.5 * (pi * (i as f64 + 0.5) / fade_in as f64).cos()
    } else if i + fade_out >= len {
        0.5 - 0.5 * (pi * ((len - i) as f64 - 0.5) / fade_out as f64).cos()
    } else {
        1.0
    }
}

/// A windowed grain cut from a signal.
#[derive(Clone, Debug, PartialEq)]
pub struct Cut {
    /// First sample in the signal.
    pub start: usize,
    /// Windowed samples.
    pub samples: Vec<f32>,
    /// Rising taper, samples.
    pub fade_in: usize,
    /// Falling taper, samples.
    pub fade_out: usize,
    /// Starts at an onset (not at a split of a long segment).
    pub onset: bool,
}

/// The grains of a signal.
#[derive(Clone, Debug, PartialEq)]
pub struct Cutting {
    /// Grains above the energy threshold.
    pub kept: Vec<Cut>,
    /// Grains cut before the threshold.
    pub total: usize,
}

/// Cuts `x` into windowed grains at [`boundaries`] and drops the quiet ones.
pub fn grains(x: &[f32], sample_rate_hz: f64, p: &SegmentParams) -> Cutting {
    let all = cut(x, sample_rate_hz, p);
    let loudest = all.iter().map(Cut::power).fold(0.0, f64::max);
    threshold(all, loudest, p.min_db)
}

/// Cuts `x` into windowed grains at [`boundaries`], all of them.
pub fn cut(x: &[f32], sample_rate_hz: f64, p: &SegmentParams) -> Vec<Cut> {
    let n = x.len();
    if n == 0 {
        return Vec::new();
    }
    let (b, onsets) = boundaries_and_onsets(x, sample_rate_hz, p);
    let mut edges = b.clone();
    edges.push(n);
    let seg: Vec<usize> = edges.windows(2).map(|w| w[1] - w[0]).collect();
    // Crossfade length at each inner edge; the signal's own start and end are kept as they are
    // (a recorded attack is not faded in).
    let fade: Vec<usize> = (0..edges.len())
        .map(|j| {
            if j == 0 || j == edges.len() - 1 {
                return 0;
            }
            let l = seg[j - 1].min(seg[j]);
            ((p.taper * l as f64 / 2.0).round() as usize).max(usize::from(p.taper > 0.0) * 2)
        })
        .collect();
    // Fade regions: [edge − fade/2, edge − fade/2 + fade), clamped into the signal.
    let region = |j: usize| -> usize {
        let f = fade[j];
        if j == 0 {
            0
        } else if j == edges.len() - 1 {
            n
        } else if onsets[j] {
            // Before an onset the crossfade lies in the previous tail: the attack stays whole.
            edges[j] - f
        } else {
            edges[j] - f / 2
        }
    };
    let mut cuts = Vec::with_capacity(seg.len());
    for j in 0..seg.len() {
        let start = region(j);
        let end = (region(j + 1) + fade[j + 1]).min(n);
        let len = end - start;
        let (fi, fo) = (fade[j].min(len / 2), fade[j + 1].min(len / 2));
        let samples = (0..len)
            .map(|i| (f64::from(x[start + i]) * taper(i, len, fi, fo)) as f32)
            .collect();
        cuts.push(Cut {
            start,
            samples,
            fade_in: fi,
            fade_out: fo,
            onset: onsets[j],
        });
    }
    cuts
}

/// Keeps the grains whose power is above `loudest · 10^(min_db/10)` (and not silent).
pub fn threshold(cuts: Vec<Cut>, loudest: f64, min_db: f64) -> Cutting {
    let floor = loudest * 10f64.powf(min_db / 10.0);
    let total = cuts.len();
    let kept = cuts
        .into_iter()
        .filter(|c| c.power() > floor && c.power() > 0.0)
        .collect();
    Cutting { kept, total }
}

impl Cut {
    /// Mean square of the windowed samples.
    pub fn power(&self) -> f64 {
        self.samples
            .iter()
            .map(|&v| f64::from(v).powi(2))
            .sum::<f64>()
            / self.samples.len().max(1) as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::testing::event;
    use rand::SeedableRng;

    #[test]
    fn concatenated_events_are_cut_at_their_offsets() {
        let fs = 44_100.0;
        let mut rng = rand::rngs::SmallRng::seed_from_u64(11);
        let lens = [2100, 2900, 1700, 2500, 3000, 1900, 2300, 2700];
        let mut x = Vec::new();
        let mut offsets = Vec::new();
        for (k, &l) in lens.iter().enumerate() {
            offsets.push(x.len());
            x.extend(event(k, l, fs, &mut rng));
        }
        let b = boundaries(&x, fs, &SegmentParams::default());
        assert_eq!(b.len(), offsets.len(), "{b:?} vs {offsets:?}");
        for (&got, &want) in b.iter().zip(&offsets) {
            assert!(got.abs_diff(want) <= 16, "{b:?} vs {offsets:?}");
        }
    }

    #[test]
    fn grains_overlap_add_back_to_the_signal() {
        let fs = 44_100.0;
        let mut rng = rand::rngs::SmallRng::seed_from_u64(2);
        let x: Vec<f32> = (0..3).flat_map(|k| event(k, 9000, fs, &mut rng)).collect();
        let p = SegmentParams {
            min_db: -200.0,
            ..SegmentParams::default()
        };
        let c = grains(&x, fs, &p);
        assert_eq!(c.kept.len(), c.total);
        assert!(c.total >= 6, "{} grains", c.total);
        let mut y = vec![0.0f32; x.len()];
        for g in &c.kept {
            assert!(g.samples.len() as f64 <= 1.05 * p.max_grain_s * fs);
            for (i, &v) in g.samples.iter().enumerate() {
                y[g.start + i] += v;
            }
        }
        for i in 0..x.len() {
            assert!(
                (y[i] - x[i]).abs() < 1e-5,
                "sample {i}: {} vs {}",
                y[i],
                x[i]
            );
        }
    }

    #[test]
    fn quiet_grains_are_dropped() {
        let fs = 44_100.0;
        let mut rng = rand::rngs::SmallRng::seed_from_u64(4);
        let mut x = event(0, 3000, fs, &mut rng);
        x.extend(vec![1e-6f32; 20_000]);
        let c = grains(&x, fs, &SegmentParams::default());
        assert!(c.total > c.kept.len());
        assert!(c.kept.iter().all(|g| g.start < 3000));
    }
}
