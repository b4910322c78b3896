//! Ren 2013 §6: the residual — what a recording holds beyond what the estimated modes represent —
//! its transfer to other objects and hit points, and its reconstruction. (Its computation,
//! §6.1, is `resound_estimate::residual`; the STFT and Griffin–Lim are `resound_signal::sine_stft`.)
//!
//! **Transfer (§6.2, Algorithm 1).** Source and target modes are paired: by index when the target
//! is the source object (or a scaled copy: natural correspondence), otherwise the `N` dominant
//! modes of each side (perceptual weight, as in the estimator) paired from low to high. Each
//! pair owns a band on either side, between the midpoints to its neighbours. A target pixel
//! `(t, f)` in pair k's band takes the source pixel at `f_s = f_k^s + (f − f_k^t)·(band ratio)`
//! (a shift of the mode frequency, the band stretched piecewise-linearly so that bands stitch
//! without gaps) and `t_s = t · d_k^t / d_k^s` (time stretched by the damping ratio), times the
//! pixel scale. For a damped sinusoid the shifted, stretched source mode's power spectrogram
//! differs from the target mode's at every pixel by the same factor `(a_k^t / a_k^s)²` (the
//! envelopes `e^{−2dt}` coincide after the stretch; the window's spectral shape moves with the
//! shift), so FindPixelScale is that constant — no per-pixel division of tiny numbers.
//!
//! **Reconstruction.** Griffin–Lim from the transferred magnitudes, started from the
//! transferred source phases; the fast variant (Perraudin, Balazs & Søndergaard 2013: momentum
//! 0.99) by default, 10 iterations as in the paper. Sine (√Hann) windows of about 21 ms, hop W/2.

use realfft::num_complex::Complex32;
use resound_core::{DampedMode, Residual};
use resound_signal::psycho::perceptual_weight;
/// The transfer's reconstruction settings (re-exported: a parameter of [`ResidualSource::transfer`]).
pub use resound_signal::sine_stft::GriffinLim;
use resound_signal::sine_stft::{griffin_lim_in, window_len_for, GlWorkspace, Stft};

/// How source and target modes are paired.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pairing {
    /// By index: the target is the source object or a scaled copy.
    Natural,
    /// The N dominant modes of each side, paired from low to high frequency.
    Dominant(usize),
}

/// A residual prepared for transfer: its STFT, computed once per material (Ren: "cache what does
/// not change between events").
#[derive(Debug)]
pub struct ResidualSource {
    sample_rate_hz: f64,
    stft: Stft,
    frames: usize,
    power: Vec<f32>,
    phase: Vec<Complex32>,
    modes: Vec<DampedMode>,
    samples: usize,
    magnitude: Vec<f32>,
    ws: GlWorkspace,
}

/// One source–target mode pair with its bands.
#[derive(Clone, Copy, Debug)]
struct Pair {
    fs: f64,
    ft: f64,
    lo_s: f64,
    hi_s: f64,
    lo_t: f64,
    hi_t: f64,
    stretch: f64,
    scale: f32,
}

impl ResidualSource {
    /// Prepares `residual` for transfer.
    pub fn new(residual: &Residual) -> Self {
        let mut stft = Stft::new(window_len_for(residual.sample_rate_hz));
        let mut spec = Vec::new();
        stft.forward(&residual.samples, &mut spec);
        let frames = spec.len() / stft.bins();
        let power = spec.iter().map(|c| c.norm_sqr()).collect();
        let phase = spec
            .iter()
            .map(|c| {
                let n = c.norm();
                if n > 0.0 {
                    *c / n
                } else {
                    Complex32::new(1.0, 0.0)
                }
            })
            .collect();
        let mut modes = residual.source_modes.clone();
        modes.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
        Self {
            sample_rate_hz: residual.sample_rate_hz,
            stft,
            frames,
            power,
            phase,
            modes,
            samples: residual.samples.len(),
            magnitude: Vec::new(),
            ws: GlWorkspace::default(),
        }
    }

    /// Sample rate of the residual (and of what [`ResidualSource::transfer`] returns).
    pub fn sample_rate_hz(&self) -> f64 {
        self.sample_rate_hz
    }

    fn pairs(&self, target: &[DampedMode], pairing: Pairing) -> Vec<Pair> {
        let mut t: Vec<DampedMode> = target.to_vec();
        t.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
        let (s, t): (Vec<DampedMode>, Vec<DampedMode>) = match pairing {
            Pairing::Natural => {
                let k = self.modes.len().min(t.len());
                (self.modes[..k].to_vec(), t[..k].to_vec())
            }
            Pairing::Dominant(n) => {
                let top = |v: &[DampedMode]| {
                    let mut v = v.to_vec();
                    v.sort_by(|a, b| {
                        perceptual_weight(b, 1.0).total_cmp(&perceptual_weight(a, 1.0))
                    });
                    v.truncate(n.max(1));
                    v.sort_by(|a, b| a.freq_hz.total_cmp(&b.freq_hz));
                    v
                };
                let (a, b) = (top(&self.modes), top(&t));
                let k = a.len().min(b.len());
                (a[..k].to_vec(), b[..k].to_vec())
            }
        };
        let nyquist = 0.5 * self.sample_rate_hz;
        let k = s.len();
        (0..k)
            .map(|i| {
                let mid = |v: &[DampedMode], j: usize| 0.5 * (v[j].freq_hz + v[j + 1].freq_hz);
                let (lo_s, hi_s) = (
                    if i == 0 { 0.0 } else { mid(&s, i - 1) },
                    if i + 1 == k { nyquist } else { mid(&s, i) },
                );
                let (lo_t, hi_t) = (
                    if i == 0 { 0.0 } else { mid(&t, i - 1) },
                    if i + 1 == k { nyquist } else { mid(&t, i) },
                );
                let ratio = if s[i].amplitude > 0.0 {
                    (t[i].amplitude / s[i].amplitude).powi(2)
                } else {
                    0.0
                };
                Pair {
                    fs: s[i].freq_hz,
                    ft: t[i].freq_hz,
                    lo_s,
                    hi_s,
                    lo_t,
                    hi_t,
                    stretch: t[i].damping_per_s / s[i].damping_per_s.max(1e-9),
                    scale: ratio as f32,
                }
            })
            .collect()
    }

    /// The transferred magnitudes into `magnitude` and initial cells (magnitude × source phase)
    /// into `cells` (frames × bins); returns the length in samples (0: nothing to transfer).
    fn transfer_into(
        &self,
        target: &[DampedMode],
        pairing: Pairing,
        magnitude: &mut Vec<f32>,
        cells: &mut Vec<Complex32>,
    ) -> usize {
        let pairs = self.pairs(target, pairing);
        let bins = self.stft.bins();
        magnitude.clear();
        cells.clear();
        if pairs.is_empty() || self.frames == 0 {
            return 0;
        }
        // Longest stretch decides the length (at most 4× the source).
        let longest = pairs
            .iter()
            .map(|p| 1.0 / p.stretch.max(1e-9))
            .fold(0.0f64, f64::max)
            .clamp(0.25, 4.0);
        let frames = ((self.frames as f64 * longest).ceil() as usize).max(1);
        magnitude.resize(frames * bins, 0.0);
        cells.resize(frames * bins, Complex32::new(0.0, 0.0));
        let bin_hz = self.sample_rate_hz / self.stft.window_len() as f64;
        let mut p_idx = 0;
        for k in 0..bins {
            let f = k as f64 * bin_hz;
            while p_idx + 1 < pairs.len() && f >= pairs[p_idx].hi_t {
                p_idx += 1;
            }
            let p = &pairs[p_idx];
            // Piecewise-linear band map with the mode frequency fixed to its partner.
            let f_s = if f <= p.ft {
                let w = (p.ft - p.lo_t).max(1e-9);
                p.lo_s + (f - p.lo_t).max(0.0) / w * (p.fs - p.lo_s)
            } else {
                let w = (p.hi_t - p.ft).max(1e-9);
                p.fs + (f - p.ft).min(w) / w * (p.hi_s - p.fs)
            };
            let ks = f_s / bin_hz;
            let k0 = (ks.floor() as usize).min(bins - 1);
            let k1 = (k0 + 1).min(bins - 1);
            let wk = (ks - k0 as f64) as f32;
            let nearest_k = if wk < 0.5 { k0 } else { k1 };
            for m in 0..frames {
                let ms = m as f64 * p.stretch;
                let m0 = ms.floor() as usize;
                if m0 >= self.frames {
                    break;
                }
                let m1 = (m0 + 1).min(self.frames - 1);
                let wm = (ms - m0 as f64) as f32;
                let at = |mm: usize, kk: usize| self.power[mm * bins + kk];
                let v = (1.0 - wm) * ((1.0 - wk) * at(m0, k0) + wk * at(m0, k1))
                    + wm * ((1.0 - wk) * at(m1, k0) + wk * at(m1, k1));
                let mag = (v * p.scale).sqrt();
                let nearest_m = if wm < 0.5 { m0 } else { m1 };
                magnitude[m * bins + k] = mag;
                cells[m * bins + k] = self.phase[nearest_m * bins + nearest_k] * mag;
            }
        }
        ((self.samples as f64 * longest) as usize).max(1)
    }

    /// The transferred power spectrogram (frames × bins) and its length in samples.
    pub fn transfer_spectrogram(
        &self,
        target: &[DampedMode],
        pairing: Pairing,
    ) -> (Vec<f32>, usize) {
        let (mut magnitude, mut cells) = (Vec::new(), Vec::new());
        let samples = self.transfer_into(target, pairing, &mut magnitude, &mut cells);
        (magnitude.iter().map(|m| m * m).collect(), samples)
    }

    /// The residual audio for `target` modes (unit impulse; scale by the impact's impulse).
    /// Buffers are reused between calls.
    pub fn transfer(
        &mut self,
        target: &[DampedMode],
        pairing: Pairing,
        gl: &GriffinLim,
    ) -> Vec<f32> {
        let mut magnitude = std::mem::take(&mut self.magnitude);
        let mut ws = std::mem::take(&mut self.ws);
        let samples = self.transfer_into(target, pairing, &mut magnitude, &mut ws.c);
        let out = if samples <= 1 {
            Vec::new()
        } else {
            griffin_lim_in(&mut self.stft, &magnitude, samples, gl, None, &mut ws);
            ws.x.clone()
        };
        self.magnitude = magnitude;
        self.ws = ws;
        out
    }
}
